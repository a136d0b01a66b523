"""Callbacks that measure a run inside ``learn``: time in the critic, checkpoints, per-rollout
records."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.vec_env import VecNormalize, unwrap_vec_normalize

from sb3_geogp.callbacks import GPValueCallback
from sb3_geogp.comparison.evaluation import (
    EVAL_SEED,
    ProbeStates,
    lockstep_returns,
    max_episode_steps,
)
from sb3_geogp.comparison.specs import RunSpec
from sb3_geogp.toolbox.stats import explained_variance


def rollout_explained_variance(buffer: Any) -> float:
    """:func:`~sb3_geogp.toolbox.stats.explained_variance` of a rollout buffer's returns and
    values (SB3's formula with the division in float64: SB3's divides the float32 variances as
    float32; the published per-rollout records were written with this one).

    Parameters
    ----------
    buffer : RolloutBuffer
        ``returns`` and ``values``, each shape (n_steps, n_envs).
    """
    return explained_variance(buffer.returns, buffer.values)


class RolloutRecorder(BaseCallback):
    """One row per rollout: the dict :meth:`row` returns at each rollout's end.

    Put it after :class:`~sb3_geogp.GPValueCallback` (``run_one``'s ``recorders`` are) to read
    the rollout buffer once the GP critic's values, returns and advantages are final, and what
    the GP logged for the rollout (``self.model.logger.name_to_value``).
    """

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, Any]] = []

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self.rows.append(self.row())

    def row(self) -> dict[str, Any]:
        """What to keep of the rollout that just ended."""
        raise NotImplementedError


class ForwardTimer:
    """Forward hooks on a module accumulating its forward time while ``enabled``."""

    def __init__(self, module: th.nn.Module) -> None:
        self.seconds = 0.0
        self.enabled = True
        self._start = 0.0
        module.register_forward_pre_hook(self._pre)
        module.register_forward_hook(self._post)

    def _pre(self, *_: Any) -> None:
        self._start = time.perf_counter()

    def _post(self, *_: Any) -> None:
        if self.enabled:
            self.seconds += time.perf_counter() - self._start


class TimedGPValueCallback(GPValueCallback):
    """:class:`~sb3_geogp.GPValueCallback` that also times its whole rollout-end work."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        #: Seconds in ``_on_rollout_end`` (targets, logging, GP update).
        self.rollout_end_seconds = 0.0

    def _on_rollout_end(self) -> None:
        start = time.perf_counter()
        super()._on_rollout_end()
        self.rollout_end_seconds += time.perf_counter() - start


class MeasureCallback(BaseCallback):
    """Evaluation curve and critic accuracy at the rollout starts after each checkpoint.

    At a rollout start the last ``train`` and the GP update are both done, so actor and critic
    are measured in the same state. The measurements use their own torch random stream, so
    they do not change training. With every evaluation goes the training clock so far
    (:attr:`train_seconds`, :attr:`train_cpu_seconds`): the wall-clock and CPU seconds since
    ``learn`` started, the measurements' own excluded, so that a run's time to a return is
    read as its steps to it are.
    """

    def __init__(
        self,
        spec: RunSpec,
        eval_envs: list[gym.Env],
        probes: ProbeStates,
        value_timer: ForwardTimer | None,
    ) -> None:
        super().__init__(verbose=0)
        self.spec = spec
        self.eval_envs = eval_envs
        self.probes = probes
        self.value_timer = value_timer
        self.targets = [
            round(k * spec.total_timesteps / spec.n_checkpoints)
            for k in range(spec.n_checkpoints + 1)
        ]
        self.next = 0
        #: Wall-clock and CPU (this process) seconds of all measurements.
        self.seconds = 0.0
        self.cpu_seconds = 0.0
        #: Wall-clock seconds, CPU seconds and environment steps of the evaluations and of the
        #: Monte Carlo rollouts.
        self.cost: dict[str, float] = dict(
            eval_seconds=0.0,
            eval_cpu_seconds=0.0,
            eval_env_steps=0,
            mc_seconds=0.0,
            mc_cpu_seconds=0.0,
            mc_env_steps=0,
        )
        self.eval_timesteps: list[int] = []
        self.eval_returns: list[list[float]] = []
        #: Training seconds (wall clock, CPU) before each evaluation, as ``eval_timesteps``.
        self.train_seconds: list[float] = []
        self.train_cpu_seconds: list[float] = []
        self._learn_started: tuple[float, float] | None = None
        self.critic: dict[str, list[float | None]] = {
            k: [] for k in ("timesteps", "rmse", "mae", "bias", "mc_stderr", "mc_std")
        }

    def start_clock(self) -> tuple[float, float]:
        """Start the training clock (call just before ``learn``); returns its start,
        ``time.perf_counter()`` and ``time.process_time()``."""
        self._learn_started = (time.perf_counter(), time.process_time())
        return self._learn_started

    def _on_training_start(self) -> None:
        if self._learn_started is None:  # learn() without start_clock(): start it here
            self.start_clock()

    def _on_step(self) -> bool:
        return True

    def _on_rollout_start(self) -> None:
        now = self.model.num_timesteps
        if self.next < len(self.targets) and now >= self.targets[self.next]:
            while self.next < len(self.targets) and now >= self.targets[self.next]:
                self.next += 1
            self.measure(final=False)

    def measure(self, final: bool) -> None:
        """Evaluate now (and measure the critic at every ``critic_every``-th or the final)."""
        if self.eval_timesteps and self.eval_timesteps[-1] == self.model.num_timesteps:
            return
        start, cpu_start = time.perf_counter(), time.process_time()
        started, cpu_started = self._learn_started or (start, cpu_start)
        self.train_seconds.append(start - started - self.seconds)
        self.train_cpu_seconds.append(cpu_start - cpu_started - self.cpu_seconds)
        if self.value_timer is not None:
            self.value_timer.enabled = False
        policy = self.model.policy
        assert isinstance(policy, ActorCriticPolicy)
        was_training = policy.training
        policy.set_training_mode(False)
        with th.random.fork_rng():
            th.manual_seed(self.spec.seed * 100_003 + len(self.eval_timesteps))
            self._evaluate(policy)
            if final or (len(self.eval_timesteps) - 1) % self.spec.critic_every == 0:
                self._critic_accuracy(policy)
        policy.set_training_mode(was_training)
        if self.value_timer is not None:
            self.value_timer.enabled = True
        self.seconds += time.perf_counter() - start
        self.cpu_seconds += time.process_time() - cpu_start

    def _normalizer(self) -> VecNormalize | None:
        """The training environments' ``VecNormalize`` (:attr:`RunSpec.normalize`), if any."""
        env = self.model.get_env()
        return None if env is None else unwrap_vec_normalize(env)

    def _obs_transform(self) -> Callable[[np.ndarray], np.ndarray] | None:
        """What the policy sees of a raw observation: normalised with the training statistics,
        as rl-baselines3-zoo's evaluation environments see it."""
        normalizer = self._normalizer()
        if normalizer is None:
            return None
        return lambda obs: np.asarray(normalizer.normalize_obs(obs))  # Box observations only

    def _value_scale(self) -> float:
        """Returns per unit of the critic's values: ``VecNormalize`` divides rewards by the
        running standard deviation of the discounted return, so a critic trained on them
        predicts returns divided by it (exactly where the rewards' clipping did not act)."""
        normalizer = self._normalizer()
        if normalizer is None or not normalizer.norm_reward:
            return 1.0
        return float(np.sqrt(normalizer.ret_rms.var + normalizer.epsilon))

    def _evaluate(self, policy: ActorCriticPolicy) -> None:
        obs = np.stack([env.reset(seed=EVAL_SEED + i)[0] for i, env in enumerate(self.eval_envs)])
        horizon = max_episode_steps(self.spec.env_id)
        start, cpu_start = time.perf_counter(), time.process_time()
        returns, lengths = lockstep_returns(
            policy, self.eval_envs, obs, True, horizon, obs_transform=self._obs_transform()
        )
        self.cost["eval_seconds"] += time.perf_counter() - start
        self.cost["eval_cpu_seconds"] += time.process_time() - cpu_start
        self.cost["eval_env_steps"] += int(lengths.sum())
        self.eval_timesteps.append(int(self.model.num_timesteps))
        self.eval_returns.append([float(r) for r in returns])

    def _critic_accuracy(self, policy: ActorCriticPolicy) -> None:
        gamma = float(getattr(self.model, "gamma", 0.99))
        transform = self._obs_transform()
        start, cpu_start = time.perf_counter(), time.process_time()
        mc, stderr, n_steps = self.probes.monte_carlo(
            policy,
            gamma,
            self.spec.n_mc_rollouts,
            seed=len(self.eval_timesteps),
            sde_sample_freq=int(getattr(self.model, "sde_sample_freq", -1)),
            obs_transform=transform,
        )
        self.cost["mc_seconds"] += time.perf_counter() - start
        self.cost["mc_cpu_seconds"] += time.process_time() - cpu_start
        self.cost["mc_env_steps"] += n_steps
        with th.no_grad():
            seen = self.probes.obs if transform is None else transform(self.probes.obs)
            obs_t, _ = policy.obs_to_tensor(seen)
            pred = policy.predict_values(obs_t).cpu().numpy().reshape(-1).astype(np.float64)
        pred *= self._value_scale()
        err = pred - mc
        c = self.critic
        c["timesteps"].append(int(self.model.num_timesteps))
        c["rmse"].append(float(np.sqrt(np.mean(err**2))))
        c["mae"].append(float(np.mean(np.abs(err))))
        c["bias"].append(float(np.mean(err)))
        # One rollout per state has no standard error: null in the JSON, not NaN.
        c["mc_stderr"].append(float(stderr.mean()) if self.spec.n_mc_rollouts > 1 else None)
        c["mc_std"].append(float(np.std(mc)))
