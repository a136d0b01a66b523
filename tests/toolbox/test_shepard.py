"""The Shepard-interpolation control against its definition."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sb3_geogp import GeodesicKernel, RBFKernel, SparseOnlineGP
from sb3_geogp.kernels import distances, shepard_weights
from sb3_geogp.toolbox.shepard import predict_mean, shepard_interpolate, shepard_mean


def fitted_gp(kernel: RBFKernel | GeodesicKernel) -> SparseOnlineGP:
    rng = np.random.default_rng(3)
    x = rng.uniform(size=(300, 2))
    gp = SparseOnlineGP(2, kernel, max_basis=20)
    gp.update(x, np.sin(4 * x[:, 0]) + x[:, 1])
    return gp


def test_exact_at_basis_vectors_and_convex_elsewhere() -> None:
    gp = fitted_gp(RBFKernel(lengthscale=[0.2, 0.4]))
    values = torch.arange(gp.n_basis, dtype=torch.float64)
    at_bvs = shepard_interpolate(gp, values, gp.basis_inputs)
    torch.testing.assert_close(at_bvs, values, atol=1e-9, rtol=0)
    x = torch.rand(500, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    inner = shepard_interpolate(gp, values, x)
    assert bool((inner >= values.min() - 1e-9).all() and (inner <= values.max() + 1e-9).all())


def test_is_the_interpolating_geodesic_prediction_rule() -> None:
    """Interpolating a geodesic GP's own BV means reproduces its predictive mean."""
    gp = fitted_gp(GeodesicKernel(lengthscale=[0.2, 0.4]))
    x = torch.rand(200, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(1))
    bv_mean = gp.predict(gp.basis_inputs, return_var=False)[0]
    expected = gp.predict(x, return_var=False)[0]
    torch.testing.assert_close(shepard_interpolate(gp, bv_mean, x), expected, atol=1e-8, rtol=0)


def test_predict_mean_by_rule_in_any_chunks() -> None:
    gp = fitted_gp(RBFKernel(lengthscale=[0.2, 0.4]))
    x = np.random.default_rng(2).uniform(size=(50, 2))
    own = gp.predict(x, return_var=False)[0].numpy()
    np.testing.assert_array_equal(predict_mean(gp, x), own)
    shepard = shepard_mean(gp, x).numpy()
    np.testing.assert_array_equal(predict_mean(gp, x, "shepard"), shepard)
    # cdist's matrix-product path rounds differently on other batch sizes: equal to 1e-12.
    np.testing.assert_allclose(predict_mean(gp, x, "shepard", chunk=7), shepard, atol=1e-12)
    with pytest.raises(ValueError, match="rule"):
        predict_mean(gp, x, "nearest")  # type: ignore[arg-type]


def test_shepard_mean_without_basis_vectors_is_the_prior_mean() -> None:
    gp = SparseOnlineGP(2, RBFKernel(lengthscale=[0.2, 0.4]), max_basis=20)
    x = np.zeros((3, 2))
    torch.testing.assert_close(shepard_mean(gp, x), gp.predict(x, return_var=False)[0])


def test_blocked_basis_vectors_are_left_out_of_the_interpolation() -> None:
    """With ``blocked``, the interpolation is the one over the unblocked basis vectors alone:
    the same rule on a GP-free reference, the weights over each point's own side."""
    gp = fitted_gp(RBFKernel(lengthscale=[0.2, 0.4]))
    bv = gp.basis_inputs
    values = torch.linspace(-1.0, 1.0, gp.n_basis, dtype=torch.float64)
    x = torch.rand(40, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(5))

    def blocked(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        return (a[:, :1] > 0.5) != (b[:, 0] > 0.5)[None, :]

    got = shepard_interpolate(gp, values, x, blocked=blocked)
    for i in range(len(x)):
        side = ~blocked(x[i : i + 1], bv)[0]
        assert int(side.sum()) > 4
        own = shepard_weights(
            distances(x[i : i + 1] / gp.lengthscale, bv[side] / gp.lengthscale), 4
        )
        expected = (own[1] * values[side][own[0]]).sum()
        torch.testing.assert_close(got[i], expected, atol=1e-12, rtol=0)
    both = predict_mean(gp, x.numpy(), "shepard", blocked=blocked)
    np.testing.assert_allclose(both, shepard_mean(gp, x, blocked=blocked).numpy(), atol=1e-12)
    with pytest.raises(ValueError, match="blocked"):
        predict_mean(gp, x.numpy(), blocked=blocked)
