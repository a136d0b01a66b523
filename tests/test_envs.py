"""PaperPendulum: gymnasium API, registration, dynamics (energy, consistency, limits)."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from sb3_geogp.envs import (
    PAPER_PENDULUM_ID,
    PaperPendulum,
    PendulumParams,
    dynamics_step,
    energy,
    wrap_angle,
)


def test_gymnasium_check_env_passes() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # [-5, 5] action box is the paper's
        check_env(PaperPendulum())
        check_env(gym.make(PAPER_PENDULUM_ID).unwrapped)
        rendered = gym.make(PAPER_PENDULUM_ID, render_mode="rgb_array")
        check_env(rendered.unwrapped, skip_render_check=False)


def test_sb3_check_env_passes() -> None:
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        sb3_check_env(PaperPendulum())


def test_registered_env_truncates_after_150_steps() -> None:
    env = gym.make(PAPER_PENDULUM_ID)
    env.reset(seed=0)
    for t in range(1, 151):
        _, _, terminated, truncated, _ = env.step(np.zeros(1, dtype=np.float32))
        assert not terminated
        assert truncated == (t == 150)


def test_step_matches_vectorised_dynamics_and_reward() -> None:
    env = PaperPendulum()
    obs, _ = env.reset(options={"state": (2.0, -3.0)})
    np.testing.assert_allclose(obs, [2.0, -3.0], rtol=1e-6)
    torque = 3.7
    _, r, _, _, info = env.step(np.array([torque], dtype=np.float32))
    th, om = dynamics_step(
        np.array([2.0]), np.array([-3.0]), np.array([np.float32(torque)]), env.params
    )
    np.testing.assert_allclose(env.state, [th[0], om[0]])
    assert r == pytest.approx(math.cos(2.0))
    assert info["energy"] == pytest.approx(float(energy(th[0], om[0], env.params)))


def test_reset_is_uniform_over_the_box_and_seeded() -> None:
    env = PaperPendulum(start_speed=8.0)
    starts = np.array([env.reset(seed=i)[0] for i in range(400)])
    assert starts[:, 0].min() < -2.5 and starts[:, 0].max() > 2.5
    assert np.all(np.abs(starts[:, 1]) <= 8.0) and starts[:, 1].std() > 3.5
    np.testing.assert_array_equal(env.reset(seed=3)[0], env.reset(seed=3)[0])


def test_torque_is_clipped_to_the_limit() -> None:
    params = PendulumParams()
    th0, om0 = np.array([1.0]), np.array([0.5])
    np.testing.assert_array_equal(
        dynamics_step(th0, om0, np.array([100.0]), params),
        dynamics_step(th0, om0, np.array([params.max_torque]), params),
    )
    space = PaperPendulum().action_space
    assert isinstance(space, gym.spaces.Box)
    assert space.low[0] == -5.0 and space.high[0] == 5.0


def _energy_drift(n_substeps: int) -> float:
    params = PendulumParams(friction=0.0, n_substeps=n_substeps)
    rng = np.random.default_rng(0)
    theta, omega = rng.uniform(-math.pi, math.pi, 200), rng.uniform(-4.0, 4.0, 200)
    e0 = energy(theta, omega, params)
    for _ in range(params.episode_length):
        theta, omega = dynamics_step(theta, omega, np.zeros_like(theta), params)
    return float(np.max(np.abs(energy(theta, omega, params) - e0)))


def test_energy_is_conserved_without_torque_and_friction() -> None:
    # Over a 150-step episode (7.5 s) the drift is at the level of the RK4 truncation error ...
    drift = _energy_drift(4)
    assert drift < 1e-5 * PendulumParams().mgl
    # ... and shrinks like h^4 (fourth-order integrator): halving h divides it by ~16.
    assert _energy_drift(8) < drift / 10


def test_friction_dissipates_energy() -> None:
    params = replace(PendulumParams(), friction=0.5)
    theta, omega = np.array([1.0]), np.array([2.0])
    e0 = energy(theta, omega, params)
    for _ in range(50):
        theta, omega = dynamics_step(theta, omega, np.zeros(1), params)
    assert energy(theta, omega, params)[0] < e0[0]


def test_torque_cannot_hold_the_pendulum_horizontal() -> None:
    # The limit is below m g l: swinging up is required (this is what makes the value jump).
    params = PendulumParams()
    assert params.max_torque < params.mgl
    theta, omega = np.array([math.pi / 2]), np.array([0.0])
    for _ in range(20):
        theta, omega = dynamics_step(theta, omega, np.array([-params.max_torque]), params)
    assert abs(theta[0]) > math.pi / 2


def test_wrap_angle() -> None:
    x = np.array([-7.0, -math.pi, 0.0, math.pi, 7.0])
    w = wrap_angle(x)
    assert np.all(w >= -math.pi) and np.all(w < math.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(x))
    np.testing.assert_allclose(np.sin(w), np.sin(x), atol=1e-12)


@pytest.mark.parametrize(
    ("theta", "tip", "empty"),
    [  # (row, column) offsets from the pivot: the tip, and the opposite end (no rod there)
        (0.0, (-48, 0), (48, 0)),  # upright: tip above the pivot
        (math.pi / 2, (0, -48), (0, 48)),  # counter-clockwise a quarter turn: to the left
        (-math.pi, (48, 0), (-48, 0)),  # hanging
    ],
)
def test_render_draws_the_rod_at_its_angle(
    theta: float, tip: tuple[int, int], empty: tuple[int, int]
) -> None:
    """``render_mode="rgb_array"``: a 128-pixel front view, the pivot at the centre, the bob
    (red) 48 pixels from it in the direction of ``theta`` (0 up, counter-clockwise positive),
    nothing on the other side; without a render mode, ``None``."""
    env = PaperPendulum(render_mode="rgb_array")
    env.reset(seed=0, options={"state": (theta, 0.0)})
    img = env.render()
    assert img is not None and img.shape == (128, 128, 3) and img.dtype == np.uint8
    centre = 63.5
    row, col = (round(centre + d) for d in tip)
    assert tuple(img[row, col]) == (220, 0, 0)
    row, col = (round(centre + d) for d in empty)
    assert tuple(img[row, col]) == (255, 255, 255)
    assert PaperPendulum().render() is None
    with pytest.raises(ValueError, match="render_mode must be None or 'rgb_array'"):
        PaperPendulum(render_mode="human")


def test_sb3_make_vec_env_builds_it_without_a_render_warning() -> None:
    """SB3's ``make_vec_env`` asks every environment for ``render_mode="rgb_array"``; the
    registered PaperPendulum supports it, so gymnasium does not warn."""
    from stable_baselines3.common.env_util import make_vec_env

    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        env = make_vec_env(PAPER_PENDULUM_ID, n_envs=1)
    env.close()
