"""Streams of value-function training data and the on-line passes that feed them to a GP.

* :func:`pendulum_rollouts`: ``Pendulum-v1`` transitions with discounted returns, under a
  noisy swing-up controller (:func:`swing_up_action`);
* :class:`Rollout` and :func:`pendulum_stream`: those transitions as tensors, in batches the
  size of a rollout buffer (the engine benchmarks); :func:`drifting_stream` and
  :func:`one_hot_stream`, the soak's stress cases;
* :func:`episode_batches` and :func:`fit_online`: one on-line pass over recorded episodes,
  a number of whole episodes per update (the studies).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch

from sb3_geogp.kernels import Kernel
from sb3_geogp.sparse_gp import SparseOnlineGP
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


@dataclass(frozen=True)
class Rollout:
    """States ``x`` (n, d), discounted returns ``y`` (n,) and episode ``starts`` (n,), float64."""

    x: torch.Tensor
    y: torch.Tensor
    starts: torch.Tensor

    @classmethod
    def pendulum(cls, n_points: int, seed: int) -> Rollout:
        """``pendulum_rollouts(n_points, seed)`` as tensors."""
        x, y, starts = pendulum_rollouts(n_points, seed=seed)
        return cls(torch.as_tensor(x), torch.as_tensor(y), torch.as_tensor(starts))

    def __len__(self) -> int:
        return int(self.y.shape[0])

    def slice(self, start: int, stop: int) -> Rollout:
        """Rows ``start:stop``."""
        return Rollout(self.x[start:stop], self.y[start:stop], self.starts[start:stop])

    def feed(self, gp: SparseOnlineGP) -> None:
        """``gp.update`` with the whole rollout (in order, with its episode starts)."""
        gp.update(self.x, self.y, self.starts)


def pendulum_stream(
    n_points: int, batch_size: int, chunk_batches: int = 16, first_seed: int = 1
) -> Iterator[Rollout]:
    """Pendulum transitions in batches of ``batch_size``, ``n_points`` in total.

    Rollouts are generated in chunks of ``chunk_batches`` batches with seeds ``first_seed``,
    ``first_seed + 1``, ...; a batch may end inside an episode (as a PPO rollout buffer does),
    a chunk starts a new one.
    """
    seed, remaining = first_seed, n_points
    while remaining > 0:
        chunk = Rollout.pendulum(min(remaining, chunk_batches * batch_size), seed)
        for start in range(0, len(chunk), batch_size):
            yield chunk.slice(start, start + batch_size)
        remaining -= len(chunk)
        seed += 1


def drifting_stream(
    n_points: int, batch_size: int, dim: int = 3, step: float = 0.05, seed: int = 0
) -> Iterator[Rollout]:
    """A random walk that keeps moving into new regions, target ``sum(sin(x))``.

    The stress case of a full basis (issue 11, defect 2): almost every point is novel, and
    most novel points are judged least informative and projected. One trajectory throughout.
    """
    rng = np.random.default_rng(seed)
    position, remaining = np.zeros(dim), n_points
    while remaining > 0:
        n = min(remaining, batch_size)
        x = position + np.cumsum(rng.normal(scale=step, size=(n, dim)), axis=0)
        position, remaining = x[-1], remaining - n
        starts = np.zeros(n, dtype=bool)
        yield Rollout(
            torch.as_tensor(x), torch.as_tensor(np.sin(x).sum(1)), torch.as_tensor(starts)
        )


def one_hot_stream(
    n_points: int, batch_size: int, n_states: int = 400, episode: int = 100, seed: int = 0
) -> Iterator[Rollout]:
    """A random walk on a ring of ``n_states`` states, observed one-hot (a ``Discrete`` space as
    SB3 encodes it), target ``cos(2 pi s / n_states)`` plus noise of sd 0.1.

    The stress case of discrete observations: states repeat exactly, so a point lies on a basis
    vector unless the basis has had to drop its state, and from 32 states on the distances come
    from the matrix product
    (:data:`~sb3_geogp.kernels.base.PRODUCT_MIN_DIM`). Episodes of ``episode`` steps, each from
    a random state; a batch may end inside one.
    """
    rng = np.random.default_rng(seed)
    eye, state, t, remaining = np.eye(n_states), 0, 0, n_points
    while remaining > 0:
        n = min(remaining, batch_size)
        states, starts = np.empty(n, dtype=np.int64), np.zeros(n, dtype=bool)
        for i in range(n):
            if t % episode == 0:
                state, starts[i] = int(rng.integers(n_states)), True
            else:
                state = (state + int(rng.choice((-1, 1)))) % n_states
            states[i], t = state, t + 1
        y = np.cos(2 * np.pi * states / n_states) + rng.normal(scale=0.1, size=n)
        remaining -= n
        yield Rollout(torch.as_tensor(eye[states]), torch.as_tensor(y), torch.as_tensor(starts))


def episode_batches(episode_starts: np.ndarray, episodes_per_batch: int | None) -> Iterator[slice]:
    """Row ranges of consecutive whole episodes, ``episodes_per_batch`` episodes each.

    Parameters
    ----------
    episode_starts : ndarray of bool, shape (n,)
        ``True`` on the first row of every episode.
    episodes_per_batch : int or None
        Episodes per range (the last range may hold fewer); ``None``: one range of all rows.

    Yields
    ------
    slice
        Non-empty, in order, covering all ``n`` rows.
    """
    n = len(episode_starts)
    if episodes_per_batch is not None and episodes_per_batch < 1:
        raise ValueError(f"episodes_per_batch must be positive, got {episodes_per_batch}")
    if episodes_per_batch is None:
        bounds = [0, n]
    else:
        firsts = np.flatnonzero(episode_starts)
        bounds = [0, *firsts[episodes_per_batch::episodes_per_batch].tolist(), n]
    for a, b in itertools.pairwise(bounds):
        if b > a:
            yield slice(a, b)


def fit_online(
    kernel: Kernel,
    states: np.ndarray,
    targets: np.ndarray,
    episode_starts: np.ndarray,
    max_basis: int,
    noise_var: float,
    novelty_tol: float | None,
    episodes_per_batch: int | None = None,
) -> SparseOnlineGP:
    """A new :class:`~sb3_geogp.SparseOnlineGP` fitted in one on-line pass over episodes.

    Parameters
    ----------
    kernel : Kernel
        Used by the GP (not copied).
    states : ndarray, shape (n, d)
    targets : ndarray, shape (n,)
    episode_starts : ndarray of bool, shape (n,)
    max_basis, noise_var, novelty_tol
        As :class:`~sb3_geogp.SparseOnlineGP`.
    episodes_per_batch : int or None
        Whole episodes per :meth:`~sb3_geogp.SparseOnlineGP.update` call, in order, as a
        critic sees rollouts (:func:`episode_batches`); ``None``: one call with everything.
    """
    gp = SparseOnlineGP(
        states.shape[1],
        kernel=kernel,
        max_basis=max_basis,
        noise_var=noise_var,
        novelty_tol=novelty_tol,
    )
    for rows in episode_batches(episode_starts, episodes_per_batch):
        gp.update(states[rows], targets[rows], episode_starts=episode_starts[rows])
    return gp
