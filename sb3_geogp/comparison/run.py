"""One run: train a model as a user would, measure it, write its result file atomically.

:func:`run_one` trains ``PPO(GPActorCriticPolicy, env, policy_kwargs=dict(gp_kwargs=...))``
with ``callback=GPValueCallback()``, or with SB3's ``"MlpPolicy"``, and writes one JSON file
(:func:`result_path`) with the metrics of the run:

* evaluation curve (:mod:`~sb3_geogp.comparison.evaluation`): mean undiscounted return of
  the deterministic policy over ``n_eval_episodes`` episodes of a separate evaluation
  environment at every checkpoint;
* final return (the last evaluation), steps to the run's threshold (:attr:`RunSpec.threshold
  <sb3_geogp.comparison.specs.RunSpec>`) and training seconds to it (``seconds_to_threshold``,
  wall clock; ``train_clock``: the training seconds at every evaluation, wall clock and CPU);
* wall clock (and CPU time of the process) of ``learn`` without the measurements made
  inside it (``train_seconds``, ``train_cpu_seconds``), and for GP critics the seconds
  spent in the critic: ``GPValueCallback``'s rollout-end work (target assembly, logging and
  :attr:`~sb3_geogp.GPValueCallback.update_seconds` of GP updates) plus every GP value prediction
  through ``policy.value_net`` inside ``learn`` (rollout collection and the algorithm's
  training passes; timed with forward hooks, the measurements excluded);
* critic accuracy at checkpoints against Monte Carlo returns (:class:`~sb3_geogp.comparison.
  evaluation.ProbeStates`);
* provenance: git commit, engine hash, package versions and the CPU kernels torch used
  (:func:`~sb3_geogp.toolbox.provenance.provenance`);
* the distinct warnings raised during the run (``"Category: message"``), caught so that a
  sweep can show each once instead of every worker printing it into the progress bar.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import stable_baselines3
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

import sb3_geogp.envs  # noqa: F401  (registers the package's environments with gymnasium)
from sb3_geogp.comparison.evaluation import (
    EVAL_SEED,
    PROBE_SEED,
    ProbeStates,
    mc_horizon,
)
from sb3_geogp.comparison.hyperparams import (
    ALGOS,
    ALL_CRITICS,
    DEVIATIONS,
    algo_kwargs,
    normalize_kwargs,
)
from sb3_geogp.comparison.measurement import ForwardTimer, MeasureCallback, TimedGPValueCallback
from sb3_geogp.comparison.specs import RunSpec
from sb3_geogp.kernels import Kernel
from sb3_geogp.policies import GPActorCriticPolicy
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.stats import steps_to_threshold

#: Version of the result-file layout.
SCHEMA = 1


def result_path(out_dir: str | Path, spec: RunSpec) -> Path:
    """Where the result of ``spec`` lives: ``out_dir/runs/<run_id>.json``."""
    return Path(out_dir) / "runs" / f"{spec.run_id}.json"


def write_json_atomic(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same folder and ``os.replace``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".tmp", dir=path.parent)
    try:
        # mkstemp makes the file private (0600); give it the mode any new file gets here.
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1, allow_nan=False)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def run_one(
    spec: RunSpec,
    out_dir: str | Path,
    recorders: Sequence[BaseCallback] = (),
    kernel: Kernel | None = None,
) -> dict[str, Any]:
    """Train one model, measure it, write its result file atomically; return the result.

    Parameters
    ----------
    spec : RunSpec
    out_dir : str or Path
        Sweep folder; the result goes to :func:`result_path`.
    recorders : sequence of BaseCallback
        Callbacks that watch the run without changing it (e.g. per-rollout diagnostics of a
        published run, re-run exactly): they come after the GP callback and the measurements.
    kernel : Kernel, optional
        The GP critic's kernel in place of the one ``spec.critic`` names (a study's own kernel,
        e.g. one that knows the walls); the result records its class as ``"kernel"``.

    Returns
    -------
    dict
        The JSON content (see the module docstring).
    """
    threads = th.get_num_threads()
    th.set_num_threads(1)  # small networks and a small GP: one thread is fastest
    try:
        with warnings.catch_warnings(record=True) as caught:
            # The zoo's PPO settings for MountainCarContinuous-v0 (batch_size 256 > n_steps 8)
            # make SB3 warn about a truncated mini-batch at every construction; expected here.
            warnings.filterwarnings("ignore", message=".*mini-batch size.*", category=UserWarning)
            result = _train_and_measure(spec, recorders, kernel)
    finally:
        th.set_num_threads(threads)
    result["warnings"] = list(dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught))
    write_json_atomic(result_path(out_dir, spec), result)
    return result


def build_model(spec: RunSpec, kernel: Kernel | None = None) -> OnPolicyAlgorithm:
    """The model of ``spec`` on its training environments, built as a user would build it.

    SB3's ``"MlpPolicy"`` for the ``mlp`` critic, else :class:`~sb3_geogp.GPActorCriticPolicy`
    with the spec's GP options and the same ``policy_kwargs``: its actor starts from the MLP
    policy's parameters for the same seed. ``kernel``, if given, replaces the kernel
    ``spec.critic`` names (a GP critic's only). With ``spec.normalize`` the environments are
    wrapped in ``VecNormalize`` as rl-baselines3-zoo wraps them; with ``spec.actor_normalize``
    the GP critic's policy normalises its actor's observations. Close ``model.get_env()``
    when done.
    """
    if spec.critic not in ALL_CRITICS:
        raise ValueError(f"critic must be one of {ALL_CRITICS}, got {spec.critic!r}")
    if spec.critic == "mlp" and (kernel is not None or spec.actor_normalize):
        raise ValueError(
            "a kernel and actor_normalize are for a GP critic; the spec's critic is 'mlp'"
        )
    n_envs, kwargs, policy_kwargs = algo_kwargs(spec.algo, spec.hyperparams)
    env: VecEnv = make_vec_env(spec.env_id, n_envs=n_envs, seed=spec.seed)
    if spec.normalize:
        vec_kwargs = normalize_kwargs(spec.hyperparams)
        if vec_kwargs is None:
            raise ValueError(
                f"normalize: the {spec.algo} entry for {spec.env_id} does not normalise"
            )
        env = VecNormalize(env, **vec_kwargs)
    if spec.critic == "mlp":
        return ALGOS[spec.algo](
            "MlpPolicy", env, seed=spec.seed, policy_kwargs=policy_kwargs, device="cpu", **kwargs
        )
    if spec.actor_normalize:
        policy_kwargs["normalize_actor_obs"] = True
    policy_kwargs["gp_kwargs"] = dict(
        kernel=spec.critic if kernel is None else kernel, **dict(spec.gp_kwargs)
    )
    return ALGOS[spec.algo](
        GPActorCriticPolicy,
        env,
        seed=spec.seed,
        policy_kwargs=policy_kwargs,
        device="cpu",
        **kwargs,
    )


def _train_and_measure(
    spec: RunSpec, recorders: Sequence[BaseCallback], kernel: Kernel | None
) -> dict[str, Any]:
    eval_envs = [gym.make(spec.env_id) for _ in range(spec.n_eval_episodes)]
    probes = ProbeStates.build(spec.env_id, spec.n_probe_states)
    model = build_model(spec, kernel)  # last: it seeds the global random streams training uses
    env = model.get_env()
    assert env is not None
    gp_callback, value_timer = _critic_timers(model, spec)
    checkpoints = MeasureCallback(spec, eval_envs, probes, value_timer)
    callbacks = [c for c in (gp_callback, checkpoints) if c is not None]
    start, cpu_start = checkpoints.start_clock()
    model.learn(spec.total_timesteps, callback=CallbackList([*callbacks, *recorders]))
    learn_seconds = time.perf_counter() - start
    learn_cpu_seconds = time.process_time() - cpu_start
    # Training time: learn() without the measurements made inside it.
    train_seconds = learn_seconds - checkpoints.seconds
    checkpoints.measure(final=True)
    env.close()

    result: dict[str, Any] = dict(
        schema=SCHEMA,
        run_id=spec.run_id,
        spec=spec.as_dict(),
        hyperparams=dict(
            source=spec.hyperparams_source,
            values=spec.hyperparams,
            deviations=list(DEVIATIONS),
        ),
        **_evaluation(spec, checkpoints),
        num_timesteps=int(model.num_timesteps),
        max_episode_steps=probes.episode_steps,
        wall_clock_seconds=learn_seconds,
        train_seconds=train_seconds,
        train_cpu_seconds=learn_cpu_seconds - checkpoints.cpu_seconds,
        checkpoint_seconds=checkpoints.seconds,
        checkpoint_cpu_seconds=checkpoints.cpu_seconds,
        checkpoint_cost=checkpoints.cost,
        **_critic_time(gp_callback, value_timer, train_seconds),
        critic_accuracy=_critic_accuracy(spec, checkpoints, float(model.gamma), probes),
        gp_n_basis=(
            int(model.policy.gp.n_basis) if isinstance(model.policy, GPActorCriticPolicy) else None
        ),
        provenance=provenance(stable_baselines3, gym),
        finished_at=time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    )
    if kernel is not None:
        result["kernel"] = f"{type(kernel).__module__}.{type(kernel).__qualname__}"
    return result


def _evaluation(spec: RunSpec, checkpoints: MeasureCallback) -> dict[str, Any]:
    """The evaluation curve, its last point, the steps and training seconds to the run's
    threshold, and the training clock at every evaluation."""
    mean_curve = np.array([np.mean(r) for r in checkpoints.eval_returns])
    timesteps = np.array(checkpoints.eval_timesteps, dtype=np.float64)
    steps = float(steps_to_threshold(timesteps, mean_curve, spec.threshold))
    seconds = dict(zip(checkpoints.eval_timesteps, checkpoints.train_seconds, strict=True))
    return dict(
        eval=dict(
            timesteps=checkpoints.eval_timesteps,
            mean_return=[float(x) for x in mean_curve],
            returns=checkpoints.eval_returns,
            deterministic=True,
            episode_seeds=[EVAL_SEED + i for i in range(spec.n_eval_episodes)],
        ),
        final_return=float(mean_curve[-1]),
        threshold=spec.threshold,
        steps_to_threshold=_finite_or_none(steps),
        # Apart from ``eval``, which the same seed reproduces exactly: clocks never do.
        train_clock=dict(
            seconds=checkpoints.train_seconds, cpu_seconds=checkpoints.train_cpu_seconds
        ),
        seconds_to_threshold=seconds[int(steps)] if math.isfinite(steps) else None,
    )


def _critic_accuracy(
    spec: RunSpec, checkpoints: MeasureCallback, gamma: float, probes: ProbeStates
) -> dict[str, Any]:
    """The critic's errors at the checkpoints and how their Monte Carlo values were made."""
    horizon = mc_horizon(gamma, probes.episode_steps)
    return dict(
        **checkpoints.critic,
        n_states=spec.n_probe_states,
        n_rollouts=spec.n_mc_rollouts,
        horizon=horizon,
        gamma=gamma,
        tail_bound=gamma**horizon,
        probe_seed=PROBE_SEED,
    )


def _critic_timers(
    model: OnPolicyAlgorithm, spec: RunSpec
) -> tuple[TimedGPValueCallback | None, ForwardTimer | None]:
    """A GP critic's feeding callback, timed, and a timer on its value predictions; ``None``
    twice for SB3's MLP critic."""
    if not isinstance(model.policy, GPActorCriticPolicy):
        return None, None
    callback = TimedGPValueCallback(
        target=spec.target, horizon=spec.horizon, feed_every=spec.feed_every
    )
    return callback, ForwardTimer(model.policy.value_net)


def _critic_time(
    gp_callback: TimedGPValueCallback | None, value_timer: ForwardTimer | None, train: float
) -> dict[str, Any]:
    """``critic_seconds`` (its parts) and ``critic_share`` (of ``train`` seconds): the time in
    a GP critic, its feeding and its predictions; ``None`` for SB3's MLP critic."""
    if gp_callback is None or value_timer is None:
        return dict(critic_seconds=None, critic_share=None)
    return dict(
        critic_seconds=dict(
            gp_update=gp_callback.update_seconds,
            rollout_end=gp_callback.rollout_end_seconds,
            value_predict=value_timer.seconds,
        ),
        critic_share=(gp_callback.rollout_end_seconds + value_timer.seconds) / train,
    )


def load_result(path: Path) -> dict[str, Any] | None:
    """The result in ``path``, or ``None`` if it is missing or unreadable (then it reruns)."""
    try:
        with open(path) as f:
            data = json.load(f)
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("schema") == SCHEMA else None
