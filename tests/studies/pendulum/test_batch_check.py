"""The batch sparse GP of the fixed-policy check against exact GPs, and the check end to end."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sb3_geogp import RBFKernel
from sb3_geogp.studies.pendulum.batch_check import (
    CheckConfig,
    Hyper,
    batch_sparse_gp,
    online_gp,
    run_check,
)
from sb3_geogp.studies.pendulum.task import Task, policy_episodes


def _rbf(lengthscale: float, dim: int, capacity: int) -> RBFKernel:
    kernel = RBFKernel(lengthscale=lengthscale)
    kernel.bind(dim, capacity)
    return kernel


def _exact_nlml(
    r2: np.ndarray, yn: np.ndarray, ls: np.ndarray, var: np.ndarray, noise: np.ndarray
) -> np.ndarray:
    """Exact negative log marginal likelihood per point of an RBF GP, broadcast over
    hyperparameters (numpy Cholesky); ``r2 : (n, n)`` squared distances."""
    n = yn.shape[0]
    K = var[..., None, None] * np.exp(-0.5 * r2 / ls[..., None, None] ** 2)
    K = K + noise[..., None, None] * np.eye(n)
    L = np.linalg.cholesky(K)
    c = np.linalg.solve(L, np.broadcast_to(yn, K.shape[:-1])[..., None])[..., 0]
    logdet = 2 * np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(-1)
    return 0.5 * ((c * c).sum(-1) + logdet + n * math.log(2 * math.pi)) / n


def _toy(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(0.0, 6.0, n))[:, None]
    return x, 3.0 + 2.0 * np.sin(x[:, 0]) + 0.5 * rng.standard_normal(n)


def test_every_point_inducing_is_the_exact_gp() -> None:
    # With z = x the DTC model is the exact GP: same posterior mean, and the collapsed bound's
    # trace term vanishes, so the bound is the exact negative log marginal likelihood.
    x, y = _toy(14, seed=0)
    x_eval = np.linspace(-0.5, 6.5, 23)[:, None]
    fit = batch_sparse_gp(_rbf(1.0, 1, len(x)), x, y, x, x_eval, jitter=0.0)
    assert fit.converged
    ls, var, noise = fit.lengthscale[0], fit.hyper.variance, fit.hyper.noise_var
    y_mean, y_std = y.mean(), y.std(ddof=1)
    yn = (y - y_mean) / y_std
    K = var * np.exp(-0.5 * (x - x.T) ** 2 / ls**2) + noise * np.eye(len(x))
    K_ex = var * np.exp(-0.5 * (x_eval - x.T) ** 2 / ls**2)
    L = np.linalg.cholesky(K)
    exact = y_mean + y_std * K_ex @ np.linalg.solve(L.T, np.linalg.solve(L, yn))
    np.testing.assert_allclose(fit.mean, exact, atol=1e-6)
    r2 = (x - x.T) ** 2
    nlml = _exact_nlml(r2, yn, np.array(ls), np.array(var), np.array(noise))
    assert fit.bound == pytest.approx(float(nlml), abs=1e-6)


def test_optimum_matches_a_grid_search_of_the_exact_marginal_likelihood() -> None:
    x, y = _toy(20, seed=1)
    yn = (y - y.mean()) / y.std(ddof=1)
    r2 = (x - x.T) ** 2
    fit = batch_sparse_gp(_rbf(1.0, 1, len(x)), x, y, x, x, jitter=0.0)
    # Brute force over log (lengthscale, variance, noise): a coarse grid, then a fine one
    # around its best node.
    centre, half = np.array([0.0, 0.0, -2.5]), np.array([2.0, 3.0, 3.5])
    for step in (0.25, 0.02):
        axes = [np.arange(c - h, c + h + step / 2, step) for c, h in zip(centre, half, strict=True)]
        grid = np.exp(np.stack(np.meshgrid(*axes, indexing="ij")))
        nlml = _exact_nlml(r2, yn, *grid)
        best = np.unravel_index(np.argmin(nlml), nlml.shape)
        centre, half = np.log(grid[(slice(None), *best)]), np.full(3, 0.3)
    found = np.log([fit.lengthscale[0], fit.hyper.variance, fit.hyper.noise_var])
    # At least as good as the grid, and within two fine steps of its best node in every log.
    assert fit.bound <= nlml[best] + 1e-9
    np.testing.assert_allclose(found, centre, atol=0.04)


def test_max_iter_zero_evaluates_the_start() -> None:
    x, y = _toy(10, seed=2)
    start = Hyper((0.7,), 1.3, 0.1)
    fit = batch_sparse_gp(_rbf(1.0, 1, len(x)), x, y, x, x, starts=(start,), max_iter=0)
    got = (*fit.hyper.factor, fit.hyper.variance, fit.hyper.noise_var)
    np.testing.assert_allclose(got, (0.7, 1.3, 0.1), rtol=1e-12)
    assert fit.evaluations == 1


def test_run_check_quick() -> None:
    """The configuration ``examples/fixed_policy_check.py --quick`` runs."""
    config = CheckConfig.quick()
    result = run_check(config)
    assert len(result.rows) == 4
    for row in result.rows:
        assert row["n_points"] == 16 * 38
        assert row["n_basis"] <= row["max_basis"]
        for key in ("mse_adaptive", "mse_default", "mse_batch", "mse_batch_online_hyper"):
            assert math.isfinite(row[key]) and row[key] > 0
        for key in ("ratio_adaptive", "ratio_default", "batch_bound"):
            assert math.isfinite(row[key])
    summary = result.summary()
    assert {(s["kernel"], s["max_basis"]) for s in summary} == {
        (k, m) for k in ("rbf", "geodesic") for m in (10, 20)
    }
    assert "no interval" in result.table()
    assert set(result.to_json()) >= {"config", "rows", "summary", "n_points", "truth"}


def test_quick_check_runs_the_euclidean_laplacian_kernel() -> None:
    """The comparison's ``laplacian`` critic has the same check (its batch GP included)."""
    result = run_check(dataclasses.replace(CheckConfig.quick(), kernels=("laplacian",)))
    assert {row["kernel"] for row in result.rows} == {"laplacian"}
    for row in result.rows:
        assert row["n_basis"] <= row["max_basis"]
        assert math.isfinite(row["ratio_adaptive"]) and row["mse_batch"] > 0


def test_online_gp_starts_from_the_configured_forgetting_only_where_it_adapts() -> None:
    """The adaptive pass gets ``config``'s starting forgetting (the 0.14 PPO default's 0.1 per
    4,096 points), the pass without adaptation none."""
    config = dataclasses.replace(CheckConfig.quick(), forgetting=0.1, forgetting_points=4096)
    task = Task()
    data = policy_episodes(task, config.n_episodes, seed=0, stride=config.stride)
    adaptive = online_gp(task, "laplacian", data, 10, config, adapt=True)
    plain = online_gp(task, "laplacian", data, 10, config, adapt=False)
    assert (adaptive.forgetting, adaptive.forgetting_points) == (0.1, 4096)
    assert (plain.forgetting, plain.forgetting_points) == (1.0, None)
