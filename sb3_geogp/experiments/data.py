"""Value-function training data from gymnasium environments (states, discounted returns)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from sb3_geogp.targets import discounted_returns


def swing_up_action(obs: np.ndarray, max_torque: float = 2.0) -> float:
    """Deterministic swing-up controller for ``Pendulum-v1`` (m = l = 1, g = 10).

    Near the top (``cos theta > 0.85``) a saturated PD law ``u = -10 theta - 2 theta_dot``;
    elsewhere energy pumping ``u = max_torque * sign((E* - E) theta_dot)`` with
    ``E = theta_dot^2 / 6 + 5 cos theta`` (per unit ``m l^2``) and ``E* = 5`` the energy at rest
    on top.

    Parameters
    ----------
    obs : ndarray, shape (3,)
        ``(cos theta, sin theta, theta_dot)``.
    max_torque : float
        Saturation.
    """
    cos_t, sin_t, vel = (float(v) for v in obs)
    theta = np.arctan2(sin_t, cos_t)
    if cos_t > 0.85:
        u = -10.0 * theta - 2.0 * vel
    else:
        energy = vel**2 / 6.0 + 5.0 * cos_t
        u = max_torque * np.sign((5.0 - energy) * vel + 1e-9)
    return float(np.clip(u, -max_torque, max_torque))


def pendulum_rollouts(
    n_steps: int, seed: int = 0, gamma: float = 0.99, episode_length: int = 200
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Trajectories of ``Pendulum-v1`` under a noisy swing-up-and-balance controller.

    Energy pumping far from the top, a PD balance near it (see :func:`swing_up_action`), plus
    Gaussian noise of std 0.2: whether the pendulum is caught on this swing or the next
    depends sharply on the state, so the value function has the ridges the paper is about.

    Parameters
    ----------
    n_steps : int
        Total number of transitions (whole episodes of ``episode_length``, the last one cut).
    seed : int
        Seeds the environment resets and the action noise.
    gamma : float
        Discount of the returns.
    episode_length : int
        Steps per episode.

    Returns
    -------
    obs : ndarray, shape (n_steps, 3)
        ``(cos theta, sin theta, theta_dot)``.
    returns : ndarray, shape (n_steps,)
        Discounted returns-to-go within each (possibly cut) episode.
    starts : ndarray of bool, shape (n_steps,)
        Episode starts.
    """
    env = gym.make("Pendulum-v1", max_episode_steps=episode_length)
    rng = np.random.default_rng(seed)
    obs_list: list[np.ndarray] = []
    rewards: list[float] = []
    starts: list[bool] = []
    episode = 0
    while len(obs_list) < n_steps:
        obs, _ = env.reset(seed=seed * 100_003 + episode)
        episode += 1
        for t in range(episode_length):
            if len(obs_list) == n_steps:
                break
            action = np.clip(swing_up_action(obs) + rng.normal(0.0, 0.2), -2.0, 2.0)
            obs_list.append(obs)
            starts.append(t == 0)
            obs, reward, _, _, _ = env.step(np.array([action], dtype=np.float32))
            rewards.append(float(reward))
    env.close()
    starts_arr = np.asarray(starts, dtype=bool)
    # An episode ends where the next one starts, and at the (possibly cut) last step.
    ends = np.append(starts_arr[1:], True)
    returns = discounted_returns(np.asarray(rewards, dtype=np.float64), ends, gamma)
    return np.asarray(obs_list, dtype=np.float64), returns, starts_arr
