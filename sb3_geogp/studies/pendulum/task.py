"""The paper's fixed Gaussian policy on :class:`~sb3_geogp.envs.PaperPendulum` and its data.

The policy is ``pi(a | s) = N(f(s), sigma^2)`` clipped to the torque limit (paper sec. 4),
with a deterministic swing-up-and-balance controller ``f`` (:class:`FixedPolicy`):

* balance (``|theta| < catch_angle``): saturated PD, ``f = clip(-k_p theta - k_d omega)``;
* elsewhere, energy pumping towards the upright energy ``E* = m g l``:
  ``f = clip(k_E (E* - E) omega)``.

The torque limit (5 N m, half of ``m g l``) makes the balance region's basin of attraction a
thin band around the upright; states just inside it are caught now, states just outside
swing once more, so the value function jumps across the band's edges and along spirals.

Training data (:func:`policy_episodes`) are episodes of this policy from uniform random
starts, with discounted Monte Carlo returns as targets (paper sec. 2). Unlike the paper,
each return is completed past the 150-step episode end by continuing the rollout for
``horizon`` steps (the extra steps are not training states): a return truncated at the
episode end estimates a *time-dependent* value, which no function of the state alone can
fit, so the truncation bias would swamp every difference between the models.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sb3_geogp.envs.pendulum import PendulumParams, dynamics_step, energy, reward


@dataclass(frozen=True)
class FixedPolicy:
    """Deterministic swing-up-and-balance controller plus fixed Gaussian torque noise.

    Attributes
    ----------
    k_p : float
        Balance proportional gain, N m / rad.
    k_d : float
        Balance derivative gain, N m s / rad.
    k_energy : float
        Energy-pumping gain, N m per (J rad/s).
    catch_angle : float
        Half-width of the balance region, rad (``|theta| < catch_angle``).
    noise_std : float
        Standard deviation ``sigma`` of the Gaussian torque noise, N m.
    """

    k_p: float = 40.0
    k_d: float = 10.0
    k_energy: float = 0.5
    catch_angle: float = 0.6
    noise_std: float = 1.0

    def mean_action(
        self, theta: np.ndarray, omega: np.ndarray, params: PendulumParams
    ) -> np.ndarray:
        """Deterministic torque ``f(s)``, clipped to the limit; shape of ``theta``."""
        u_max = params.max_torque
        pump = self.k_energy * (params.mgl - energy(theta, omega, params)) * omega
        balance = -self.k_p * theta - self.k_d * omega
        near_top = np.cos(theta) > math.cos(self.catch_angle)
        return np.clip(np.where(near_top, balance, pump), -u_max, u_max)

    def sample(
        self,
        theta: np.ndarray,
        omega: np.ndarray,
        params: PendulumParams,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """Torque ``f(s) + sigma eps``, ``eps ~ N(0, 1)``, clipped; shape of ``theta``."""
        noise = self.noise_std * rng.standard_normal(np.shape(theta))
        return np.clip(
            self.mean_action(theta, omega, params) + noise, -params.max_torque, params.max_torque
        )


@dataclass(frozen=True)
class Task:
    """The evaluation task: dynamics, policy, discount and the state box of the grid.

    Attributes
    ----------
    params : PendulumParams
    policy : FixedPolicy
    gamma : float
        Discount factor.
    speed_limit : float
        The grid and the start distribution cover ``omega`` in ``[-speed_limit, speed_limit]``.
    horizon_tol : float
        Returns are summed over ``horizon`` steps, the first with ``gamma^horizon <= horizon_tol``.
    reward_fn : callable
        ``theta (n,) -> reward (n,)``; the environment's :func:`~sb3_geogp.envs.pendulum.reward`
        (``cos theta``). Replaceable to test the estimators against closed forms.
    """

    params: PendulumParams = field(default_factory=PendulumParams)
    policy: FixedPolicy = field(default_factory=FixedPolicy)
    gamma: float = 0.97
    speed_limit: float = 8.0
    horizon_tol: float = 1e-4
    reward_fn: Callable[[np.ndarray], np.ndarray] = field(default=reward, repr=False, compare=False)

    @property
    def horizon(self) -> int:
        """Number of discounted steps in a return (``gamma^horizon <= horizon_tol``)."""
        return math.ceil(math.log(self.horizon_tol) / math.log(self.gamma))

    def grid(self, n: int = 60) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell centres of an ``n x n`` grid over the state box.

        Returns
        -------
        states : ndarray, shape (n * n, 2)
            ``(theta, omega)`` of every cell, row-major with ``omega`` the slow index.
        thetas : ndarray, shape (n,)
        omegas : ndarray, shape (n,)
        """
        thetas = -math.pi + (np.arange(n) + 0.5) * (2 * math.pi / n)
        omegas = -self.speed_limit + (np.arange(n) + 0.5) * (2 * self.speed_limit / n)
        om, th = np.meshgrid(omegas, thetas, indexing="ij")
        return np.stack([th.ravel(), om.ravel()], axis=1), thetas, omegas

    def sample_starts(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` start states uniform over the box, shape (n, 2)."""
        theta = rng.uniform(-math.pi, math.pi, n)
        omega = rng.uniform(-self.speed_limit, self.speed_limit, n)
        return np.stack([theta, omega], axis=1)

    def rollout_rewards(
        self, starts: np.ndarray, n_steps: int, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray]:
        """Roll the noisy policy from each start for ``n_steps`` steps, all in parallel.

        Parameters
        ----------
        starts : ndarray, shape (n, 2)
        n_steps : int
        rng : numpy Generator
            Draws the torque noise.

        Returns
        -------
        states : ndarray, shape (n, n_steps, 2)
            The state at each step (``states[:, 0] = starts``).
        rewards : ndarray, shape (n, n_steps)
            Reward of each step.
        """
        theta = np.array(starts[:, 0], dtype=np.float64)
        omega = np.array(starts[:, 1], dtype=np.float64)
        states = np.empty((len(starts), n_steps, 2))
        rewards = np.empty((len(starts), n_steps))
        for t in range(n_steps):
            states[:, t, 0], states[:, t, 1] = theta, omega
            rewards[:, t] = self.reward_fn(theta)
            torque = self.policy.sample(theta, omega, self.params, rng)
            theta, omega = dynamics_step(theta, omega, torque, self.params)
        return states, rewards


@dataclass
class EpisodeData:
    """States of whole episodes with their discounted returns.

    Attributes
    ----------
    states : ndarray, shape (n, 2)
        ``(theta, omega)`` in trajectory order, episode after episode.
    returns : ndarray, shape (n,)
        Discounted Monte Carlo return of each state.
    episode_starts : ndarray of bool, shape (n,)
        ``True`` on the first step of every episode.
    episode_length : int
        States per episode.
    """

    states: np.ndarray
    returns: np.ndarray
    episode_starts: np.ndarray
    episode_length: int

    @property
    def n_episodes(self) -> int:
        """Number of episodes."""
        return len(self.states) // self.episode_length

    def episodes(self, index: slice | np.ndarray) -> EpisodeData:
        """The selected episodes (a slice or integer array over episode numbers)."""
        L = self.episode_length
        ids = np.arange(self.n_episodes)[index]
        rows = (ids[:, None] * L + np.arange(L)[None, :]).ravel()
        return EpisodeData(self.states[rows], self.returns[rows], self.episode_starts[rows], L)


def discounted_tail_sums(rewards: np.ndarray, gamma: float, horizon: int) -> np.ndarray:
    """Discounted sums of the next ``horizon`` rewards from each step.

    Parameters
    ----------
    rewards : ndarray, shape (n, T)
        Rewards along ``n`` rollouts; ``T >= horizon``.
    gamma : float
    horizon : int

    Returns
    -------
    ndarray, shape (n, T - horizon + 1)
        ``G[:, t] = sum_{i < horizon} gamma^i rewards[:, t + i]``.
    """
    n, T = rewards.shape
    if horizon > T:
        raise ValueError(f"horizon {horizon} exceeds the rollout length {T}")
    # Backward recursion of the infinite-tail sum, then subtract the part beyond the horizon.
    tail = np.zeros((n, T + 1))
    for t in range(T - 1, -1, -1):
        tail[:, t] = rewards[:, t] + gamma * tail[:, t + 1]
    steps = T - horizon + 1
    return tail[:, :steps] - gamma**horizon * tail[:, horizon : horizon + steps]


def policy_episodes(task: Task, n_episodes: int, seed: int, stride: int = 1) -> EpisodeData:
    """Episodes of the fixed policy from uniform starts, with completed discounted returns.

    Each episode's ``episode_length`` (150) steps are simulated and every ``stride``-th state
    (steps ``0, stride, 2 stride, ...``) is kept as a training state; the rollout goes on for
    ``task.horizon`` more steps so that every state's return sums exactly ``horizon``
    discounted rewards (a single-rollout sample of the value
    :func:`~sb3_geogp.studies.pendulum.ground_truth.mc_value` estimates).

    Parameters
    ----------
    task : Task
    n_episodes : int
    seed : int
        Seeds the starts and the torque noise.
    stride : int
        Keep every ``stride``-th state of each episode (1 = all 150).

    Returns
    -------
    EpisodeData
        ``ceil(150 / stride)`` states per episode.
    """
    if stride < 1:
        raise ValueError(f"stride must be >= 1, got {stride}")
    rng = np.random.default_rng(seed)
    L, H = task.params.episode_length, task.horizon
    starts = task.sample_starts(n_episodes, rng)
    states, rewards = task.rollout_rewards(starts, L + H - 1, rng)
    returns = discounted_tail_sums(rewards, task.gamma, H)[:, :L:stride]
    kept = states[:, :L:stride]
    flags = np.zeros(returns.shape, dtype=bool)
    flags[:, 0] = True
    return EpisodeData(kept.reshape(-1, 2), returns.ravel(), flags.ravel(), kept.shape[1])
