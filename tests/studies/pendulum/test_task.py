"""The fixed policy and its episode data (states, completed discounted returns)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sb3_geogp.envs.pendulum import PendulumParams
from sb3_geogp.studies.pendulum.task import (
    FixedPolicy,
    Task,
    discounted_tail_sums,
    policy_episodes,
)


def test_controller_balances_near_top_and_pumps_energy_elsewhere() -> None:
    params, policy = PendulumParams(), FixedPolicy()
    # Near the top: PD towards upright, saturated at the limit.
    assert policy.mean_action(np.array([0.1]), np.array([0.0]), params)[0] == pytest.approx(-4.0)
    assert policy.mean_action(np.array([0.5]), np.array([0.0]), params)[0] == -5.0
    # Hanging and moving: push along the motion (energy below E*).
    assert policy.mean_action(np.array([math.pi - 0.1]), np.array([1.0]), params)[0] > 0
    assert policy.mean_action(np.array([math.pi - 0.1]), np.array([-1.0]), params)[0] < 0


def test_noisy_policy_stays_in_limits_and_has_the_fixed_std() -> None:
    params, policy = PendulumParams(), FixedPolicy(noise_std=1.0)
    rng = np.random.default_rng(0)
    theta, omega = np.full(20_000, math.pi - 0.3), np.full(20_000, 0.0)
    a = policy.sample(theta, omega, params, rng)
    assert np.all(np.abs(a) <= params.max_torque)
    assert a.std() == pytest.approx(1.0, rel=0.05)


def test_discounted_tail_sums_match_a_direct_loop() -> None:
    rng = np.random.default_rng(1)
    rewards = rng.normal(size=(3, 12))
    gamma, horizon = 0.8, 5
    out = discounted_tail_sums(rewards, gamma, horizon)
    assert out.shape == (3, 8)
    for t in range(8):
        direct = sum(gamma**i * rewards[:, t + i] for i in range(horizon))
        np.testing.assert_allclose(out[:, t], direct)
    with pytest.raises(ValueError):
        discounted_tail_sums(rewards, gamma, 13)


def test_policy_episodes_layout_and_returns() -> None:
    task = Task()
    data = policy_episodes(task, n_episodes=3, seed=0)
    assert data.states.shape == (450, 2) and data.episode_length == 150
    assert data.episode_starts.sum() == 3 and data.episode_starts[[0, 150, 300]].all()
    assert np.all(np.abs(data.returns) <= 1 / (1 - task.gamma))
    # A state that stays balanced collects nearly the maximal return.
    assert data.returns.max() > 0.95 / (1 - task.gamma)
    strided = policy_episodes(task, n_episodes=3, seed=0, stride=4)
    assert strided.episode_length == 38 and strided.n_episodes == 3
    np.testing.assert_allclose(strided.states[:38], data.states[:150:4])
    np.testing.assert_allclose(strided.returns[:38], data.returns[:150:4])
    sub = strided.episodes(slice(1, 3))
    np.testing.assert_array_equal(sub.states, strided.states[38:])


def test_grid_is_row_major_with_omega_slow() -> None:
    states, thetas, omegas = Task().grid(4)
    assert states.shape == (16, 2)
    np.testing.assert_allclose(states[:4, 0], thetas)
    np.testing.assert_allclose(states[::4, 1], omegas)
    assert thetas[0] == pytest.approx(-math.pi + math.pi / 4)
