"""Advantage errors: SB3's GAE and the scores (the Monte Carlo returns are tested with
``value_ceiling``'s)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import RolloutBuffer

from sb3_geogp.studies.advantage_error import advantage_scores, gae

GAMMA = 0.9


def test_gae_is_sb3s_recursion() -> None:
    """Reference implementation: SB3's own ``RolloutBuffer`` on the same rollout, episode
    starts inside it and a done after its last step."""
    rng = np.random.default_rng(0)
    T, n_envs = 12, 3
    rewards = rng.normal(size=(T, n_envs))
    values = rng.normal(size=(T, n_envs))
    starts = rng.random((T, n_envs)) < 0.2
    last_values, last_dones = rng.normal(size=n_envs), np.array([True, False, False])
    buffer = RolloutBuffer(
        T,
        spaces.Box(-1, 1, (2,)),
        spaces.Box(-1, 1, (1,)),
        gamma=GAMMA,
        gae_lambda=0.95,
        n_envs=n_envs,
    )
    for t in range(T):
        buffer.add(
            np.zeros((n_envs, 2)),
            np.zeros((n_envs, 1)),
            rewards[t],
            starts[t],
            th.as_tensor(values[t]),
            th.zeros(n_envs),
        )
    buffer.compute_returns_and_advantage(th.as_tensor(last_values), last_dones)
    ours = gae(rewards, values, starts, last_values, last_dones, GAMMA, 0.95)
    np.testing.assert_allclose(ours, buffer.advantages, rtol=1e-5, atol=1e-5)


def test_scores_are_invariant_to_the_advantages_scale_only() -> None:
    """PPO standardises advantages, so an affine map with a positive factor keeps the
    correlation at 1 and a negative one gives -1; the value RMSE is the closed form."""
    rng = np.random.default_rng(1)
    reference, true_values = rng.normal(size=50), rng.normal(size=50)
    assert advantage_scores(reference, 3 * reference + 2, true_values, true_values + 0.5)[
        "correlation"
    ] == pytest.approx(1.0)
    scores = advantage_scores(reference, -reference, true_values, true_values + 0.5)
    assert scores["correlation"] == pytest.approx(-1.0)
    assert scores["value_rmse"] == pytest.approx(0.5)
    assert math.isnan(
        advantage_scores(reference, np.zeros(50), true_values, true_values)["correlation"]
    )


def test_scores_take_the_advantage_error_apart_as_the_regression_does() -> None:
    """Closed forms: the correlation is ``b / sqrt(b^2 + rho^2)`` with ``b`` the least-squares
    slope of the critic's advantages on the reference (numpy's polyfit) and ``rho`` the sd of
    the fit's residual over the reference's; bias and spread make up the RMSE."""
    rng = np.random.default_rng(2)
    reference, true_values = rng.normal(size=400), rng.normal(size=400)
    advantages = 0.6 * reference + 0.5 * rng.normal(size=400) + 3.0
    values = true_values + 2.0 + rng.normal(size=400)
    scores = advantage_scores(reference, advantages, true_values, values)
    slope, intercept = np.polyfit(reference, advantages, 1)
    fit_residual = advantages - slope * reference - intercept
    assert scores["advantage_slope"] == pytest.approx(slope, rel=1e-10)
    assert scores["advantage_residual"] == pytest.approx(fit_residual.std() / reference.std())
    b, rho = scores["advantage_slope"], scores["advantage_residual"]
    assert scores["correlation"] == pytest.approx(b / math.hypot(b, rho), rel=1e-10)
    error = values - true_values
    assert scores["value_bias"] == pytest.approx(error.mean())
    assert scores["value_rmse"] ** 2 == pytest.approx(
        scores["value_bias"] ** 2 + scores["value_spread"] ** 2
    )
    flat = advantage_scores(np.zeros(400), advantages, true_values, true_values)
    assert math.isnan(flat["advantage_slope"]) and math.isnan(flat["error_gain"])


@pytest.mark.parametrize("kind", ["per trajectory", "per step"])
def test_error_gain_is_the_closed_form_of_gaes_filter(kind: str) -> None:
    """GAE is linear in the values, so an error ``e`` reaches the advantages through a fixed
    filter: ``-e_t + sum_j gamma (gamma lambda)^(j-1) (1 - lambda) e_(t+j)``. Over long
    trajectories its gain is ``(1 - gamma) / (1 - gamma lambda)`` for an error constant along
    each, and the filter's coefficient norm for one independent at every step."""
    rng = np.random.default_rng(3)
    T, n_envs, lam = 4000, 40, 0.95
    rewards, true_values = rng.normal(size=(T, n_envs)), rng.normal(size=(T, n_envs))
    starts = np.zeros((T, n_envs), dtype=bool)
    shape = (1, n_envs) if kind == "per trajectory" else (T, n_envs)
    error = np.broadcast_to(rng.normal(size=shape), (T, n_envs))
    last, dones = rng.normal(size=n_envs), np.ones(n_envs, dtype=bool)

    def advantages(values: np.ndarray) -> np.ndarray:
        return gae(rewards, values, starts, last, dones, GAMMA, lam).ravel()

    scores = advantage_scores(
        advantages(true_values),
        advantages(true_values + error),
        true_values.ravel(),
        (true_values + error).ravel(),
    )
    if kind == "per trajectory":
        expected = (1 - GAMMA) / (1 - GAMMA * lam)
    else:
        expected = math.sqrt(1 + (GAMMA * (1 - lam)) ** 2 / (1 - (GAMMA * lam) ** 2))
    assert scores["error_gain"] == pytest.approx(expected, rel=0.01)
