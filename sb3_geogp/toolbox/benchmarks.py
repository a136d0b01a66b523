"""Helpers of the engine benchmarks (``examples/benchmark_speed.py``,
``examples/long_run_numerics.py``): named GP configurations and thread limits."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
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
