"""Helpers of the benchmarks (``examples/benchmark_speed.py``, ``long_run_numerics.py``,
``benchmark_training.py``, ``adaptation_schedule.py``): named GP configurations, thread
limits, and a clock on a GP's methods."""

from __future__ import annotations

import contextlib
import functools
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import torch

from sb3_geogp.kernels import make_kernel
from sb3_geogp.sparse_gp import SparseOnlineGP


@dataclass(frozen=True)
class Variant:
    """A named configuration of :class:`SparseOnlineGP`.

    Attributes
    ----------
    label : str
        Name printed in tables.
    kernel : str
        ``"rbf"`` or ``"geodesic"``.
    kernel_options : dict
        Keyword arguments of the kernel (defaults otherwise).
    gp_options : dict
        Keyword arguments of :class:`SparseOnlineGP` besides ``max_basis`` (e.g. ``forgetting``).
    """

    label: str
    kernel: str
    kernel_options: dict[str, Any] = field(default_factory=dict)
    gp_options: dict[str, Any] = field(default_factory=dict)

    def build(self, input_dim: int, max_basis: int) -> SparseOnlineGP:
        """An empty model of this variant with capacity ``max_basis``."""
        kernel = make_kernel(self.kernel, **self.kernel_options)  # type: ignore[arg-type]
        return SparseOnlineGP(input_dim, kernel, max_basis=max_basis, **self.gp_options)


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Run with ``threads`` torch (and, with threadpoolctl, BLAS) threads; ``None`` = as is.

    torch's thread count is restored afterwards.
    """
    before = torch.get_num_threads()
    if threads is not None:
        torch.set_num_threads(threads)
    try:
        with _blas_threads(threads):
            yield
    finally:
        torch.set_num_threads(before)


def _blas_threads(threads: int | None) -> contextlib.AbstractContextManager[Any]:
    """Limit NumPy's BLAS threads too (threadpoolctl ships with scikit-learn), if installed."""
    if threads is None:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=threads)


#: :class:`SparseOnlineGP` methods that run for adaptation (inside its updates): the
#: out-of-sample statistics and forgetting scores, the summary of points leaving the window,
#: its snapshots, the adaptation proper, and the forgetting it chooses (``_forget``, which a
#: GP without adaptation runs only with a fixed ``forgetting < 1``).
ADAPTATION_STEPS = ("_adapt", "_summarise", "_snapshot", "_out_of_sample", "_forget")


class GPClock:
    """Seconds one GP spends in ``update``, in ``predict`` and, inside its updates, in
    :data:`ADAPTATION_STEPS`; :meth:`time` adds other methods (a policy's drift measurement).

    The methods are wrapped on the instance (instance attributes shadow the class's), so every
    call is timed, also those SB3 makes inside ``learn()``.
    """

    def __init__(self, gp: SparseOnlineGP) -> None:
        self.seconds = {"update": 0.0, "predict": 0.0, "adaptation": 0.0}
        for name in ("update", "predict"):
            self.time(gp, name, name)
        for name in ADAPTATION_STEPS:
            self.time(gp, name, "adaptation")

    def time(self, owner: object, name: str, clock: str) -> None:
        """Time every later call of ``owner``'s method ``name`` on ``seconds[clock]``."""
        method = getattr(type(owner), name).__get__(owner)
        self.seconds.setdefault(clock, 0.0)
        setattr(owner, name, self._timed(method, clock))

    def _timed(self, method: Callable[..., Any], clock: str) -> Callable[..., Any]:
        @functools.wraps(method)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return method(*args, **kwargs)
            finally:
                self.seconds[clock] += time.perf_counter() - start

        return wrapper
