"""Controls shared by the experiments: predicting by Shepard interpolation from a GP's BVs."""

from __future__ import annotations

import torch
from torch import Tensor

from sb3_geogp.kernels import shepard_weights
from sb3_geogp.sparse_gp import SparseOnlineGP


def shepard_interpolate(
    gp: SparseOnlineGP, values: Tensor, x: Tensor, n_neighbors: int = 4
) -> Tensor:
    """Interpolate ``values`` given at ``gp``'s basis vectors to ``x``, as the geodesic kernel does.

    ``out(x) = sum_i w_i(x) values_i`` with the modified Shepard weights of
    :func:`sb3_geogp.kernels.shepard_weights` over the ``n_neighbors`` nearest basis vectors,
    distances in lengthscale units: the prediction rule of ``GeodesicKernel(attach=
    "interpolate")``, applied to any GP (the control that separates that rule from the graph).

    Parameters
    ----------
    gp : SparseOnlineGP
        Supplies the basis vectors and the lengthscale.
    values : Tensor, shape (n_basis,)
    x : Tensor, shape (n, d)
    n_neighbors : int

    Returns
    -------
    Tensor, shape (n,)
    """
    scale = gp.lengthscale
    bv = gp.basis_inputs
    idx, w = shepard_weights(torch.cdist(x.to(bv.dtype) / scale, bv / scale), n_neighbors)
    return (w * values.to(w.dtype)[idx]).sum(dim=1)
