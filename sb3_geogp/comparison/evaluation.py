"""Measuring a policy and its critic outside training.

* evaluation curve: :func:`lockstep_returns` of the deterministic policy over episodes started
  from the same seeded states (``EVAL_SEED + i``) at every checkpoint and in every run;
* critic accuracy: the critic's value at a fixed set of probe states against Monte Carlo
  discounted returns of the current (stochastic) policy from those states
  (:class:`ProbeStates`).
"""

from __future__ import annotations

import copy
import importlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import EnvSpec
from stable_baselines3.common.policies import ActorCriticPolicy

import sb3_geogp.envs  # noqa: F401  (registers the package's environments with gymnasium)

#: Monte Carlo rollouts run until ``gamma^t`` < MC_TAIL, at most MC_MAX_EPISODES episode
#: lengths (:func:`mc_horizon`).
MC_TAIL = 0.01
MC_MAX_EPISODES = 5

#: Seeds of the evaluation episodes' starts (``EVAL_SEED + i``) and of the probe states.
EVAL_SEED = 10_000
PROBE_SEED = 20_000


def env_spec(env_id: str) -> EnvSpec:
    """The registered spec of ``env_id``; for ``"module:EnvId"`` the module is imported first,
    as ``gymnasium.make`` does (``gymnasium.spec`` does not).

    Raises
    ------
    gymnasium.error.Error
        If the id is not registered.
    ImportError
        If the module cannot be imported.
    """
    module, _, name = env_id.rpartition(":")
    if module:
        importlib.import_module(module)
    return gym.spec(name)


def max_episode_steps(env_id: str) -> int:
    """The registered time limit of ``env_id``.

    Raises
    ------
    ValueError
        If it has none.
    """
    spec = env_spec(env_id)
    if spec.max_episode_steps is None:
        raise ValueError(
            f"{env_id} has no time limit: register it with max_episode_steps=N (the evaluations "
            "and the critic's Monte Carlo check need episodes that end)"
        )
    return int(spec.max_episode_steps)


def lockstep_returns(
    policy: ActorCriticPolicy,
    envs: Sequence[gym.Env],
    obs: np.ndarray,
    deterministic: bool,
    horizon: int,
    gamma: float = 1.0,
    sde_sample_freq: int = -1,
    obs_transform: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Returns of ``len(envs)`` episodes stepped together, one batched policy call per step.

    Parameters
    ----------
    policy : ActorCriticPolicy
    envs : sequence of gymnasium.Env
        Environments already at their start states (stepped in place).
    obs : ndarray, shape (n, *obs_shape)
        Their current observations.
    deterministic : bool
        Greedy actions or samples of the policy (clipped to Box bounds as SB3 does).
    horizon : int
        At most this many steps per episode.
    gamma : float
        Discount; 1 gives the undiscounted episode return.
    sde_sample_freq : int
        With gSDE and ``deterministic=False``: every episode draws its own exploration
        matrix at the start and again every ``sde_sample_freq`` steps (if positive), as SB3
        does during rollouts. The policy's own exploration matrices are restored afterwards.
    obs_transform : callable, optional
        What the policy sees of the observations, e.g. ``VecNormalize.normalize_obs`` of a
        policy trained in ``VecNormalize``.

    Returns
    -------
    returns : ndarray, shape (n,)
        ``sum_{t < T} gamma^t r_t`` with ``T`` the termination, truncation or ``horizon``.
    lengths : ndarray of int, shape (n,)
        ``T`` of each episode.
    """
    n = len(envs)
    returns = np.zeros(n)
    lengths = np.zeros(n, dtype=np.int64)
    alive = np.ones(n, dtype=bool)
    obs = np.array(obs, copy=True)
    discount = 1.0
    sde = bool(policy.use_sde) and not deterministic
    saved = _save_sde_state(policy) if sde else None
    try:
        for t in range(horizon):
            idx = np.flatnonzero(alive)
            if idx.size == 0:
                break
            if sde and (t == 0 or (sde_sample_freq > 0 and t % sde_sample_freq == 0)):
                policy.reset_noise(n)
            # The whole batch every step (finished episodes are ignored), so that each row
            # keeps its own gSDE exploration matrix.
            seen = obs if obs_transform is None else obs_transform(obs)
            actions, _ = policy.predict(seen, deterministic=deterministic)
            for i in idx.tolist():
                o, r, terminated, truncated, _ = envs[i].step(actions[i])
                returns[i] += discount * float(r)
                lengths[i] += 1
                obs[i] = o
                if terminated or truncated:
                    alive[i] = False
            discount *= gamma
    finally:
        if saved is not None:
            _restore_sde_state(policy, saved)
    return returns, lengths


_SDE_STATE = ("exploration_mat", "exploration_matrices", "weights_dist")


def _save_sde_state(policy: ActorCriticPolicy) -> dict[str, Any]:
    dist = policy.action_dist
    return {k: getattr(dist, k) for k in _SDE_STATE if hasattr(dist, k)}


def _restore_sde_state(policy: ActorCriticPolicy, saved: dict[str, Any]) -> None:
    for k, v in saved.items():
        setattr(policy.action_dist, k, v)


@dataclass
class ProbeStates:
    """A fixed set of states at which the critic is compared with Monte Carlo returns.

    Probe ``k`` is reached by ``reset(seed=PROBE_SEED + k)`` and then ``k * stride`` uniformly
    random actions (action space seeded with ``PROBE_SEED + k``), stopping one step short of
    any termination, where ``stride = max(1, max_episode_steps // (2 * n))``. The states do
    not depend on the run, so every critic and seed is measured on the same states.

    Monte Carlo value of probe ``k``: the mean over ``n_rollouts`` copies of the unwrapped
    environment (no time limit) at that state of ``sum_{t < T} gamma^t r_t`` under the
    current stochastic policy, ``T`` the termination or :func:`mc_horizon` steps. SB3's
    critics bootstrap at time-limit truncations, so they estimate this time-agnostic
    discounted value rather than the return to the end of an episode.

    A copy is ``copy.deepcopy`` of the probe's environment where that copies the state, else
    the probe's recipe (its reset seed and actions) replayed on a new environment: gymnasium's
    ``EzPickle`` environments (MuJoCo's, Box2D's) answer ``deepcopy`` by building a new
    environment from their constructor's arguments, not at the state (a MuJoCo copy starts at
    the model's initial state; a LunarLander copy cannot step). :meth:`build` decides by
    stepping a copy and a replay of the last probe side by side.

    Attributes
    ----------
    snapshots : list of gymnasium.Env
        Unwrapped environments at the probe states (never stepped but to check a copy).
    obs : ndarray, shape (n, *obs_shape)
    episode_steps : int
        The environment's time limit.
    env_id : str
    recipes : list of (int, list)
        Each probe's reset seed and the actions that reach it from there.
    copies : bool
        Whether ``copy.deepcopy`` copies the probe states (else they are replayed).
    """

    snapshots: list[gym.Env]
    obs: np.ndarray
    episode_steps: int
    env_id: str
    recipes: list[tuple[int, list[Any]]]
    copies: bool

    @classmethod
    def build(cls, env_id: str, n: int, seed: int = PROBE_SEED) -> ProbeStates:
        """Probe states of ``env_id`` (see the class docstring).

        Raises
        ------
        ValueError
            If the probe states can be neither copied nor replayed (an environment whose
            steps a seed does not fix).
        """
        episode_steps = max_episode_steps(env_id)
        stride = max(1, episode_steps // (2 * n))
        snapshots: list[gym.Env] = []
        obs_list = []
        recipes = []
        for k in range(n):
            env = gym.make(env_id).unwrapped
            actions = _probe_actions(env, k * stride, seed + k)
            # Walk until the step before any termination, then replay that many steps.
            n_ok = 0
            env.reset(seed=seed + k)
            for a in actions:
                if env.step(a)[2]:
                    break
                n_ok += 1
            recipes.append((seed + k, actions[:n_ok]))
            env, o = _replay(env_id, *recipes[-1], env)
            snapshots.append(env)
            obs_list.append(o)
        probes = cls(snapshots, np.stack(obs_list), episode_steps, env_id, recipes, False)
        probes.copies = probes._copy_is_faithful()
        if not probes.copies:
            probes._check_replays()
        return probes

    def start(self, k: int) -> gym.Env:
        """A new environment at probe ``k``'s state."""
        if self.copies:
            return copy.deepcopy(self.snapshots[k])
        return _replay(self.env_id, *self.recipes[k])[0]

    def _copy_is_faithful(self) -> bool:
        """Whether a ``deepcopy`` of the last probe steps as its replay does (same random
        stream, the same actions): then it holds the state."""
        k = len(self.snapshots) - 1
        pair = [copy.deepcopy(self.snapshots[k]), _replay(self.env_id, *self.recipes[k])[0]]
        space = copy.deepcopy(pair[1].action_space)
        space.seed(PROBE_SEED)
        for env in pair:
            env.np_random = np.random.default_rng(PROBE_SEED)
        for _ in range(_COPY_CHECK_STEPS):
            action = space.sample()
            replayed = pair[1].step(action)
            try:
                copied = pair[0].step(action)
            # Whatever a broken copy raises (LunarLander: AssertionError) says it is not one.
            except Exception:
                return False
            if not _same_step(copied, replayed):
                return False
            if replayed[2] or replayed[3]:
                break
        return True

    def _check_replays(self) -> None:
        """Raise ValueError unless every probe's replay reaches its observation."""
        for k, recipe in enumerate(self.recipes):
            if not np.array_equal(_replay(self.env_id, *recipe)[1], self.obs[k]):
                raise ValueError(
                    f"{self.env_id}: the critic-accuracy probe states can be neither copied "
                    "(copy.deepcopy of the environment does not hold its state) nor replayed "
                    f"(reset(seed={recipe[0]}) and the same {len(recipe[1])} actions reach "
                    "another observation): the comparison cannot measure its critics' accuracy"
                )

    def monte_carlo(
        self,
        policy: ActorCriticPolicy,
        gamma: float,
        n_rollouts: int,
        seed: int,
        sde_sample_freq: int = -1,
        obs_transform: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """Monte Carlo values of the probes, their standard errors and the env steps taken.

        ``sde_sample_freq`` and ``obs_transform`` as in :func:`lockstep_returns`; standard
        errors are NaN with a single rollout per probe. Returns arrays of shape (n,), (n,) and
        an int.
        """
        horizon = mc_horizon(gamma, self.episode_steps)
        n = len(self.snapshots)
        envs = []
        for k in range(n):
            for r in range(n_rollouts):
                env = self.start(k)
                env.np_random = np.random.default_rng([seed, k, r])  # independent env noise
                envs.append(env)
        obs = np.repeat(self.obs, n_rollouts, axis=0)
        returns, lengths = lockstep_returns(
            policy,
            envs,
            obs,
            False,
            horizon,
            gamma,
            sde_sample_freq=sde_sample_freq,
            obs_transform=obs_transform,
        )
        returns = returns.reshape(n, n_rollouts)
        stderr = returns.std(axis=1, ddof=1) / math.sqrt(n_rollouts) if n_rollouts > 1 else None
        if stderr is None:
            stderr = np.full(n, np.nan)
        return returns.mean(axis=1), stderr, int(lengths.sum())


#: Steps a copy of a probe state is checked for (:meth:`ProbeStates._copy_is_faithful`).
_COPY_CHECK_STEPS = 5


def _replay(
    env_id: str, seed: int, actions: Sequence[Any], env: gym.Env | None = None
) -> tuple[gym.Env, np.ndarray]:
    """``env`` (by default a new unwrapped ``env_id``) reset with ``seed`` and stepped with
    ``actions``, and its observation there."""
    env = gym.make(env_id).unwrapped if env is None else env
    o, _ = env.reset(seed=seed)
    for a in actions:
        o = env.step(a)[0]
    return env, np.asarray(o)


def _same_step(a: tuple[Any, ...], b: tuple[Any, ...]) -> bool:
    """Whether two ``step`` results have the same observation, reward and flags."""
    return bool(np.array_equal(a[0], b[0])) and tuple(a[1:4]) == tuple(b[1:4])


def mc_horizon(gamma: float, episode_steps: int) -> int:
    """Monte Carlo horizon: where ``gamma^H`` falls below :data:`MC_TAIL`, at most
    :data:`MC_MAX_EPISODES` episode lengths.

    The ignored tail is at most ``gamma^H`` times the value scale (recorded as
    ``tail_bound``): below 1 % except for MountainCarContinuous-v0 (gamma 0.9999, capped at
    ``5 * 999`` steps, tail 0.61).
    """
    if not 0 < gamma < 1:
        return MC_MAX_EPISODES * episode_steps
    needed = math.ceil(math.log(MC_TAIL) / math.log(gamma))
    return int(max(1, min(needed, MC_MAX_EPISODES * episode_steps)))


def _probe_actions(env: gym.Env, n: int, seed: int) -> list[Any]:
    space = copy.deepcopy(env.action_space)
    space.seed(seed)
    return [space.sample() for _ in range(n)]
