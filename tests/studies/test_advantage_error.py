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
