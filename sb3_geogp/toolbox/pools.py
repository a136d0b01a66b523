"""Worker processes for sweeps of runs that Ctrl-C stops at once.

A Ctrl-C in a terminal reaches every process of the foreground group. In a plain
:class:`concurrent.futures.ProcessPoolExecutor` a worker reports its interrupted run as that
run's exception and starts the next one it holds, and leaving the executor's ``with`` block
waits for every queued run: a sweep of quick runs with two workers took 98 s to stop. Here a
worker exits on SIGINT, and the parent cancels what is queued (on any error, not only
Ctrl-C) and, when it is interrupted itself, ends the workers' running tasks (a SIGTERM sent to
the parent alone reaches no worker). A run cut short is lost whole, so a sweep that writes each
run's file at its end, atomically, resumes where it stopped.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing as mp
import os
import signal
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any


@contextlib.contextmanager
def worker_pool(
    workers: int,
    initializer: Callable[..., None] | None = None,
    initargs: tuple[Any, ...] = (),
) -> Iterator[cf.ProcessPoolExecutor]:
    """A pool of ``workers`` spawned processes (no forked torch or OpenMP state).

    Parameters
    ----------
    workers : int
    initializer : callable, optional
        Run in each worker before its first task, with ``initargs``; a module-level function,
        as spawned workers import it.
    initargs : tuple

    Yields
    ------
    concurrent.futures.ProcessPoolExecutor
        When the block raises, the queued tasks are cancelled before the exception goes on;
        on a :class:`KeyboardInterrupt` the workers are also ended in their running tasks
        (the parent alone may have been interrupted: a SIGTERM it turns into one), while a
        task's error re-raised by ``result()`` lets the running tasks finish.
    """
    pool = cf.ProcessPoolExecutor(
        max_workers=workers,
        mp_context=mp.get_context("spawn"),
        initializer=_start_worker,
        initargs=(initializer, initargs),
    )
    try:
        yield pool
    except KeyboardInterrupt:
        # A SIGTERM the parent turned into an interrupt (or a Ctrl-C the workers did not
        # get, as when only the parent is signalled) leaves them in their tasks: leaving
        # would wait for those runs to end.
        _stop_workers(pool)
        raise
    except BaseException:
        _let_running_finish(pool)
        raise
    finally:
        _shutdown(pool)


def _let_running_finish(pool: cf.ProcessPoolExecutor) -> None:
    """Cancel the queued tasks and wait for the running ones, unless interrupted meanwhile."""
    try:
        _shutdown(pool, cancel_futures=True)
    except KeyboardInterrupt:
        _stop_workers(pool)
        raise


def _stop_workers(pool: cf.ProcessPoolExecutor) -> None:
    """End the workers in their running tasks; the executor's thread then fails the tasks
    they held, and shutting down waits for that thread alone."""
    # The executor's own process table: Python 3.14's terminate_workers() reads it too, but
    # does not wait for the executor's thread, which leaves futures pending after the block.
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()
    _shutdown(pool, cancel_futures=True)


def _shutdown(pool: cf.ProcessPoolExecutor, cancel_futures: bool = False) -> None:
    """``pool.shutdown``, also where an interrupt cut ``submit`` between creating the
    executor's thread and starting it (joining the thread then raises)."""
    try:
        pool.shutdown(cancel_futures=cancel_futures)
    except RuntimeError as err:
        if "before it is started" not in str(err):
            raise
        pool.shutdown(wait=False, cancel_futures=True)


def _start_worker(initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
    signal.signal(signal.SIGINT, _exit_interrupted)
    if initializer is not None:
        initializer(*initargs)


def _exit_interrupted(signum: int, frame: FrameType | None) -> None:
    os._exit(128 + signal.SIGINT)
