"""Covariance functions of the sparse GP, one family per module (as GPyTorch's kernels).

* :mod:`~sb3_geogp.kernels.base`: the interface the GP talks to (:class:`Kernel`) and the two
  forms of kernel rows (:class:`DenseRows`, :class:`MixedRows`).
* :mod:`~sb3_geogp.kernels.euclidean`: :class:`RBFKernel`, :class:`LaplacianKernel`,
  :class:`MaternKernel`.
* :mod:`~sb3_geogp.kernels.geodesic`: :class:`GeodesicKernel`, which owns the basis-vector
  graph, and :func:`shepard_weights`.

A new kernel family is one new module with a :class:`Kernel` subclass; nothing in
:mod:`sb3_geogp.sparse_gp` changes.
"""

from __future__ import annotations

import copy
import inspect
from typing import Any, Literal

from sb3_geogp.kernels.base import (
    BasisMatrices,
    DenseRows,
    Gram,
    Kernel,
    MixedRows,
    Rows,
    distances,
)
from sb3_geogp.kernels.euclidean import EuclideanKernel, LaplacianKernel, MaternKernel, RBFKernel
from sb3_geogp.kernels.geodesic import GeodesicKernel, shepard_weights
from sb3_geogp.options import unknown_option

#: Names of the kernels of :data:`KERNELS`.
KernelName = Literal["rbf", "laplacian", "matern", "geodesic"]
#: Kernels that :func:`make_kernel` (and so ``gp_kwargs=dict(kernel=...)``) builds by name.
KERNELS: dict[str, type[Kernel]] = {
    "rbf": RBFKernel,
    "laplacian": LaplacianKernel,
    "matern": MaternKernel,
    "geodesic": GeodesicKernel,
}


def make_kernel(kernel: Kernel | KernelName, **kwargs: Any) -> Kernel:
    """A copy of ``kernel``, or a new one built by name (a key of :data:`KERNELS`).

    A kernel holds state (its lengthscale once chosen, the geodesic kernel's graph), so a GP
    never shares it.
    """
    if isinstance(kernel, Kernel):
        if kwargs:
            raise ValueError("kernel options can only be given with a kernel name")
        return copy.deepcopy(kernel)
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be a Kernel or one of {sorted(KERNELS)}, got {kernel!r}")
    _check_options(kernel, kwargs)
    return KERNELS[kernel](**kwargs)


def _check_options(kernel: str, kwargs: dict[str, Any]) -> None:
    """Raise ``TypeError`` naming an option the kernel ``kernel`` does not take, the closest
    it does and the kernels that take it."""
    cls = KERNELS[kernel]
    accepted = _options(cls)
    if accepted is None:
        return
    message = unknown_option(f"kernel {kernel!r} ({cls.__name__})", kwargs, accepted)
    if message is None:
        return
    option = next(k for k in kwargs if k not in accepted)
    takers = kernels_taking(option)
    elsewhere = f"; {option!r} is an option of {kernel_names(takers)}" if takers else ""
    raise TypeError(message + elsewhere)


def kernels_taking(option: str) -> list[str]:
    """The names (keys of :data:`KERNELS`) of the kernels whose constructor takes ``option``."""
    return [k for k, c in KERNELS.items() if option in (_options(c) or ())]


def kernel_names(kernels: list[str]) -> str:
    """Kernel names for a message: ``"the geodesic kernel"``, ``"the rbf, laplacian and
    geodesic kernels"``."""
    if len(kernels) == 1:
        return f"the {kernels[0]} kernel"
    return f"the {', '.join(kernels[:-1])} and {kernels[-1]} kernels"


def _options(cls: type[Kernel]) -> list[str] | None:
    """The keyword options of a kernel class's constructor (``None``: it takes any)."""
    parameters = list(inspect.signature(cls.__init__).parameters.values())[1:]
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return None
    return [p.name for p in parameters]


__all__ = [
    "KERNELS",
    "BasisMatrices",
    "DenseRows",
    "EuclideanKernel",
    "GeodesicKernel",
    "Gram",
    "Kernel",
    "KernelName",
    "LaplacianKernel",
    "MaternKernel",
    "MixedRows",
    "RBFKernel",
    "Rows",
    "distances",
    "kernel_names",
    "kernels_taking",
    "make_kernel",
    "shepard_weights",
]
