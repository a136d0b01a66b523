"""sb3_geogp.posterior_cache: the products a GP keeps between the steps of its updates equal
the same products formed afresh from its buffers, after insertions, deletions, forgetting and
refits (the Gram matrix grows and shrinks by a row in place; every other product is dropped
when the state it depends on changes).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sb3_geogp import SparseOnlineGP
from sb3_geogp.posterior_cache import kqk

NAMES = ("z", "K", "K_nugget", "K_alpha", "KQK", "KPK", "P_cholesky", "S", "least_novelty")


def fresh(gp: SparseOnlineGP) -> dict[str, torch.Tensor]:
    """Every cached product computed directly from the GP's buffers and its kernel."""
    m = gp.n_basis
    alpha, P, Q, nugget = gp.alpha[:m], gp.P[:m, :m], gp.Q[:m, :m], gp.nugget[:m]
    z = gp.kernel.scale(gp.bv_x[:m])
    K = gp.kernel.gram(z)
    L = torch.linalg.cholesky(P.double())
    return {
        "z": z,
        "K": K,
        "K_nugget": K + torch.diag(nugget),
        "K_alpha": K @ alpha,
        "KQK": K @ Q @ K,
        "KPK": K @ P @ K,
        "P_cholesky": P,  # compared as L L^T
        "S": L.T @ (K + torch.diag(nugget)).double() @ L,
        "least_novelty": (1.0 / (torch.diagonal(Q) * (gp.kernel.variance + nugget))).min(),
    }


@pytest.mark.parametrize("score", ["shrink", "lagged"])
@pytest.mark.parametrize("kernel", ["rbf", "laplacian", "geodesic"])
def test_cached_products_equal_fresh_ones_through_a_stream(kernel: str, score: str) -> None:
    """A stream that fills a 12-BV basis, deletes at capacity, forgets and refits, with either
    forgetting score (the lagged one uses ``P``'s factor and ``S``); after every batch, each
    product the cache holds (formed during the update, so carried through its changes) and
    each it forms now equals the fresh one."""
    adapt = dict(interval=120, forgetting_score=score)
    gp = SparseOnlineGP(2, kernel, max_basis=12, adapt=adapt, forgetting=0.9)
    rng = np.random.default_rng(0)
    deleted = 0
    for k in range(12):
        x = rng.uniform(-2, 2, size=(40, 2))
        gp.update(x, np.sin(2 * x[:, 0]) + (k / 4) * x[:, 1])
        cache, expected = gp._matrices(), fresh(gp)
        held = [name for name in NAMES if cache.has(name)]
        for name in held + [name for name in NAMES if name not in held]:
            got = cache.P_factor[1] if name == "S" else getattr(cache, name)
            if name == "P_cholesky":
                got = got @ got.T
            torch.testing.assert_close(got, expected[name].to(got), rtol=1e-9, atol=1e-9)
        deleted = int(gp.n_deleted)
    assert deleted > 0 and int(gp.n_blocks) > 1  # the shrinking and refit paths ran


def test_kqk_with_nuggets_is_the_dense_product() -> None:
    """``K Q K`` for ``Q = (K + N)^{-1}`` by the O(m^2) identity, against the dense product;
    without nuggets it is ``K`` itself."""
    rng = np.random.default_rng(1)
    A = torch.tensor(rng.normal(size=(6, 6)))
    K = A @ A.T + 0.1 * torch.eye(6, dtype=torch.float64)
    nugget = torch.tensor([0.0, 0.3, 0.0, 0.0, 1.2, 0.0], dtype=torch.float64)
    Q = torch.linalg.inv(K + torch.diag(nugget))
    torch.testing.assert_close(kqk(K, Q, nugget), K @ Q @ K, rtol=1e-10, atol=1e-10)
    assert kqk(K, torch.linalg.inv(K), torch.zeros(6, dtype=torch.float64)) is K
