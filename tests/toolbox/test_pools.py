"""Worker pools that Ctrl-C stops at once: a worker hit by SIGINT exits instead of reporting
its task and starting the next, and an interrupt in the parent cancels the queued tasks."""

from __future__ import annotations

import concurrent.futures.process as cf_process
import os
import signal
import threading
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest

from sb3_geogp.toolbox.pools import worker_pool


def test_workers_run_their_tasks_after_the_initializer(tmp_path: Path) -> None:
    with worker_pool(2, os.chdir, (str(tmp_path),)) as pool:
        assert [f.result() for f in [pool.submit(os.getcwd) for _ in range(3)]] == [
            str(tmp_path)
        ] * 3
        assert pool.submit(pow, 2, 10).result() == 1024


@pytest.mark.parametrize("error", [KeyboardInterrupt, ValueError])
def test_an_error_in_the_parent_cancels_the_queued_tasks(error: type[BaseException]) -> None:
    """One worker, eight tasks of a second: at most the running one and the one handed to the
    worker's queue run; leaving the block does not wait for the rest. (An interrupt also ends
    the running task: its queued tasks are then cancelled or fail with the pool, whichever the
    executor's thread gets to first.)"""
    futures = []
    with pytest.raises(error), worker_pool(1) as pool:
        futures = [pool.submit(time.sleep, 1.0) for _ in range(8)]
        raise error
    assert all(f.done() for f in futures)
    ran = [f for f in futures if not f.cancelled() and f.exception() is None]
    if error is ValueError:
        assert len(ran) <= 2 and sum(f.cancelled() for f in futures) >= 6
    else:
        assert ran == []


def test_a_worker_interrupted_mid_task_exits_instead_of_reporting_it() -> None:
    """A plain pool's worker returns the interrupt as its task's exception (which would
    re-raise ``KeyboardInterrupt`` here) and goes on to its next task."""
    with worker_pool(1) as pool:
        pid = pool.submit(os.getpid).result()
        task = pool.submit(time.sleep, 30.0)
        time.sleep(1.0)  # the worker is inside the task
        os.kill(pid, signal.SIGINT)
        try:
            task.result(timeout=60)
        except BrokenProcessPool:
            pass
        except KeyboardInterrupt:
            pytest.fail("the worker reported its interrupted task instead of exiting")
        else:
            pytest.fail("the task ran to its end")


def _sleep_then_write(seconds: float, path: str) -> None:
    time.sleep(seconds)
    Path(path).write_text("finished")


def test_an_interrupt_of_the_parent_alone_ends_the_running_task(tmp_path: Path) -> None:
    """The parent interrupted while its worker, not signalled, is inside a task (a SIGTERM
    sent to the parent, which the commands turn into an interrupt): leaving the block ends the
    worker in its task instead of waiting for it to write its file."""
    done = tmp_path / "done"
    with pytest.raises(KeyboardInterrupt), worker_pool(1) as pool:
        pid = pool.submit(os.getpid).result()
        pool.submit(_sleep_then_write, 5.0, str(done))
        time.sleep(1.0)  # the worker is inside the task
        raise KeyboardInterrupt
    assert not done.exists()
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # ended and reaped: it cannot write the file later


def test_an_interrupt_while_the_pool_starts_its_thread_stays_an_interrupt(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An interrupt that lands in the first ``submit``, after the executor created its thread
    but before it started it: leaving the block raises the interrupt, not the executor's
    "cannot join thread before it is started"."""

    def interrupted(self: threading.Thread) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(cf_process._ExecutorManagerThread, "start", interrupted)
    with pytest.raises(KeyboardInterrupt), worker_pool(1) as pool:
        pool.submit(os.getpid)
