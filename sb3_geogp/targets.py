"""Value targets for the GP critic, and rollouts cut into trajectories (numpy only, no SB3).

The SB3 adapter (:mod:`sb3_geogp.callbacks`) keeps no maths of its own: it cuts rollouts into
per-environment trajectories and asks this module for their targets.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: One environment's steps not fed yet: (observations, rewards, episode starts), time order.
Segment = tuple[np.ndarray, np.ndarray, np.ndarray]


def discounted_returns(rewards: np.ndarray, episode_ends: np.ndarray, gamma: float) -> np.ndarray:
    """Discounted return-to-go of every step, restarting after each episode end.

    ``G_t = r_t + gamma * G_{t+1} * (1 - end_t)``, with ``G`` after the last step taken as 0.

    Parameters
    ----------
    rewards : ndarray, shape (n,)
        Rewards in time order. A time-limit bootstrap (``gamma * V(s_terminal)``) is expected
        to be folded into the reward of the truncated step already, as SB3 does.
    episode_ends : ndarray of bool, shape (n,)
        ``True`` on the last step of each episode.
    gamma : float
        Discount factor in [0, 1].

    Returns
    -------
    ndarray, shape (n,), float64
        The return-to-go of each step within its own episode.
    """
    rewards = np.asarray(rewards, dtype=np.float64)
    ends = np.asarray(episode_ends, dtype=bool)
    if rewards.ndim != 1 or ends.shape != rewards.shape:
        raise ValueError(
            f"rewards and episode_ends must be 1-D of equal length, got {rewards.shape} "
            f"and {ends.shape}"
        )
    out = np.empty_like(rewards)
    acc = 0.0
    for t in range(len(rewards) - 1, -1, -1):
        acc = rewards[t] + (0.0 if ends[t] else gamma * acc)
        out[t] = acc
    return out


def horizon_bootstraps(episode_ends: np.ndarray, horizon: int, n_steps: int) -> np.ndarray:
    """Where the ``horizon``-step return of each of the first ``n_steps`` steps bootstraps.

    Parameters
    ----------
    episode_ends : ndarray of bool, shape (n,)
        ``True`` on the last step of each episode.
    horizon : int
        ``H >= 1``.
    n_steps : int
        The steps asked for, the first ones; each must have its ``H`` successors in the data or
        its episode's end within ``H`` steps.

    Returns
    -------
    ndarray of int, shape (n_steps,)
        ``t + H`` where step ``t``'s episode goes on past ``t + H - 1``, else -1 (the return is
        the discounted rest of the episode).
    """
    end_steps = np.flatnonzero(np.asarray(episode_ends, dtype=bool))
    steps = np.arange(n_steps)
    # The first episode end at or after each step (none: beyond any horizon).
    next_end = np.append(end_steps, np.iinfo(np.int64).max)[np.searchsorted(end_steps, steps)]
    out = np.where(next_end - steps < horizon, -1, steps + horizon)
    if np.any(out >= len(episode_ends)):
        raise ValueError(f"the {horizon}-step returns of the first {n_steps} steps need more data")
    return out


def horizon_returns(
    rewards: np.ndarray,
    episode_ends: np.ndarray,
    gamma: float,
    bootstraps: np.ndarray,
    values: np.ndarray,
) -> np.ndarray:
    """``H``-step returns: ``sum_{k<H} gamma^k r_{t+k} + gamma^H V(s_{t+H})``, or the
    discounted rest of the episode where it ends within ``H`` steps.

    Parameters
    ----------
    rewards : ndarray, shape (n,)
        As :func:`discounted_returns`.
    episode_ends : ndarray of bool, shape (n,)
    gamma : float
    bootstraps : ndarray of int, shape (m,)
        :func:`horizon_bootstraps` of the first ``m`` steps.
    values : ndarray, shape (m,)
        The critic's value of the state at ``bootstraps[t]`` (ignored where it is -1).

    Returns
    -------
    ndarray, shape (m,), float64
    """
    # Within an episode G_t = sum_{k<H} gamma^k r_{t+k} + gamma^H G_{t+H} (also where the data
    # stop before its end: both sums run to the same last step), so swapping G_{t+H} for V
    # gives the cut return.
    returns = discounted_returns(rewards, episode_ends, gamma)
    out = returns[: len(bootstraps)].copy()
    (cut,) = np.nonzero(bootstraps >= 0)
    stops = bootstraps[cut]
    out[cut] += gamma ** (stops - cut) * (np.asarray(values)[cut] - returns[stops])
    return out


def split_completed(episode_starts: np.ndarray, last_done: bool) -> tuple[np.ndarray, int]:
    """Episode ends of one environment's trajectory and the length of its completed part.

    Parameters
    ----------
    episode_starts : ndarray of bool, shape (n,)
        ``True`` on the first step of an episode (SB3's ``episode_starts`` column).
    last_done : bool
        Whether the last step ended an episode (SB3's ``dones`` after the last step).

    Returns
    -------
    episode_ends : ndarray of bool, shape (n,)
        ``True`` on the last step of each episode.
    n_completed : int
        Number of leading steps that belong to completed episodes (0 if none completed).
    """
    starts = np.asarray(episode_starts, dtype=bool)
    ends = np.zeros(starts.shape, dtype=bool)
    if starts.size:
        ends[:-1] = starts[1:]
        ends[-1] = bool(last_done)
    idx = np.flatnonzero(ends)
    return ends, int(idx[-1]) + 1 if idx.size else 0


def env_major(a: np.ndarray) -> np.ndarray:
    """Time-major ``(n_steps, n_envs, ...)`` reordered env by env, ``(n_envs * n_steps, ...)``."""
    return np.swapaxes(a, 0, 1).reshape(-1, *a.shape[2:])


def per_env(
    observations: np.ndarray, targets: np.ndarray, episode_starts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A rollout's time-major arrays reordered env by env, each env in time order.

    Parameters
    ----------
    observations : ndarray, shape (n_steps, n_envs, *obs_shape)
    targets : ndarray, shape (n_steps, n_envs)
    episode_starts : ndarray, shape (n_steps, n_envs)
        SB3's ``episode_starts`` column.

    Returns
    -------
    observations : ndarray, shape (n_envs * n_steps, *obs_shape)
    targets : ndarray, shape (n_envs * n_steps,)
    episode_starts : ndarray of bool, shape (n_envs * n_steps,)
        ``True`` on each env's first step (a trajectory starts there for the GP), and where
        an episode starts.
    """
    starts = np.swapaxes(episode_starts, 0, 1).astype(bool)
    starts[:, 0] = True
    return env_major(observations), env_major(targets), starts.reshape(-1)


def empty_segment(obs_shape: tuple[int, ...]) -> Segment:
    """A :data:`Segment` with no steps, observations of shape ``obs_shape``."""
    return (
        np.empty((0, *obs_shape), dtype=np.float32),
        np.empty(0, dtype=np.float64),
        np.empty(0, dtype=bool),
    )


def completed_returns(
    pending: list[Segment],
    observations: np.ndarray,
    rewards: np.ndarray,
    episode_starts: np.ndarray,
    dones: np.ndarray,
    gamma: float,
    horizon: int | None,
    value: Callable[[np.ndarray], np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Monte Carlo targets of the steps a rollout completes, env by env.

    Each env's pending steps and the rollout's are stitched in time order; the steps of
    completed episodes get their discounted returns (:func:`discounted_returns`), and with a
    ``horizon`` also the steps whose ``horizon`` successors have arrived (their returns cut
    there with ``value`` of the state reached, :func:`horizon_returns`). The other steps wait:
    ``pending`` is updated in place.

    Parameters
    ----------
    pending : list of Segment, one per env
        Each env's steps not fed yet; replaced by those still waiting.
    observations : ndarray, shape (n_steps, n_envs, *obs_shape)
    rewards : ndarray, shape (n_steps, n_envs)
        Time-limit bootstraps folded in, as SB3 folds them.
    episode_starts : ndarray, shape (n_steps, n_envs)
        SB3's ``episode_starts`` column.
    dones : ndarray of bool, shape (n_envs,)
        Whether each env's last step ended an episode.
    gamma : float
    horizon : int or None
        Where returns are cut (``None``: not cut).
    value : callable
        The critic's values of states, shape (k, *obs_shape) -> (k,); called once, with the
        states where returns are cut, and only with a ``horizon``.

    Returns
    -------
    observations : ndarray, shape (n, *obs_shape)
    targets : ndarray, shape (n,), float64
    starts : ndarray of bool, shape (n,)
        ``True`` where a trajectory fed starts (each env's first step fed, and episode starts).
    """
    # Per env with steps to feed: stitched observations, rewards, episode ends, trajectory
    # starts of the steps fed, and how many are fed (the first ones).
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]] = []
    for env in range(observations.shape[1]):
        old_obs, old_rew, old_starts = pending[env]
        obs = np.concatenate([old_obs, observations[:, env]])
        rew = np.concatenate([old_rew, rewards[:, env].astype(np.float64)])
        starts = np.concatenate([old_starts, episode_starts[:, env].astype(bool)])
        ends, n_ready = split_completed(starts, bool(dones[env]))
        if horizon is not None:
            n_ready = max(n_ready, len(obs) - horizon)
        pending[env] = (obs[n_ready:], rew[n_ready:], starts[n_ready:])
        if n_ready:
            chunk_starts = starts[:n_ready].copy()
            chunk_starts[0] = True
            parts.append((obs, rew, ends, chunk_starts, n_ready))
    if not parts:
        obs_shape = observations.shape[2:]
        return (
            np.empty((0, *obs_shape), dtype=observations.dtype),
            np.empty(0),
            np.empty(0, dtype=bool),
        )
    return (
        np.concatenate([obs[:n] for obs, _, _, _, n in parts]),
        np.concatenate(_part_returns(parts, gamma, horizon, value)),
        np.concatenate([s for _, _, _, s, _ in parts]),
    )


def _part_returns(
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]],
    gamma: float,
    horizon: int | None,
    value: Callable[[np.ndarray], np.ndarray],
) -> list[np.ndarray]:
    """Targets of the steps fed from each env's stitched trajectory; with a ``horizon``, the
    values that close the cut returns come from one call of ``value`` for all envs."""
    if horizon is None:
        return [discounted_returns(rew[:n], ends[:n], gamma) for _, rew, ends, _, n in parts]
    bootstraps = [horizon_bootstraps(ends, horizon, n) for _, _, ends, _, n in parts]
    cut_states = [obs[b[b >= 0]] for (obs, *_), b in zip(parts, bootstraps, strict=True)]
    values = value(np.concatenate(cut_states))
    sections = np.cumsum([len(s) for s in cut_states])[:-1]
    out = []
    for (_, rew, ends, _, n), b, v in zip(
        parts, bootstraps, np.split(values, sections), strict=True
    ):
        at_cut = np.zeros(n)
        at_cut[b >= 0] = v
        out.append(horizon_returns(rew, ends, gamma, b, at_cut))
    return out
