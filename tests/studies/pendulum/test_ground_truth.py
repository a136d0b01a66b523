"""Ground truth of the fixed policy: Monte Carlo and tabular TD against closed forms."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sb3_geogp.envs.pendulum import PendulumParams
from sb3_geogp.studies.pendulum.ground_truth import cell_index, mc_value, mc_value_at, td_baseline
from sb3_geogp.studies.pendulum.task import FixedPolicy, Task


def _constant(value: float):  # type: ignore[no-untyped-def]
    return lambda theta: np.full(np.shape(theta), value)


def test_mc_value_of_a_constant_reward_is_the_geometric_sum() -> None:
    # Any policy (here the noisy one) earns c per step: V = c (1 - gamma^H) / (1 - gamma).
    task = Task(gamma=0.9, reward_fn=_constant(0.7))
    gv = mc_value(task, n=5, n_rollouts=3, seed=0)
    expected = 0.7 * (1 - task.gamma**task.horizon) / (1 - task.gamma)
    np.testing.assert_allclose(gv.value, expected, rtol=1e-12)
    np.testing.assert_allclose(gv.stderr, 0.0, atol=1e-12)
    assert gv.image().shape == (5, 5)


def test_mc_value_of_free_rotation_matches_closed_form() -> None:
    # No gravity, friction, torque or noise: theta_t = theta_0 + omega dt t, r_t = cos(theta_t),
    # V = Re(e^{i theta_0} (1 - z^H) / (1 - z)), z = gamma e^{i omega dt}.
    params = replace(PendulumParams(), gravity=0.0, friction=0.0)
    policy = FixedPolicy(k_p=0.0, k_d=0.0, k_energy=0.0, noise_std=0.0)
    task = Task(params=params, policy=policy, gamma=0.95)
    gv = mc_value(task, n=6, n_rollouts=2)
    states, _, _ = task.grid(6)
    z = task.gamma * np.exp(1j * states[:, 1] * params.dt)
    expected = np.real(np.exp(1j * states[:, 0]) * (1 - z**task.horizon) / (1 - z))
    np.testing.assert_allclose(gv.value, expected, atol=1e-9)


def test_mc_standard_error_shrinks_like_one_over_sqrt_n() -> None:
    task = Task()
    small = mc_value(task, n=4, n_rollouts=8, seed=1).stderr.mean()
    large = mc_value(task, n=4, n_rollouts=128, seed=1).stderr.mean()
    assert large < small / 2


def test_mc_value_has_sharp_jumps_and_a_high_balanced_top() -> None:
    task = Task()
    states, _, _ = task.grid(20)
    gv = mc_value(task, n=20, n_rollouts=8, seed=2)
    v = gv.image()
    # Upright at rest is worth about the maximum 1 / (1 - gamma); hanging much less.
    top = np.argmin(np.abs(states[:, 0]) + np.abs(states[:, 1]))
    assert gv.value[top] > 0.9 / (1 - task.gamma)
    # Neighbouring cells differ by far more than the MC noise somewhere: a discontinuity.
    jumps = np.abs(np.diff(v, axis=1))
    assert jumps.max() > 10 * gv.stderr.max() / 2 and jumps.max() > 10.0


def test_td_baseline_of_a_constant_reward_is_c_over_one_minus_gamma() -> None:
    # Every cell visited and every successor visited: the batch TD fixed point is exact.
    task = Task(gamma=0.9, reward_fn=_constant(2.0))
    td = td_baseline(task, n=4, n_episodes=200, seed=0)
    assert td.coverage == 1.0
    np.testing.assert_allclose(td.value, 2.0 / (1 - task.gamma), rtol=1e-10)


def test_td_baseline_approaches_the_mc_value() -> None:
    task = Task()
    n = 12
    mc = mc_value(task, n=n, n_rollouts=16, seed=3)
    td = td_baseline(task, n=n, n_episodes=800, seed=4)
    seen = td.visits > 0
    assert td.coverage > 0.9
    err = np.mean((td.value[seen] - mc.value[seen]) ** 2)
    assert err < 0.5 * mc.value.var()


def test_cell_index_matches_the_grid() -> None:
    task = Task()
    for n in (3, 60):
        states, _, _ = task.grid(n)
        np.testing.assert_array_equal(cell_index(states, task, n), np.arange(n * n))
    # omega outside the box falls into the edge rows, theta wraps.
    idx = cell_index(np.array([[math.pi - 1e-9, 100.0], [-math.pi, -100.0]]), task, 3)
    assert idx.tolist() == [8, 0]


def test_mc_value_needs_two_rollouts() -> None:
    with pytest.raises(ValueError, match="n_rollouts"):
        mc_value(Task(), n=2, n_rollouts=1)


def test_mc_value_at_matches_the_grid_estimator() -> None:
    task = Task()
    states, _, _ = task.grid(3)
    grid = mc_value(task, n=3, n_rollouts=4, seed=9)
    value, stderr = mc_value_at(task, states, n_rollouts=4, seed=9)
    np.testing.assert_array_equal(value, grid.value)
    np.testing.assert_array_equal(stderr, grid.stderr)
