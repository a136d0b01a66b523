"""Default hyperparameters: the one rule, checked against hand computations."""

from __future__ import annotations

import numpy as np
import torch

from sb3_geogp.defaults import (
    bounds_lengthscale,
    default_lengthscale,
    resolve_lengthscale,
    target_standardisation,
)


def test_bounds_lengthscale_uses_finite_bounds_only() -> None:
    """The std of a uniform on the bounds where bounded, NaN (from data) elsewhere."""
    low = np.array([-1.0, -np.inf, 0.0, -3.4e38], dtype=np.float32)
    high = np.array([1.0, np.inf, 6.0, 3.4e38], dtype=np.float32)
    got = bounds_lengthscale(low, high)
    np.testing.assert_allclose(got, [2 / np.sqrt(12), np.nan, 6 / np.sqrt(12), np.nan])


def test_resolve_lengthscale_order_is_request_then_bounds_then_batch() -> None:
    rng = np.random.default_rng(0)
    x = torch.as_tensor(rng.normal(size=(50, 3)) * [1.0, 2.0, 3.0])
    requested = torch.tensor([0.5, float("nan"), float("nan")], dtype=torch.float64)
    bounds = (np.array([-9.0, -1.0, -np.inf]), np.array([9.0, 2.0, np.inf]))
    before_data = resolve_lengthscale(requested, bounds=bounds)
    np.testing.assert_allclose(before_data.numpy(), [0.5, 3 / np.sqrt(12), np.nan])
    after = resolve_lengthscale(before_data, x=x)
    std = x.numpy().std(axis=0)
    np.testing.assert_allclose(after.numpy(), [0.5, 3 / np.sqrt(12), std[2]], rtol=1e-12)


def test_default_lengthscale_falls_back_for_constant_dimensions() -> None:
    x = torch.tensor([[1.0, -4.0, 0.0], [3.0, -4.0, 0.0]], dtype=torch.float64)
    np.testing.assert_allclose(default_lengthscale(x).numpy(), [1.0, 4.0, 1.0])


def test_target_standardisation_uses_given_values_else_the_batch() -> None:
    y = torch.tensor([1.0, 2.0, 6.0], dtype=torch.float64)
    mean, scale = target_standardisation(y)
    assert float(mean) == 3.0 and abs(float(scale) - float(np.std([1, 2, 6], ddof=1))) < 1e-12
    assert target_standardisation(y, mean=-1.0, scale=2.0) == (-1.0, 2.0)
    assert float(target_standardisation(torch.full((4,), 7.0, dtype=torch.float64))[1]) == 1.0
