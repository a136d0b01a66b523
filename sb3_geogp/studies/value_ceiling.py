"""What the policy's own value function ``V^pi`` scores by issue 13's critic-fit measure.

Issue 13's critic-fit score of a critic ``V`` on a rollout is SB3's explained variance of its
values against the GAE returns computed with it,

.. math::  \\mathrm{EV}(V) = 1 - \\frac{\\mathrm{Var}(R_V - V)}{\\mathrm{Var}(R_V)}, \\qquad
           R_V = A_V + V,

with ``A_V`` the GAE advantages (:func:`~sb3_geogp.studies.advantage_error.gae`; SB3 adds
``gamma V(terminal observation)`` to the reward at a time-limit truncation). The return from a
state is random (the policy samples its actions), and no function of the state predicts it
better than its mean, ``V^pi``. The *ceiling* of a rollout (:func:`ceiling`) is the score of
``V^pi`` itself on its own GAE returns: what the exact critic would score. It is not a bound on
other critics' scores: with ``lambda < 1`` a critic's targets carry its own values
(:func:`own_value_weight`), so a critic can score well by agreeing with itself, even where
``V^pi`` is constant and scores about 0. :func:`ceiling` therefore also scores ``V^pi`` and the
critic on the same targets, which no critic shapes: ``G``, the rollout's own discounted
returns bootstrapped with ``V^pi``; there ``V^pi``'s score bounds every critic's, up to Monte
Carlo noise.

``V^pi`` is estimated at every state of the rollout by Monte Carlo (:func:`policy_returns`;
:func:`model_returns` for an SB3 model's policy, its training left as it was):
CartPole-v1, Acrobot-v1, Pendulum-v1, the paper's pendulum and the WallMaze variants
(:data:`TASKS`) have deterministic dynamics and observations that are their states (Acrobot's
and Pendulum-v1's angles through their cosines and sines, a maze's position), so every state
is restarted exactly, up to the float32 rounding of the observation; only the policy's draws
are sampled. The rollouts run without a time limit, as the bootstrapped targets assume, and are
cut after :func:`horizon`'s steps, which leaves out at most ``tail`` of the return in units of
the task's largest reward (:attr:`RestartableTask.reward_bound`). The batch dynamics are the
gymnasium equations in vectorised numpy (:func:`acrobot_step`; :func:`pendulum_v1_step`;
CartPole's :func:`~sb3_geogp.studies.action_gap.cartpole_step`; the paper pendulum's
:func:`~sb3_geogp.envs.pendulum.dynamics_step`; the mazes'
:meth:`~sb3_geogp.envs.wall_maze.WallMaze.transitions`).
Monte Carlo noise in ``V^pi`` lowers the estimated ceiling; :func:`ceiling` also scores each
half of the rollouts, whose difference from the whole measures that bias (it shrinks as
``1 / n_rollouts``), and checks the estimate against the rollout's own returns.

:func:`lagged_ceiling` scores, on the same rollout, the value function of the policy one
rollout earlier: what a critic would score that knew that policy's values exactly, as critics
are trained on earlier policies' returns and predict a rollout's values before they see it.

:func:`capacity` asks what a value model fitted once to a rollout can know of ``V^pi``: each
model of a set is fitted to half the rollout's environments and scored against ``V^pi`` on the
other half, on three sets of targets (``V^pi`` itself, ``G``, and the previous rollout's
``V^pi``), which separates what the model's function class represents from what one rollout's
noisy returns and a change of policy cost (:func:`knn_fit`, :func:`mlp_fit`: references
that know nothing of GPs).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from gymnasium import spaces
from scipy.spatial import cKDTree

from sb3_geogp.envs import PAPER_PENDULUM_ID
from sb3_geogp.envs.pendulum import PendulumParams, dynamics_step
from sb3_geogp.envs.pendulum import reward as pendulum_reward
from sb3_geogp.envs.wall_maze import (
    CORNER_LAYOUT,
    DOOR_LAYOUT,
    WALL_MAZE_CORNER_ID,
    WALL_MAZE_DISCRETE_ID,
    WALL_MAZE_DOOR_ID,
    WALL_MAZE_ID,
    WallMaze,
    WallMazeDiscrete,
)
from sb3_geogp.studies.action_gap import cartpole_step
from sb3_geogp.studies.advantage_error import gae
from sb3_geogp.targets import env_major, per_env
from sb3_geogp.toolbox.stats import correlation, explained_variance, moments

if TYPE_CHECKING:  # the studies import without stable-baselines3 (tests/toolbox/test_layers.py)
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
    from stable_baselines3.common.policies import ActorCriticPolicy

#: ``act(obs, step) -> actions``: a stochastic policy's draws for a batch of observations,
#: shape (n, obs_dim) -> (n,) (discrete actions) or (n, action_dim); ``step`` counts the steps
#: since the rollouts started (for noise resampled every few steps, as gSDE's).
Act = Callable[[np.ndarray, int], np.ndarray]

#: ``predict(z) -> values``: a fitted value model, shape (m, obs_dim) -> (m,).
Predict = Callable[[np.ndarray], np.ndarray]
#: ``fit(x, y, episode_starts) -> predict``: a value model fitted once to ``x : (n, obs_dim)``,
#: ``y : (n,)`` (env by env, each in time order; ``episode_starts : (n,)`` True where a
#: trajectory starts), returning ``predict(z : (m, obs_dim)) -> (m,)``.
Fit = Callable[[np.ndarray, np.ndarray, np.ndarray], Predict]

#: Acrobot-v1's constants (gymnasium ``AcrobotEnv``, its default "book" dynamics).
ACROBOT_DT = 0.2
ACROBOT_MAX_VEL = (4 * math.pi, 9 * math.pi)
ACROBOT_TORQUES = np.array([-1.0, 0.0, 1.0])
_M1 = _M2 = _L1 = _I1 = _I2 = 1.0
_LC1 = _LC2 = 0.5
_G = 9.8


def _acrobot_derivatives(s: np.ndarray, torque: np.ndarray) -> np.ndarray:
    """Time derivative of Acrobot states (gymnasium's ``_dsdt``, "book" dynamics), shape (n, 4)."""
    theta1, theta2, dtheta1, dtheta2 = s.T
    d1 = _M1 * _LC1**2 + _M2 * (_L1**2 + _LC2**2 + 2 * _L1 * _LC2 * np.cos(theta2)) + _I1 + _I2
    d2 = _M2 * (_LC2**2 + _L1 * _LC2 * np.cos(theta2)) + _I2
    phi2 = _M2 * _LC2 * _G * np.cos(theta1 + theta2 - math.pi / 2.0)
    phi1 = (
        -_M2 * _L1 * _LC2 * dtheta2**2 * np.sin(theta2)
        - 2 * _M2 * _L1 * _LC2 * dtheta2 * dtheta1 * np.sin(theta2)
        + (_M1 * _LC1 + _M2 * _L1) * _G * np.cos(theta1 - math.pi / 2)
        + phi2
    )
    ddtheta2 = (torque + d2 / d1 * phi1 - _M2 * _L1 * _LC2 * dtheta1**2 * np.sin(theta2) - phi2) / (
        _M2 * _LC2**2 + _I2 - d2**2 / d1
    )
    ddtheta1 = -(d2 * ddtheta2 + phi1) / d1
    return np.stack([dtheta1, dtheta2, ddtheta1, ddtheta2], axis=1)


def _wrap(x: np.ndarray) -> np.ndarray:
    """gymnasium's ``wrap(x, -pi, pi)``: whole turns added or taken away until in range."""
    x = x.copy()
    while (high := x > math.pi).any():
        x[high] -= 2 * math.pi
    while (low := x < -math.pi).any():
        x[low] += 2 * math.pi
    return x


def acrobot_step(state: np.ndarray, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One Acrobot-v1 step (one RK4 step of ``dt`` = 0.2, as gymnasium) for a batch of states.

    Parameters
    ----------
    state : ndarray, shape (n, 4)
        ``(theta1, theta2, dtheta1, dtheta2)``.
    action : ndarray of int, shape (n,)
        Torque -1, 0 or +1 on the joint.

    Returns
    -------
    next_state : ndarray, shape (n, 4), float64
        Angles wrapped to ``[-pi, pi]``, velocities clipped to 4 pi and 9 pi.
    terminated : ndarray of bool, shape (n,)
        The tip is more than one link's length above the pivot.
    """
    s = np.asarray(state, dtype=np.float64)
    torque = ACROBOT_TORQUES[np.asarray(action, dtype=np.int64)]
    h = ACROBOT_DT
    k1 = _acrobot_derivatives(s, torque)
    k2 = _acrobot_derivatives(s + h / 2 * k1, torque)
    k3 = _acrobot_derivatives(s + h / 2 * k2, torque)
    k4 = _acrobot_derivatives(s + h * k3, torque)
    nxt = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    nxt[:, 0], nxt[:, 1] = _wrap(nxt[:, 0]), _wrap(nxt[:, 1])
    for i, limit in enumerate(ACROBOT_MAX_VEL):
        nxt[:, 2 + i] = np.clip(nxt[:, 2 + i], -limit, limit)
    terminated = -np.cos(nxt[:, 0]) - np.cos(nxt[:, 1] + nxt[:, 0]) > 1.0
    return nxt, terminated


@dataclass(frozen=True)
class RestartableTask:
    """A task whose every state can be restarted from its observation.

    Attributes
    ----------
    state : callable
        Observations, shape (n, obs_dim), to states, shape (n, state_dim).
    observe : callable
        States to observations.
    step : callable
        ``(states, actions) -> (next states, terminated)``.
    reward : callable
        ``(states, actions, terminated) -> rewards`` of the steps from ``states : (n,
        state_dim)`` by ``actions``, shape (n,).
    reward_bound : float
        The largest size of a reward, which :func:`horizon`'s ``tail`` is counted in.
    """

    state: Callable[[np.ndarray], np.ndarray]
    observe: Callable[[np.ndarray], np.ndarray]
    step: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    reward: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    reward_bound: float = 1.0


def _acrobot_state(obs: np.ndarray) -> np.ndarray:
    o = np.asarray(obs, dtype=np.float64)
    return np.stack(
        [np.arctan2(o[:, 1], o[:, 0]), np.arctan2(o[:, 3], o[:, 2]), o[:, 4], o[:, 5]], 1
    )


def _acrobot_observe(s: np.ndarray) -> np.ndarray:
    return np.stack(
        [np.cos(s[:, 0]), np.sin(s[:, 0]), np.cos(s[:, 1]), np.sin(s[:, 1]), s[:, 2], s[:, 3]], 1
    )


def _identity(x: np.ndarray) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


def _maze_task(env: WallMaze) -> RestartableTask:
    """A WallMaze variant: its state is its position, which the observation holds in float32
    (restarts are off by at most that rounding); reward ``step_reward`` for every step, the one
    that reaches the goal included."""
    reward = env.layout.step_reward
    return RestartableTask(
        _identity, env.observe, env.transitions, lambda _s, _a, done: np.full(done.shape, reward)
    )


def _pendulum_task(params: PendulumParams) -> RestartableTask:
    """The paper's pendulum: its observation ``(theta, omega)`` is its state (float32, so
    restarts are off by that rounding), it never terminates, and a step's reward is
    ``cos(theta)`` of the state it starts from."""

    def step(s: np.ndarray, torque: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        theta, omega = dynamics_step(s[:, 0], s[:, 1], torque[:, 0], params)
        return np.stack([theta, omega], axis=1), np.zeros(len(s), dtype=bool)

    return RestartableTask(_identity, _identity, step, lambda s, _a, _d: pendulum_reward(s[:, 0]))


#: gymnasium's Pendulum-v1: gravity, mass, length, time step, torque and speed limits.
PENDULUM_V1 = {"g": 10.0, "m": 1.0, "l": 1.0, "dt": 0.05, "max_torque": 2.0, "max_speed": 8.0}


def pendulum_v1_step(states: np.ndarray, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """gymnasium's Pendulum-v1 ``step`` for a batch: the torque clipped, one explicit Euler
    step of the angular velocity (clipped to ``max_speed``), then of the angle (not wrapped);
    it never terminates.

    Parameters
    ----------
    states : ndarray, shape (n, 2)
        Angle ``theta`` (0 upright) and angular velocity.
    actions : ndarray, shape (n, 1)
        Torques.

    Returns
    -------
    next_states : ndarray, shape (n, 2)
    terminated : ndarray, shape (n,), all False
    """
    p = PENDULUM_V1
    th, thdot = states[:, 0], states[:, 1]
    u = np.clip(actions[:, 0], -p["max_torque"], p["max_torque"])
    accel = 3 * p["g"] / (2 * p["l"]) * np.sin(th) + 3.0 / (p["m"] * p["l"] ** 2) * u
    new_thdot = np.clip(thdot + accel * p["dt"], -p["max_speed"], p["max_speed"])
    return np.stack([th + new_thdot * p["dt"], new_thdot], 1), np.zeros(len(states), dtype=bool)


def pendulum_v1_reward(states: np.ndarray, actions: np.ndarray, _: np.ndarray) -> np.ndarray:
    """gymnasium's Pendulum-v1 reward of a step from ``states`` by ``actions``: minus the
    squared angle from upright (wrapped to ``[-pi, pi)``), 0.1 times the squared angular
    velocity and 0.001 times the squared (clipped) torque."""
    u = np.clip(actions[:, 0], -PENDULUM_V1["max_torque"], PENDULUM_V1["max_torque"])
    angle = (states[:, 0] + math.pi) % (2 * math.pi) - math.pi
    return -(angle**2 + 0.1 * states[:, 1] ** 2 + 0.001 * u**2)


def _pendulum_v1_state(obs: np.ndarray) -> np.ndarray:
    o = np.asarray(obs, dtype=np.float64)
    return np.stack([np.arctan2(o[:, 1], o[:, 0]), o[:, 2]], 1)


def _pendulum_v1_observe(s: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(s[:, 0]), np.sin(s[:, 0]), s[:, 1]], 1)


#: The tasks :func:`policy_returns` can restart, by gymnasium id.
TASKS: dict[str, RestartableTask] = {
    # reward 1 for every step, the one that ends the episode included
    "CartPole-v1": RestartableTask(
        _identity, _identity, cartpole_step, lambda _s, _a, done: np.ones(done.shape)
    ),
    # reward -1 for every step but the one that reaches the goal
    "Acrobot-v1": RestartableTask(
        _acrobot_state,
        _acrobot_observe,
        acrobot_step,
        lambda _s, _a, done: np.where(done, 0.0, -1.0),
    ),
    # the largest cost: upside down at full speed and full torque
    "Pendulum-v1": RestartableTask(
        _pendulum_v1_state,
        _pendulum_v1_observe,
        pendulum_v1_step,
        pendulum_v1_reward,
        reward_bound=math.pi**2
        + 0.1 * PENDULUM_V1["max_speed"] ** 2
        + 0.001 * PENDULUM_V1["max_torque"] ** 2,
    ),
    PAPER_PENDULUM_ID: _pendulum_task(PendulumParams()),
    WALL_MAZE_ID: _maze_task(WallMaze()),
    WALL_MAZE_DISCRETE_ID: _maze_task(WallMazeDiscrete()),
    WALL_MAZE_CORNER_ID: _maze_task(WallMaze(CORNER_LAYOUT)),
    WALL_MAZE_DOOR_ID: _maze_task(WallMaze(DOOR_LAYOUT)),
}


def horizon(gamma: float, tail: float) -> int:
    """Steps after which a return of rewards at most 1 in size has at most ``tail`` left:
    the smallest ``H`` with ``gamma^H / (1 - gamma) <= tail``."""
    if not (0 < gamma < 1) or tail <= 0:
        raise ValueError(f"need 0 < gamma < 1 and tail > 0, got gamma={gamma}, tail={tail}")
    return max(0, math.ceil(math.log(tail * (1 - gamma)) / math.log(gamma)))


def policy_returns(
    act: Act,
    task: RestartableTask,
    obs: np.ndarray,
    gamma: float,
    steps: int,
    n_rollouts: int,
) -> np.ndarray:
    """Discounted returns of the policy from each observation's state, without a time limit,
    cut after ``steps`` steps: their mean over the rollouts is ``V^pi`` by Monte Carlo.

    Parameters
    ----------
    act : callable
        The policy (:data:`Act`), called once per step on the rollouts still running, with
        the step's index.
    task : RestartableTask
    obs : ndarray, shape (n, obs_dim)
    gamma : float
    steps : int
    n_rollouts : int
        At least 2, so that :func:`ceiling` can score halves.

    Returns
    -------
    ndarray, shape (n, n_rollouts)

    Raises
    ------
    ValueError
        For ``obs`` not of shape (n, obs_dim) or not finite, ``steps < 1``, ``gamma`` outside
        [0, 1] or ``n_rollouts < 2``.
    """
    _check_returns_arguments(obs, gamma, steps, n_rollouts)
    state = np.repeat(task.state(obs), n_rollouts, axis=0)
    total = np.zeros(len(state))
    running = np.arange(len(state))
    discount = 1.0
    for step in range(steps):
        if not len(running):
            break
        actions = act(task.observe(state), step)
        after, done = task.step(state, actions)
        total[running] += discount * task.reward(state, actions, done)
        discount *= gamma
        state, running = after[~done], running[~done]
    return total.reshape(-1, n_rollouts)


def _check_returns_arguments(obs: np.ndarray, gamma: float, steps: int, n_rollouts: int) -> None:
    o = np.asarray(obs)
    if o.ndim != 2:
        raise ValueError(f"obs must have shape (n, obs_dim), got {o.shape}; stack the states")
    if not np.isfinite(o).all():
        raise ValueError("obs contains NaN or inf; pass the states the returns start from")
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    if not 0.0 <= gamma <= 1.0:
        raise ValueError(f"gamma must be in [0, 1], got {gamma}")
    if n_rollouts < 2:
        raise ValueError(f"n_rollouts must be >= 2, got {n_rollouts}")


#: What gSDE's ``reset_noise`` replaces in SB3's state-dependent noise distribution.
_GSDE_STATE = ("exploration_mat", "exploration_matrices", "weights_dist")


def model_returns(
    model: OnPolicyAlgorithm,
    task: RestartableTask,
    obs: np.ndarray,
    steps: int,
    n_rollouts: int,
    seed: int,
    policy: ActorCriticPolicy | None = None,
) -> np.ndarray:
    """:func:`policy_returns` of an SB3 model's current policy at its discount, leaving its
    training as it was.

    The actions are draws of the policy's distribution shaped by its action space (clipped to
    a box), its gSDE noise resampled as in training (at the start and every
    ``sde_sample_freq`` steps), all inside torch random streams (the CPU's and every CUDA
    device's) forked and seeded by ``seed``; the policy's gSDE exploration matrices are put
    back afterwards, so that training draws what it would have drawn without this call.

    Parameters
    ----------
    model : OnPolicyAlgorithm
    task : RestartableTask
    obs : ndarray, shape (n, obs_dim)
    steps, n_rollouts : int
        As :func:`policy_returns`.
    seed : int
    policy : ActorCriticPolicy, optional
        The policy to roll out instead of the model's own, e.g. a copy of an earlier one
        (:func:`lagged_ceiling`); the model still gives the spaces, discount and gSDE
        schedule. The same ``seed`` starts either policy's draws from the same random stream
        (the same draws while their rollouts run alike).

    Returns
    -------
    ndarray, shape (n, n_rollouts)

    Raises
    ------
    ValueError
        As :func:`policy_returns`, and for observations not shaped as the model's.
    """
    expected = model.observation_space.shape or ()
    if np.ndim(obs) != 1 + len(expected) or np.shape(obs)[1:] != expected:
        raise ValueError(
            f"obs must have shape (n, {', '.join(map(str, expected))}) as the model's "
            f"observations, got {np.shape(obs)}"
        )
    policy = model.policy if policy is None else policy
    space = model.action_space
    shape = space.shape or ()

    def act(o: np.ndarray, step: int) -> np.ndarray:
        every = model.sde_sample_freq
        if model.use_sde and (step == 0 or (every > 0 and step % every == 0)):
            policy.reset_noise(len(o))
        with torch.no_grad():
            dist = policy.get_distribution(
                torch.as_tensor(o, dtype=torch.float32, device=policy.device)
            )
            actions = dist.get_actions().cpu().numpy().reshape(len(o), *shape)
        if isinstance(space, spaces.Box):
            actions = np.clip(actions, space.low, space.high).astype(np.float64)
        return actions

    noise = policy.action_dist
    saved = {k: getattr(noise, k) for k in _GSDE_STATE if hasattr(noise, k)}
    try:
        # Every device's stream: manual_seed re-seeds CUDA's too, and a policy there draws from it.
        with torch.random.fork_rng():
            torch.manual_seed(seed)
            return policy_returns(act, task, obs, float(model.gamma), steps, n_rollouts)
    finally:
        for k, v in saved.items():
            setattr(noise, k, v)


@dataclass(frozen=True)
class Rollout:
    """What :func:`ceiling` needs of a PPO/A2C rollout of ``T`` steps in ``n_envs`` envs.

    Attributes
    ----------
    obs : ndarray, shape (T, n_envs, obs_dim)
        The observation each step starts from.
    rewards : ndarray, shape (T, n_envs)
        The environment's rewards, before SB3 adds a bootstrap at truncations.
    episode_starts : ndarray, shape (T, n_envs)
    last_obs : ndarray, shape (n_envs, obs_dim)
    last_dones : ndarray, shape (n_envs,)
    truncations : list of (int, int, ndarray)
        ``(step, env, terminal observation)`` of the time-limit truncations
        (:func:`~sb3_geogp.callbacks.time_limit_truncations`).
    """

    obs: np.ndarray
    rewards: np.ndarray
    episode_starts: np.ndarray
    last_obs: np.ndarray
    last_dones: np.ndarray
    truncations: list[tuple[int, int, np.ndarray]]

    def states(self) -> np.ndarray:
        """Every observation whose value enters the GAE returns, shape (T n_envs + n_envs + k,
        obs_dim): the steps', the last ones, then the truncations' terminal ones."""
        dim = self.obs.shape[-1]
        terminal = [np.reshape(t, (1, dim)) for _, _, t in self.truncations]
        parts = [self.obs.reshape(-1, dim), self.last_obs.reshape(-1, dim), *terminal]
        return np.concatenate(parts).astype(np.float64)

    def returns(self, values: np.ndarray, gamma: float, gae_lambda: float) -> np.ndarray:
        """GAE returns ``R_V`` with ``values`` at :meth:`states` (shape (m,)), SB3's bootstrap
        ``gamma V(terminal)`` added at truncations; shape (T, n_envs)."""
        T, n_envs = self.rewards.shape
        own, last, terminal = np.split(
            np.asarray(values, np.float64), [T * n_envs, T * n_envs + n_envs]
        )
        own = own.reshape(T, n_envs)
        rewards = self.rewards.astype(np.float64).copy()
        for (step, env, _), v in zip(self.truncations, terminal, strict=True):
            rewards[step, env] += gamma * v
        advantages = gae(
            rewards, own, self.episode_starts, last, self.last_dones, gamma, gae_lambda
        )
        return advantages + own


def own_value_weight(gamma: float, gae_lambda: float) -> float:
    """The share of a critic's own values in its GAE targets, ``gamma (1 - lambda) / (1 - gamma
    lambda)``.

    Unrolled (inside an episode), ``R_V(t) = sum_k (gamma lambda)^k r_{t+k} + gamma (1 - lambda)
    sum_{j >= 1} (gamma lambda)^{j-1} V(s_{t+j})``: the target is the critic's values at the
    next states, weighted by this much in all, plus rewards. Where it is large, a critic's
    errors reappear in its own targets, and its explained variance rewards agreeing with
    itself as well as with the returns.
    """
    return gamma * (1 - gae_lambda) / (1 - gamma * gae_lambda)


def ceiling(
    rollout: Rollout,
    mc_returns: np.ndarray,
    gamma: float,
    gae_lambda: float,
    critic: np.ndarray | None = None,
    advantages: np.ndarray | None = None,
) -> dict[str, Any]:
    """The score of ``V^pi`` on the rollout, with ``V^pi`` the Monte Carlo mean, and with
    ``critic`` that critic's distance from it.

    Two readings. The goal's: each value function scored on its own GAE returns (``explained``;
    a critic's own score is the run's). And one on targets that no critic shapes: the rollout's
    own discounted returns (``lambda = 1``) bootstrapped with ``V^pi`` where the rollout stops or
    an episode is truncated, ``G``; on them ``V^pi`` is the best predictor there is, so
    ``mc_ceiling`` bounds ``mc_critic`` up to Monte Carlo noise.

    Parameters
    ----------
    rollout : Rollout
    mc_returns : ndarray, shape (m, n_rollouts)
        :func:`policy_returns` from :meth:`Rollout.states`.
    gamma, gae_lambda : float
    critic : ndarray, shape (T n_envs,), optional
        The critic's values at the rollout's steps (its ``values``, flattened).
    advantages : ndarray, shape (T n_envs,), optional
        The advantages the actor learned from with that critic (the buffer's, flattened).

    Returns
    -------
    dict
        ``explained``: the ceiling; ``halves``: the mean of the two halves' ceilings (each
        from every other Monte Carlo rollout); ``mc_se``: the root-mean-square standard
        error of ``V^pi`` at the rollout's states; ``moments``: those of ``V^pi``'s returns
        and residuals (:func:`~sb3_geogp.toolbox.stats.moments`), to pool rollouts;
        ``check_mean``, ``check_se``: the mean of ``G - V^pi`` (per env, then over envs,
        with its standard error), near 0 if the restarted rollouts are those of the policy and
        the task; ``mc_ceiling`` (and its ``mc_ceiling_moments``): ``V^pi``'s explained
        variance of ``G``. With ``critic``: ``mc_critic`` (``mc_critic_moments``), the
        critic's explained variance of ``G``, and ``value_rmse``, ``value_bias`` (mean of
        critic - ``V^pi``), ``truth_sd`` (``V^pi``'s standard deviation) at the rollout's steps.
        With ``advantages``: ``advantage_correlation``, their Pearson correlation with
        :func:`reference_advantages` (NaN if either is constant), and
        ``advantage_reliability``, the correlation ``r`` of the two halves' reference
        advantages. Monte Carlo noise lowers every critic's correlation alike: the whole
        reference's reliability is about ``2 r / (1 + r)`` (Spearman-Brown), and a critic's
        correlation is not expected above its square root.
    """
    n = rollout.rewards.size

    def returns(values: np.ndarray) -> np.ndarray:
        return rollout.returns(values, gamma, gae_lambda).ravel()

    values = mc_returns.mean(axis=1)
    truth, own = values[:n], returns(values)
    # each half's GAE returns once, for its ceiling and for its reference advantages
    half_values = [mc_returns[:, k::2].mean(axis=1) for k in (0, 1)]
    half_truth, half_own = [h[:n] for h in half_values], [returns(h) for h in half_values]
    halves = [explained_variance(o, t) for o, t in zip(half_own, half_truth, strict=True)]
    se = mc_returns[:n].std(axis=1, ddof=1) / math.sqrt(mc_returns.shape[1])
    targets = rollout.returns(values, gamma, 1.0).ravel()
    check = (targets - truth).reshape(rollout.rewards.shape).mean(axis=0)
    result = dict(
        explained=explained_variance(own, truth),
        halves=float(np.mean(halves)),
        mc_se=float(np.sqrt(np.mean(se**2))),
        moments=moments(own, own - truth),
        check_mean=float(check.mean()),
        check_se=float(check.std(ddof=1) / math.sqrt(len(check))),
        mc_ceiling=explained_variance(targets, truth),
        mc_ceiling_moments=moments(targets, targets - truth),
    )
    if critic is not None:
        v = np.asarray(critic, dtype=np.float64).ravel()
        result.update(
            mc_critic=explained_variance(targets, v),
            mc_critic_moments=moments(targets, targets - v),
            value_rmse=float(np.sqrt(np.mean((v - truth) ** 2))),
            value_bias=float(np.mean(v - truth)),
            truth_sd=float(truth.std()),
        )
    if advantages is not None:
        # own - truth is reference_advantages(rollout, mc_returns, ...), already at hand
        result.update(
            advantage_correlation=correlation(own - truth, advantages),
            advantage_reliability=correlation(
                *(o - t for o, t in zip(half_own, half_truth, strict=True))
            ),
        )
    return result


def lagged_ceiling(
    rollout: Rollout,
    mc_returns: np.ndarray,
    lagged_returns: np.ndarray,
    gamma: float,
    gae_lambda: float,
) -> dict[str, Any]:
    """What the previous rollout's policy's value function ``V^pi'`` scores on this rollout:
    the *lagged ceiling*, what a critic would score that knew the previous policy's values
    exactly and nothing of the policy that collected the rollout.

    A critic predicts a rollout's values before it sees the rollout's returns, from returns of
    earlier policies: SB3's MLP critic last trained on the previous rollout's GAE returns, and
    the GP critic is fed the returns of episodes as they end. ``V^pi'`` is what both learn
    towards; the score asks for ``V^pi``. A critic can beat ``V^pi'`` only by foreseeing how
    the policy changed (or, by the goal's reading, by agreeing with itself).

    Parameters
    ----------
    rollout : Rollout
    mc_returns : ndarray, shape (m, n_rollouts)
        :func:`policy_returns` of the policy that collected the rollout, from
        :meth:`Rollout.states`.
    lagged_returns : ndarray, shape (m, n_lagged)
        The same for the previous policy (:func:`model_returns` with ``policy=``).
    gamma, gae_lambda : float

    Returns
    -------
    dict
        By the goal's reading, ``V^pi'`` scored as a critic on its own GAE returns, as
        :func:`ceiling` scores ``V^pi``: ``explained``, ``halves``, ``moments``. On G (the
        rollout's returns bootstrapped with ``V^pi``), as :func:`ceiling` scores a critic:
        ``mc_critic``, ``mc_critic_moments``; and ``V^pi' - V^pi`` at the rollout's steps:
        ``value_rmse``, ``value_bias``, ``truth_sd``.

    Raises
    ------
    ValueError
        If the two sets of returns do not start from the same states.
    """
    if np.shape(lagged_returns)[0] != np.shape(mc_returns)[0]:
        raise ValueError(
            f"the lagged returns start from {np.shape(lagged_returns)[0]} states and the "
            f"rollout's from {np.shape(mc_returns)[0]}: roll both out from Rollout.states()"
        )
    n = rollout.rewards.size
    own = ceiling(rollout, lagged_returns, gamma, gae_lambda)
    lagged = np.asarray(lagged_returns, dtype=np.float64).mean(axis=1)[:n]
    versus = ceiling(rollout, mc_returns, gamma, gae_lambda, critic=lagged)
    return {
        **{key: own[key] for key in ("explained", "halves", "moments")},
        **{
            key: versus[key]
            for key in ("mc_critic", "mc_critic_moments", "value_rmse", "value_bias", "truth_sd")
        },
    }


def reference_advantages(
    rollout: Rollout, mc_returns: np.ndarray, gamma: float, gae_lambda: float
) -> np.ndarray:
    """The GAE advantages of the rollout with ``V^pi`` (the Monte Carlo mean) as the critic:
    what the exact critic would give the actor, shape (T n_envs,).

    Parameters
    ----------
    rollout : Rollout
    mc_returns : ndarray, shape (m, n_rollouts)
        :func:`policy_returns` from :meth:`Rollout.states`.
    gamma, gae_lambda : float
    """
    values = mc_returns.mean(axis=1)
    own = values[: rollout.rewards.size]
    return rollout.returns(values, gamma, gae_lambda).ravel() - own


def value_r2(values: np.ndarray, truth: np.ndarray) -> float:
    """Share of ``truth``'s variance that ``values`` explain, ``1 - mean((v - t)^2) / Var(t)``
    (bias counted, unlike :func:`~sb3_geogp.toolbox.stats.explained_variance`); NaN where
    ``truth`` is constant."""
    truth = np.asarray(truth, dtype=np.float64)
    var = float(truth.var())
    if var == 0.0:
        return math.nan
    return 1.0 - float(np.mean((np.asarray(values, dtype=np.float64) - truth) ** 2)) / var


def _env_block(
    obs: np.ndarray, values: np.ndarray, starts: np.ndarray, envs: slice
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The steps of ``envs`` env by env (:func:`~sb3_geogp.targets.per_env` of ``obs (T, n_envs,
    d)``, ``values``/``starts`` ``(T, n_envs)``), in float64 for the value models."""
    x, y, block_starts = per_env(obs[:, envs], values[:, envs], starts[:, envs])
    return x.astype(np.float64), y.astype(np.float64), block_starts


def capacity(
    fits: dict[str, Fit],
    rollout: Rollout,
    values: np.ndarray,
    gamma: float,
    critic: np.ndarray,
    previous: tuple[Rollout, np.ndarray] | None = None,
) -> dict[str, float]:
    """What models fitted once to this rollout explain of ``V^pi`` on held-out environments.

    Every model is fitted to the first half of the rollout's environments and scored with
    :func:`value_r2` against ``V^pi`` on the second half, on the targets

    * ``exact``: ``V^pi`` itself (what the model represents of it from these states);
    * ``G``: the rollout's own discounted returns bootstrapped with ``V^pi`` where it stops or
      is truncated (what one rollout's returns teach, as a Monte Carlo target would);
    * ``lag`` (with ``previous``): ``V^pi`` of the previous rollout's policy, all its
      environments (what a critic one policy behind can know).

    Parameters
    ----------
    fits : dict of name to :data:`Fit`
    rollout : Rollout
        ``T`` steps in ``n_envs >= 2`` environments.
    values : ndarray, shape (m,)
        ``V^pi`` at :meth:`Rollout.states` (the Monte Carlo mean).
    gamma : float
    critic : ndarray, shape (T n_envs,)
        The critic's values at the rollout's steps, scored on the same half (``critic``).
    previous : (Rollout, ndarray), optional
        The previous scored rollout and its ``V^pi`` at its states.

    Returns
    -------
    dict
        ``"critic"`` and ``"<model>|<targets>"`` for every model and set of targets.
    """
    T, n_envs = rollout.rewards.shape
    if n_envs < 2:
        raise ValueError(f"capacity needs at least 2 environments to hold some out, got {n_envs}")
    truth = np.asarray(values, dtype=np.float64)[: T * n_envs].reshape(T, n_envs)
    returns = rollout.returns(values, gamma, 1.0)
    train, test = slice(0, n_envs // 2), slice(n_envs // 2, n_envs)
    x_test, y_test, _ = _env_block(rollout.obs, truth, rollout.episode_starts, test)
    own = env_major(np.reshape(critic, (T, n_envs))[:, test])
    targets = {"exact": truth, "G": returns}
    result = {"critic": value_r2(own, y_test)}
    blocks = {
        name: _env_block(rollout.obs, y, rollout.episode_starts, train)
        for name, y in targets.items()
    }
    if previous is not None:
        old, old_values = previous
        old_truth = np.asarray(old_values)[: old.rewards.size].reshape(old.rewards.shape)
        blocks["lag"] = _env_block(old.obs, old_truth, old.episode_starts, slice(None))
    for model, fit in fits.items():
        for name, (x, y, starts) in blocks.items():
            result[f"{model}|{name}"] = value_r2(fit(x, y, starts)(x_test), y_test)
    return result


def knn_fit(k: int = 10) -> Fit:
    """:data:`Fit` of ``k`` nearest neighbours (the mean of their targets) in inputs scaled by
    the training data's standard deviation per dimension."""

    def fit(x: np.ndarray, y: np.ndarray, episode_starts: np.ndarray) -> Predict:
        scale = np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
        tree = cKDTree(x / scale)
        neighbours = min(k, len(x))

        def predict(z: np.ndarray) -> np.ndarray:
            index = tree.query(np.asarray(z) / scale, k=neighbours)[1]
            return y[np.reshape(index, (len(z), neighbours))].mean(axis=1)

        return predict

    return fit


def mlp_fit(hidden: tuple[int, ...] = (64, 64), steps: int = 1500, lr: float = 3e-3) -> Fit:
    """:data:`Fit` of SB3's default value network (``hidden`` tanh layers, float64), trained by
    full-batch Adam for ``steps`` on standardised targets from a fixed initialisation (seed 0),
    to convergence rather than PPO's few epochs."""

    def fit(x: np.ndarray, y: np.ndarray, episode_starts: np.ndarray) -> Predict:
        with torch.random.fork_rng():
            torch.manual_seed(0)
            sizes = (x.shape[1], *hidden)
            layers: list[torch.nn.Module] = []
            for n_in, n_out in itertools.pairwise(sizes):
                layers += [torch.nn.Linear(n_in, n_out), torch.nn.Tanh()]
            net = torch.nn.Sequential(*layers, torch.nn.Linear(sizes[-1], 1)).double()
        mean, sd = float(y.mean()), float(y.std()) or 1.0
        inputs, targets = torch.as_tensor(x), torch.as_tensor((y - mean) / sd)
        optimizer = torch.optim.Adam(net.parameters(), lr=lr)
        for _ in range(steps):
            optimizer.zero_grad()
            loss = (net(inputs).squeeze(-1) - targets).square().mean()
            loss.backward()
            optimizer.step()

        def predict(z: np.ndarray) -> np.ndarray:
            with torch.no_grad():
                out = net(torch.as_tensor(np.asarray(z, dtype=np.float64))).squeeze(-1)
            return out.numpy() * sd + mean

        return predict

    return fit
