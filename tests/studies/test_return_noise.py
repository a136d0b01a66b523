"""The Monte Carlo GPTD noise model and its exact GP against brute force: the noise built step
by step, scipy's normal density, and the independent-noise exact GP."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from sb3_geogp.studies.exact_gp import exact_gp
from sb3_geogp.studies.return_noise import (
    episode_steps,
    fit_exact_gp,
    log_evidence,
    trajectory_noise,
)
from tests.test_sparse_gp import matern

GAMMA = 0.9
#: Three episodes of 4, 1 and 3 steps, in time order.
STARTS = np.array([1, 0, 0, 0, 1, 1, 0, 0], dtype=bool)


def step_by_step(starts: np.ndarray, gamma: float) -> np.ndarray:
    """``G G^T (1 - gamma^2)``: ``n = G eps`` with ``G[t, t + k] = gamma^k`` to each
    episode's end, per-step noise of variance ``1 - gamma^2`` (so ``s^2`` = 1)."""
    n = len(starts)
    ends = np.append(np.flatnonzero(starts)[1:], n)
    g = np.zeros((n, n))
    for t in range(n):
        end = ends[np.searchsorted(ends, t, side="right")]
        for j in range(t, end):
            g[t, j] = gamma ** (j - t)
    return g @ g.T * (1 - gamma**2)


def test_episode_steps() -> None:
    episode, step, length = episode_steps(STARTS)
    assert episode.tolist() == [0, 0, 0, 0, 1, 2, 2, 2]
    assert step.tolist() == [0, 1, 2, 3, 0, 0, 1, 2]
    assert length.tolist() == [4, 4, 4, 4, 1, 3, 3, 3]


def test_trajectory_noise_is_the_discounted_sum_of_per_step_noise() -> None:
    expected = step_by_step(STARTS, GAMMA)
    np.testing.assert_allclose(
        trajectory_noise(*episode_steps(STARTS), GAMMA), expected, atol=1e-15
    )


def test_trajectory_noise_of_a_subset_of_steps_is_the_submatrix() -> None:
    # the study fits every k-th step: the marginal of a Gaussian is its submatrix
    keep = np.array([0, 2, 3, 5, 7])
    episode, step, length = episode_steps(STARTS)
    sub = trajectory_noise(episode[keep], step[keep], length[keep], GAMMA)
    np.testing.assert_allclose(sub, step_by_step(STARTS, GAMMA)[np.ix_(keep, keep)], atol=1e-15)


def test_trajectory_noise_refuses_a_bad_discount() -> None:
    with pytest.raises(ValueError, match="gamma"):
        trajectory_noise(*episode_steps(STARTS), 1.0)


def _data(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2, 2, size=(n, 2))
    starts = rng.random(n) < 0.1
    y = np.sin(2 * x[:, 0]) + 0.5 * x[:, 1] + 0.2 * rng.normal(size=n)
    return x, y, starts


def test_log_evidence_is_the_normal_density() -> None:
    x, y, starts = _data(40, 0)
    lengthscale, signal = np.array([0.7, 1.3]), 0.8
    noise = 0.3 * trajectory_noise(*episode_steps(starts), GAMMA)
    cov = signal * matern(x, x, lengthscale, 1.0, 0.5) + noise
    expected = multivariate_normal(np.zeros(len(y)), cov).logpdf(y)
    assert log_evidence(x, y, lengthscale, signal, noise) == pytest.approx(expected, rel=1e-10)


@pytest.mark.parametrize("correlated", [False, True])
def test_fit_is_at_least_as_likely_as_its_start_and_predicts_with_its_posterior(
    correlated: bool,
) -> None:
    x, y, starts = _data(120, 1)
    shape = trajectory_noise(*episode_steps(starts), GAMMA) if correlated else np.eye(len(y))
    fit = fit_exact_gp(x, y, shape if correlated else None)
    z = (y - y.mean()) / y.std()
    start = log_evidence(x, z, x.std(axis=0, ddof=1), 1.0, 0.1 * shape)  # the fit's start
    found = log_evidence(x, z, fit.lengthscale, fit.signal_var, fit.noise_var * shape)
    assert found == pytest.approx(fit.log_marginal_likelihood, rel=1e-8)
    assert found >= start
    # the posterior mean by brute force at the fitted hyperparameters
    new = np.random.default_rng(2).uniform(-2, 2, size=(30, 2))
    cov = fit.signal_var * matern(x, x, fit.lengthscale, 1.0, 0.5) + fit.noise_var * shape
    cross = fit.signal_var * matern(new, x, fit.lengthscale, 1.0, 0.5)
    expected = cross @ np.linalg.solve(cov, z) * y.std() + y.mean()
    np.testing.assert_allclose(fit.predict(new), expected, rtol=1e-8, atol=1e-10)


def test_independent_noise_predicts_as_the_exact_gp_at_its_hyperparameters() -> None:
    x, y, _ = _data(150, 3)
    fit = fit_exact_gp(x, y)
    reference = exact_gp(x, y, "laplacian", fixed=(fit.lengthscale, fit.signal_var, fit.noise_var))
    new = np.random.default_rng(4).uniform(-2, 2, size=(50, 2))
    np.testing.assert_allclose(fit.predict(new), reference.predict(new), rtol=1e-8, atol=1e-10)


def test_bad_inputs_are_refused() -> None:
    x, y, _ = _data(10, 5)
    with pytest.raises(ValueError, match="constant"):
        fit_exact_gp(x, np.ones(10))
    with pytest.raises(ValueError, match="shape"):
        fit_exact_gp(x, y[:5])
    with pytest.raises(ValueError, match="noise must have shape"):
        fit_exact_gp(x, y, np.eye(5))
