"""Ground-truth value of the fixed pendulum policy on the paper's 60 x 60 grid.

Two estimates of ``V^pi(s) = E[sum_{t < H} gamma^t r_t | s_0 = s]`` (``H = task.horizon``,
``gamma^H <= 1e-4``, i.e. the discounted value up to a negligible tail):

* :func:`mc_value` (the reference): ``n_rollouts`` independent noisy rollouts from the centre
  of every grid cell, all simulated in parallel with numpy, with the standard error of each
  cell's mean;
* :func:`td_baseline` (the paper's baseline): tabular TD(0) on the discretised state space
  (one table entry per grid cell) from 800 episodes of 150 steps, run to convergence, i.e.
  the batch TD(0) fixed point ``V = r_hat + gamma P_hat V`` of the empirical cell-to-cell
  model, computed exactly with a sparse solve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from sb3_geogp.envs.pendulum import dynamics_step
from sb3_geogp.studies.pendulum.task import Task


@dataclass
class GridValue:
    """A value estimate on the ``n x n`` grid of :meth:`Task.grid`.

    Attributes
    ----------
    value : ndarray, shape (n * n,)
        Estimate per cell (row-major, ``omega`` the slow index).
    stderr : ndarray, shape (n * n,)
        Standard error of each cell's estimate (NaN where not available).
    n : int
        Cells per axis.
    """

    value: np.ndarray
    stderr: np.ndarray
    n: int

    def image(self) -> np.ndarray:
        """The value as an image, shape (n, n): ``[omega index, theta index]``."""
        return self.value.reshape(self.n, self.n)


def mc_value(
    task: Task,
    n: int = 60,
    n_rollouts: int = 100,
    seed: int = 12345,
    chunk: int = 200_000,
) -> GridValue:
    """Monte Carlo value of the noisy policy from the centre of every grid cell.

    Parameters
    ----------
    task : Task
    n : int
        Cells per axis.
    n_rollouts : int
        Independent rollouts per cell (``>= 2`` for a standard error).
    seed : int
        Seeds the torque noise.
    chunk : int
        Rollouts simulated at once (bounds memory: a few arrays of this length).

    Returns
    -------
    GridValue
        Mean discounted return over ``task.horizon`` steps, and its standard error
        ``std / sqrt(n_rollouts)``.
    """
    states, _, _ = task.grid(n)
    value, stderr = mc_value_at(task, states, n_rollouts, seed, chunk)
    return GridValue(value, stderr, n)


def mc_value_at(
    task: Task,
    states: np.ndarray,
    n_rollouts: int,
    seed: int,
    chunk: int = 200_000,
) -> tuple[np.ndarray, np.ndarray]:
    """Monte Carlo value (and its standard error) at arbitrary states.

    Parameters
    ----------
    task : Task
    states : ndarray, shape (n, 2)
    n_rollouts : int
        Independent rollouts per state (``>= 2``).
    seed : int
    chunk : int
        Rollouts simulated at once.

    Returns
    -------
    value, stderr : ndarray, shape (n,)
    """
    if n_rollouts < 2:
        raise ValueError(f"n_rollouts must be >= 2 for a standard error, got {n_rollouts}")
    starts = np.repeat(np.asarray(states, dtype=np.float64), n_rollouts, axis=0)
    rng = np.random.default_rng(seed)
    returns = np.empty(len(starts))
    for lo in range(0, len(starts), chunk):
        returns[lo : lo + chunk] = _discounted_returns(task, starts[lo : lo + chunk], rng)
    per_state = returns.reshape(len(states), n_rollouts)
    return per_state.mean(axis=1), per_state.std(axis=1, ddof=1) / math.sqrt(n_rollouts)


def _discounted_returns(task: Task, starts: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One discounted ``task.horizon``-step return per start, shape (len(starts),)."""
    theta, omega = starts[:, 0].copy(), starts[:, 1].copy()
    total = np.zeros(len(starts))
    discount = 1.0
    for _ in range(task.horizon):
        total += discount * task.reward_fn(theta)
        discount *= task.gamma
        torque = task.policy.sample(theta, omega, task.params, rng)
        theta, omega = dynamics_step(theta, omega, torque, task.params)
    return total


def cell_index(states: np.ndarray, task: Task, n: int) -> np.ndarray:
    """Grid cell of each state (omega clipped into the box), shape (len(states),)."""
    i_theta = np.floor((states[..., 0] + math.pi) / (2 * math.pi) * n).astype(np.int64) % n
    frac = (states[..., 1] + task.speed_limit) / (2 * task.speed_limit)
    i_omega = np.clip(np.floor(frac * n).astype(np.int64), 0, n - 1)
    return i_omega * n + i_theta


@dataclass
class TDResult(GridValue):
    """Tabular TD(0) values plus their support.

    Attributes
    ----------
    visits : ndarray of int, shape (n * n,)
        Transitions observed from each cell; cells with none keep TD's initial value 0.
    """

    visits: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def coverage(self) -> float:
        """Fraction of cells visited at least once."""
        return float(np.mean(self.visits > 0))


def td_baseline(
    task: Task,
    n: int = 60,
    n_episodes: int = 800,
    seed: int = 777,
) -> TDResult:
    """The paper's baseline: tabular TD(0) from ``n_episodes`` episodes, run to convergence.

    Episodes of ``task.params.episode_length`` steps start uniformly over the box (as the
    training data do). TD(0) iterated over this fixed data set until convergence reaches the
    fixed point of the empirical model (batch TD): for every visited cell ``c``,
    ``V(c) = r_hat(c) + gamma sum_c' P_hat(c' | c) V(c')``, with ``r_hat`` the mean reward
    and ``P_hat`` the transition frequencies observed from ``c`` (the 150th transition of an
    episode bootstraps, a time limit is not a terminal state). Unvisited cells keep the
    initial value 0; we solve the linear system directly.

    Parameters
    ----------
    task : Task
    n : int
        Cells per axis.
    n_episodes : int
    seed : int

    Returns
    -------
    TDResult
        Values (standard errors are NaN: a batch TD solution has none in closed form).
    """
    rng = np.random.default_rng(seed)
    L = task.params.episode_length
    states, rewards = task.rollout_rewards(task.sample_starts(n_episodes, rng), L + 1, rng)
    cells = cell_index(states, task, n)
    src, dst = cells[:, :L].ravel(), cells[:, 1:].ravel()
    r = rewards[:, :L].ravel()
    n_cells = n * n
    visits = np.bincount(src, minlength=n_cells)
    r_hat = np.bincount(src, weights=r, minlength=n_cells).astype(np.float64)
    seen = visits > 0
    r_hat[seen] /= visits[seen]
    counts = sparse.coo_matrix((np.ones_like(r), (src, dst)), shape=(n_cells, n_cells)).tocsr()
    P_hat = sparse.diags(1.0 / np.maximum(visits, 1)) @ counts
    idx = np.flatnonzero(seen)
    # Unvisited successors contribute gamma * 0 (their initial value).
    A = sparse.identity(len(idx), format="csr") - task.gamma * P_hat[idx][:, idx]
    value = np.zeros(n_cells)
    value[idx] = spsolve(A.tocsc(), r_hat[idx])
    return TDResult(value, np.full(n_cells, np.nan), n, visits)
