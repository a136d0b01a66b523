"""Advantage errors on the paper's pendulum: SB3's GAE, Monte Carlo returns against the
environment itself and a closed form, and the scores."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import RolloutBuffer

from sb3_geogp.envs.pendulum import PaperPendulum, PendulumParams
from sb3_geogp.studies.advantage_error import advantage_scores, gae, policy_returns

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


def test_returns_at_rest_hanging_are_the_geometric_sum() -> None:
    """Closed form: without torque the hanging pendulum at rest stays there (a stable
    equilibrium), earning ``cos(pi) = -1`` each step: ``-(1 - gamma^H) / (1 - gamma)``."""
    horizon = 50
    returns = policy_returns(
        lambda obs, step: np.zeros(len(obs)), np.array([[-math.pi, 0.0]]), GAMMA, horizon, 3
    )
    np.testing.assert_allclose(returns, -(1 - GAMMA**horizon) / (1 - GAMMA), rtol=1e-10)


def test_returns_match_the_environment_stepped_one_by_one() -> None:
    """Brute force: a deterministic feedback policy stepped through ``PaperPendulum`` itself
    from each start state; every rollout of a deterministic policy is the same."""
    params = PendulumParams()
    states = np.array([[0.3, -1.0], [-2.5, 4.0], [3.0, 0.5]])

    def act(obs: np.ndarray, step: int) -> np.ndarray:
        return -2.0 * obs[:, 1] + 0.1 * step

    returns = policy_returns(act, states, GAMMA, 40, 2, params)
    env = PaperPendulum(params)
    for state, got in zip(states, returns, strict=True):
        env.reset(options={"state": state})
        total, discount = 0.0, 1.0
        for step in range(40):
            theta, omega = env.state
            _, r, *_ = env.step(np.array([act(np.array([[theta, omega]]), step)[0]]))
            total += discount * r
            discount *= GAMMA
        np.testing.assert_allclose(got, total, rtol=1e-12)


def test_returns_need_two_rollouts() -> None:
    with pytest.raises(ValueError, match="n_rollouts"):
        policy_returns(lambda obs, step: np.zeros(len(obs)), np.zeros((1, 2)), GAMMA, 5, 1)


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
