"""The Shepard control: predicting from any GP's basis vectors as the geodesic kernel does.

``GeodesicKernel(attach="interpolate")`` predicts by interpolating its basis vectors with
modified Shepard weights. Applied to a Euclidean GP, the same rule separates the effect of
that attachment from the effect of the graph distance, so both studies compare each kernel
under two prediction rules (:data:`PredictionRule`): the GP's own posterior mean (``"gp"``)
and the Shepard interpolation of its posterior means at the basis vectors (``"shepard"``).
Training is the same under both rules; only the prediction differs. Either Shepard function
takes ``blocked``, pairs of points and basis vectors that may not be interpolated between (an
oracle that knows the obstacles, as :class:`~sb3_geogp.GeodesicKernel`'s ``blocked``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
import torch
from torch import Tensor

from sb3_geogp.kernels import distances, shepard_weights
from sb3_geogp.kernels.geodesic import BLOCKED_DISTANCE
from sb3_geogp.sparse_gp import SparseOnlineGP

PredictionRule = Literal["gp", "shepard"]
#: ``blocked(x, b) -> mask``: points ``x : (n, d)`` and basis vectors ``b : (m, d)`` in input
#: units to a bool mask, shape (n, m), ``True`` where ``b_j`` may not be interpolated to ``x_i``.
Blocked = Callable[[Tensor, Tensor], Tensor]


def shepard_interpolate(
    gp: SparseOnlineGP,
    values: Tensor,
    x: Tensor,
    n_neighbors: int = 4,
    blocked: Blocked | None = None,
) -> Tensor:
    """Interpolate ``values`` given at ``gp``'s basis vectors to ``x``, as the geodesic kernel does.

    ``out(x) = sum_i w_i(x) values_i`` with the modified Shepard weights of
    :func:`sb3_geogp.kernels.shepard_weights` over the ``n_neighbors`` nearest basis vectors,
    distances in lengthscale units: the prediction rule of ``GeodesicKernel(attach=
    "interpolate")``, applied to any GP.

    Parameters
    ----------
    gp : SparseOnlineGP
        Supplies the basis vectors and the lengthscale.
    values : Tensor, shape (n_basis,)
    x : Tensor, shape (n, d)
    n_neighbors : int
    blocked : callable, optional
        Pairs left out of the interpolation (:data:`Blocked`): given the distance
        :data:`~sb3_geogp.kernels.geodesic.BLOCKED_DISTANCE`, as the geodesic kernel does.

    Returns
    -------
    Tensor, shape (n,)
    """
    scale = gp.lengthscale
    bv = gp.basis_inputs
    x = x.to(bv.dtype)
    dist = distances(x / scale, bv / scale)
    if blocked is not None:
        dist = dist.masked_fill(blocked(x, bv), BLOCKED_DISTANCE)
    idx, w = shepard_weights(dist, n_neighbors)
    return (w * values.to(w.dtype)[idx]).sum(dim=1)


def shepard_mean(
    gp: SparseOnlineGP,
    x: np.ndarray | Tensor,
    n_neighbors: int = 4,
    blocked: Blocked | None = None,
) -> Tensor:
    """The Shepard rule's prediction: ``gp``'s posterior means at its basis vectors, interpolated.

    ``mean(x) = sum_i w_i(x) mean(b_i)`` (:func:`shepard_interpolate`). Without basis vectors
    it is the GP's prior mean, as the GP itself predicts.

    Parameters
    ----------
    gp : SparseOnlineGP
    x : ndarray or Tensor, shape (n, d)
    n_neighbors : int
    blocked : callable, optional
        As :func:`shepard_interpolate`.

    Returns
    -------
    Tensor, shape (n,)
    """
    if gp.n_basis == 0:
        return gp.predict(x, return_var=False)[0]
    bv_mean = gp.predict(gp.basis_inputs, return_var=False)[0]
    return shepard_interpolate(gp, bv_mean, torch.as_tensor(x), n_neighbors, blocked)


def predict_mean(
    gp: SparseOnlineGP,
    x: np.ndarray,
    rule: PredictionRule = "gp",
    chunk: int | None = None,
    blocked: Blocked | None = None,
) -> np.ndarray:
    """Posterior mean at ``x`` under a prediction rule.

    Parameters
    ----------
    gp : SparseOnlineGP
    x : ndarray, shape (n, d)
    rule : {"gp", "shepard"}
        The GP's own mean, or :func:`shepard_mean`.
    chunk : int, optional
        Predict this many points at a time (bounds the memory of the interpolation on large
        grids); ``None``: all at once.
    blocked : callable, optional
        With ``rule="shepard"``, as :func:`shepard_interpolate`; the ``"gp"`` rule takes none.

    Returns
    -------
    ndarray, shape (n,)
    """
    if rule not in ("gp", "shepard"):
        raise ValueError(f"rule must be 'gp' or 'shepard', got {rule!r}")
    if blocked is not None and rule != "shepard":
        raise ValueError(
            "blocked applies to the 'shepard' rule only (the GP attaches by its kernel)"
        )
    step = chunk or max(len(x), 1)
    parts = [
        shepard_mean(gp, x[i : i + step], blocked=blocked)
        if rule == "shepard"
        else gp.predict(x[i : i + step], return_var=False)[0]
        for i in range(0, len(x), step)
    ]
    return torch.cat(parts).cpu().numpy()
