"""Action gaps on CartPole: the batch dynamics and Monte Carlo gaps against gymnasium's env."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from sb3_geogp.studies.action_gap import (
    action_gaps,
    cartpole_step,
    gap_scores,
    policy_returns,
)

GAMMA = 0.98


def _gym_return(state: np.ndarray, first: int, policy: int, horizon: int) -> float:
    """Brute force: ``r + gamma G`` from ``state`` after ``first``, then ``policy`` throughout,
    stepped by gymnasium's own CartPole (no time limit)."""
    env = gym.make("CartPole-v1").unwrapped
    env.reset(seed=0)
    env.state = np.array(state, dtype=np.float64)
    total, discount, action = 0.0, 1.0, first
    for _ in range(horizon + 1):
        _, reward, terminated, _, _ = env.step(action)
        total += discount * reward
        discount *= GAMMA
        action = policy
        if terminated:
            break
    return total


def _states(n: int, seed: int, edge: float = 0.0) -> np.ndarray:
    """Inside the bounds; ``edge`` > 0 reaches that far past them, so some steps terminate."""
    rng = np.random.default_rng(seed)
    high = np.array([2.0 + 2 * edge, 1.5, 0.15 + edge / 4, 1.5])
    return rng.uniform(-high, high, size=(n, 4))


def test_cartpole_step_is_gymnasiums_step() -> None:
    env = gym.make("CartPole-v1").unwrapped
    env.reset(seed=0)
    states = _states(64, 1, edge=0.3)
    actions = np.arange(64) % 2
    nxt, terminated = cartpole_step(states, actions)
    for s, a, n, t in zip(states, actions, nxt, terminated, strict=True):
        env.state = s.copy()
        _, _, done, _, _ = env.step(int(a))
        np.testing.assert_allclose(n, env.state, rtol=1e-12, atol=1e-12)
        assert t == done
    assert terminated.any() and not terminated.all()


@pytest.mark.parametrize("policy", [0, 1])
def test_returns_of_a_deterministic_policy_are_gymnasiums(policy: int) -> None:
    states = _states(8, 2)
    horizon = 60
    got = policy_returns(
        lambda s: np.full(len(s), float(policy)),
        states,
        np.ones(8, dtype=bool),
        GAMMA,
        horizon,
        np.random.default_rng(0),
    )
    # policy_returns counts the steps after the state: the brute force's first action is the
    # policy's, its first reward then belongs to the same step.
    expected = [_gym_return(s, policy, policy, horizon - 1) for s in states]
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_gaps_of_a_deterministic_policy_are_exact_with_zero_stderr() -> None:
    states = _states(6, 3)
    horizon = 40
    estimate = action_gaps(lambda s: np.ones(len(s)), states, GAMMA, 4, horizon, seed=5)
    expected = [_gym_return(s, 1, 1, horizon) - _gym_return(s, 0, 1, horizon) for s in states]
    np.testing.assert_allclose(estimate.gap, expected, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(estimate.stderr, 0.0)
    assert estimate.successors.shape == (2, 6, 4) and estimate.terminal.shape == (2, 6)


def test_common_random_numbers_give_zero_gap_where_actions_do_not_matter() -> None:
    """A policy that ignores the state, from states where both successors terminate or
    both survive identically long: the uniforms are shared, so the gaps cancel exactly."""
    falling = np.array([[0.0, 0.0, 0.2094, 3.0], [0.0, 0.0, -0.2094, -3.0]])
    estimate = action_gaps(lambda s: np.full(len(s), 0.5), falling, GAMMA, 8, 30, seed=1)
    assert estimate.terminal.all()
    np.testing.assert_array_equal(estimate.gap, 0.0)
    np.testing.assert_array_equal(estimate.stderr, 0.0)


def test_critic_gap_values_terminal_successors_at_zero() -> None:
    falling = np.array([[0.0, 0.0, 0.2094, 3.0]])
    estimate = action_gaps(lambda s: np.full(len(s), 0.5), falling, GAMMA, 2, 5)
    np.testing.assert_array_equal(estimate.critic_gap(lambda s: np.full(len(s), 7.0), GAMMA), 0.0)
    upright = action_gaps(lambda s: np.full(len(s), 0.5), np.zeros((1, 4)), GAMMA, 2, 5)
    # pushing right moves the cart right: a critic equal to x ranks action 1 first
    critic = upright.critic_gap(lambda s: s[:, 1], GAMMA)
    assert critic[0] == pytest.approx(
        GAMMA * (upright.successors[1, 0, 1] - upright.successors[0, 0, 1])
    )
    assert critic[0] > 0


def test_gap_scores_by_hand() -> None:
    gap = np.array([1.0, -1.0, 0.1, -2.0])
    stderr = np.array([0.1, 0.1, 0.1, 0.5])
    estimate = np.array([2.0, 1.0, -1.0, -0.5])
    scores = gap_scores(gap, stderr, estimate)
    # decisive: |gap| > 2 stderr -> states 0, 1, 3; signs agree on 0 and 3
    assert scores["n_decisive"] == 3
    assert scores["sign_accuracy"] == pytest.approx(2 / 3)
    assert scores["weighted_sign_accuracy"] == pytest.approx(3.0 / 4.1)
    g, e = gap - gap.mean(), estimate - estimate.mean()
    assert scores["correlation"] == pytest.approx(g @ e / math.sqrt((g @ g) * (e @ e)))
    none = gap_scores(np.zeros(3), np.zeros(3), np.ones(3))
    assert math.isnan(none["sign_accuracy"]) and math.isnan(none["weighted_sign_accuracy"])
    assert math.isnan(none["correlation"]) and none["n_decisive"] == 0


def test_action_gaps_needs_two_rollouts() -> None:
    with pytest.raises(ValueError, match="n_rollouts"):
        action_gaps(lambda s: np.ones(len(s)), np.zeros((1, 4)), GAMMA, 1)
