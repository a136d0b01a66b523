"""Shadow critics: critics that learn beside a comparison run, from the batches it feeds its own.

A diagnosis that compares critics on *the same data* (so that the critic is the only thing
that differs) feeds every batch the run's critic learns from to other critics too:

* :func:`ppo_spec`: the comparison's PPO run of a critic with a setting (kernel, adaptation,
  other GP options);
* :func:`gp_shadow`: a fresh GP critic built exactly as that run's policy builds it;
* :class:`MLPShadow`: SB3's MLP critic of the comparison's ``mlp`` run, trained on the
  batches as PPO trains its critic;
* :class:`ShadowFeed`: the callback that gives them every rollout of a run of SB3's MLP
  critic (SB3's returns, which SB3's MLP critic learns);
* :class:`ActorDrift`: the callback that measures how far the run's actor moved at every
  rollout end and gives each GP shadow's learner (:meth:`ActorDrift.learner`) the drift since
  the batch it last learnt, as :class:`~sb3_geogp.GPValueCallback` gives the run's own GP
  critic its, for shadows that forget by it (``drift_forgetting``);
* :class:`TeeFeed`: a run's GP critic's feed, which hands every batch it feeds to the shadows
  too (SB3's returns, as 0.23's default fed the GP critic, or the PPO family's default since
  0.24, Monte Carlo returns);
* :class:`OwnReturnsFeed`, :class:`MonteCarloFeed`: the feeds that give a shadow what its own
  training would give it, beside a run of any critic (the GAE returns of its own values, as
  PPO trains SB3's critic; Monte Carlo returns with its own bootstraps, as PPO's default feed
  trains a GP critic);
* :func:`learn_with_shadows`: a run trained with an MLP shadow and GP shadows beside it, each
  critic's values (the run's own too) given to a callback that scores them at rollout ends;
* :func:`study_parser`, :func:`run_study`: the command line and the resumable loop over actors
  and seeds of a study built on them (``examples/action_gap.py``, ``advantage_error.py``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from torch import Tensor
from tqdm.auto import tqdm

from sb3_geogp.callbacks import (
    GPValueCallback,
    Target,
    default_feed,
    rollout_states,
    time_limit_truncations,
)
from sb3_geogp.comparison.run import build_model, write_json_atomic
from sb3_geogp.comparison.specs import RunSpec, SweepConfig, setting_differences
from sb3_geogp.drift import PolicyDrift, drift_keyword
from sb3_geogp.kernels import Kernel
from sb3_geogp.policies import GPActorCriticPolicy
from sb3_geogp.sparse_gp import SparseOnlineGP
from sb3_geogp.studies.advantage_error import gae
from sb3_geogp.targets import Segment, completed_returns, empty_segment, per_env
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter

#: A shadow critic's learning step: ``learn(x, y, episode_starts)``, shapes (n, d), (n,), (n,).
Learner = Callable[[Tensor, Tensor, Tensor], None]
#: A critic's values of a batch of states, numpy in and out: shapes (n, d) -> (n,), float64.
NumpyValue = Callable[[np.ndarray], np.ndarray]
#: The names under which :func:`learn_with_shadows` gives the run's own critic and its MLP
#: shadow.
OWN, MLP = "run's own critic", "SB3 MLP critic (shadow)"
#: A study's results: per actor, per seed, what its run returned.
StudyResults = dict[str, dict[int, Any]]


def ppo_spec(env_id: str, seed: int, timesteps: int, setting: dict[str, Any]) -> RunSpec:
    """The comparison's PPO run of a critic on ``env_id`` with ``setting``, its GP critic fed
    SB3's returns (as the shadows are).

    Parameters
    ----------
    env_id : str
    seed : int
    timesteps : int
    setting : dict
        :class:`~sb3_geogp.adaptation.Adaptation` settings, plus optionally ``"gp_options"``
        (other options of the GP critic, e.g. ``{"max_basis": 1024}``), ``"kernel"`` (the
        critic: ``"geodesic"``, the default, ``"rbf"``, ``"laplacian"``, or ``"mlp"``) and
        ``"target"`` / ``"horizon"`` (what the GP critic is fed: SB3's returns by default;
        ``None`` for :class:`~sb3_geogp.GPValueCallback`'s default feed, as the drop-in policy
        is trained).
    """
    special = ("gp_options", "kernel", "target", "horizon")
    adapt = {k: v for k, v in setting.items() if k not in special}
    options = {**setting.get("gp_options", {}), **({"adapt": adapt} if adapt else {})}
    config = SweepConfig(
        algos=("ppo",),
        critics=(setting.get("kernel", "geodesic"),),
        envs=(env_id,),
        seeds=(seed,),
        timesteps=timesteps,
        gp_options=tuple(sorted(options.items())),
        target=setting.get("target", "returns"),
        horizon=setting.get("horizon"),
    )
    (spec,) = config.specs()
    return spec


def built_model(spec: RunSpec, kernel: Kernel | None = None) -> OnPolicyAlgorithm:
    """``spec``'s model (with ``kernel`` in place of the one ``spec.critic`` names, if given)
    with its training environments closed: a shadow needs its critic only.

    Sets torch's thread count to 1 for the process, as the comparison's runs do.
    """
    th.set_num_threads(1)
    model = build_model(spec, kernel)
    env = model.get_env()
    assert env is not None
    env.close()
    return model


def gp_critic(model: OnPolicyAlgorithm) -> SparseOnlineGP:
    """The GP of a model with a GP critic."""
    if not isinstance(model.policy, GPActorCriticPolicy):
        raise TypeError(f"the model's policy has no GP critic: {type(model.policy).__name__}")
    return model.policy.gp


def gp_shadow(spec: RunSpec, kernel: Kernel | None = None) -> SparseOnlineGP:
    """A fresh GP critic of ``spec`` (``spec.critic`` a kernel name, which ``kernel``, an
    instance, may replace), built as its policy builds it: same observation bounds and options.
    Feed it with ``update(x, y, episode_starts)``, or through :meth:`ActorDrift.learner`
    where it forgets by the actor's drift (``drift_forgetting``) as the run's critic does."""
    return gp_critic(built_model(spec, kernel))


class MLPShadow:
    """SB3's MLP critic of the comparison's ``mlp`` PPO run, trained as PPO trains it.

    For each batch given to :meth:`learn`: ``n_epochs`` passes over shuffled minibatches of
    ``batch_size`` of PPO's value loss alone (``vf_coef`` times the mean squared error), with
    the policy's optimizer and gradient clipping. The actor gets no gradient, so only the
    critic learns, from the targets it is given.

    Parameters
    ----------
    env_id : str
    seed : int
        Seed of the network's initialisation and of the minibatch order.
    """

    def __init__(self, env_id: str, seed: int) -> None:
        model = built_model(dataclasses.replace(ppo_spec(env_id, seed, 1, {}), critic="mlp"))
        assert isinstance(model, PPO)
        self.model = model
        self.generator = th.Generator().manual_seed(seed)

    def predict(self, x: Tensor) -> Tensor:
        """Values of states ``x : (n, d)``; shape (n,)."""
        with th.no_grad():
            return self.model.policy.predict_values(x.float())[:, 0]

    def learn(self, x: Tensor, y: Tensor, learning_rate: float | None = None) -> None:
        """PPO's critic epochs on the batch ``x : (n, d)``, ``y : (n,)``.

        ``learning_rate``: the step size (``None``: the schedule's initial value, what a
        replay that knows no training progress uses).
        """
        model, policy = self.model, self.model.policy
        rate = model.lr_schedule(1.0) if learning_rate is None else learning_rate
        for group in policy.optimizer.param_groups:
            group["lr"] = rate
        obs, target = x.float(), y.float()
        for _ in range(model.n_epochs):
            order = th.randperm(x.shape[0], generator=self.generator)
            for start in range(0, x.shape[0], model.batch_size):
                rows = order[start : start + model.batch_size]
                error = policy.predict_values(obs[rows])[:, 0] - target[rows]
                loss = model.vf_coef * error.square().mean()
                policy.optimizer.zero_grad()
                loss.backward()
                th.nn.utils.clip_grad_norm_(policy.parameters(), model.max_grad_norm)
                policy.optimizer.step()


class ShadowFeed(BaseCallback):
    """Feeds every rollout's states and SB3 returns, env by env, as
    :class:`~sb3_geogp.GPValueCallback` feeds them, to shadow critics.

    Pass it after the run's :class:`~sb3_geogp.GPValueCallback`, whose deferred values complete
    the returns, and GP shadows' learners from an :class:`ActorDrift` before it.

    Parameters
    ----------
    learners : sequence of callables
        Each called with ``(x, y, episode_starts)`` per rollout (:data:`Learner`).
    """

    def __init__(self, learners: Sequence[Learner]) -> None:
        super().__init__()
        self.learners = list(learners)

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        buffer = cast(OnPolicyAlgorithm, self.model).rollout_buffer
        x, y, starts = per_env(buffer.observations, buffer.returns, buffer.episode_starts)
        for learn in self.learners:
            learn(th.as_tensor(x), th.as_tensor(y), th.as_tensor(starts))


class ActorDrift(BaseCallback):
    """Measures how far the run's actor moved at every rollout end, on the rollout's states
    (:class:`~sb3_geogp.drift.PolicyDrift`, as :class:`~sb3_geogp.GPValueCallback` measures it
    for the run's own GP critic), and passes it to GP shadows that forget by it.

    :meth:`learner` gives a shadow's :data:`Learner`: its ``update`` with ``drift`` the sum of
    the drifts since the batch it last learnt, as the run's own critic gets it (the drift of a
    rollout that feeds it nothing waits for the next batch). Put this callback before the feeds
    in the callback list. It measures only where a shadow has ``drift_forgetting > 0``.
    """

    def __init__(self) -> None:
        super().__init__()
        self._drift = PolicyDrift()
        self._learners: list[_DriftingUpdate] = []

    def learner(self, gp: SparseOnlineGP) -> Learner:
        """``gp``'s learner, fed the drift of the run's actor since its last batch."""
        learn = _DriftingUpdate(gp)
        self._learners.append(learn)
        return learn

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        if not any(learn.gp.drift_forgetting > 0 for learn in self._learners):
            return
        model = cast(OnPolicyAlgorithm, self.model)
        drift = self._drift.measure(model.policy, *rollout_states(model.rollout_buffer))
        for learn in self._learners:
            learn.pending = drift + learn.pending


class _DriftingUpdate:
    """A GP shadow's :data:`Learner` that passes the drift held for it (:class:`ActorDrift`)."""

    def __init__(self, gp: SparseOnlineGP) -> None:
        self.gp = gp
        self.pending = 0.0

    def __call__(self, x: Tensor, y: Tensor, episode_starts: Tensor) -> None:
        drift, self.pending = self.pending, 0.0
        self.gp.update(x, y, episode_starts, **drift_keyword(drift))


class OwnBootstraps(BaseCallback):
    """Base of the feeds that give a shadow critic a rollout's rewards with its own time-limit
    bootstraps: at a truncation SB3 adds ``gamma * V(terminal observation)`` of the run's
    critic to the reward; :meth:`own_rewards` puts the shadow's value in its place.

    Parameters
    ----------
    learn : callable
        The shadow's :data:`Learner`.
    value : callable
        The shadow's values (:data:`NumpyValue`), read at the rollout's end before it learns.
    """

    def __init__(self, learn: Learner, value: NumpyValue) -> None:
        super().__init__()
        self.learn, self.value = learn, value
        self._bootstraps: list[tuple[int, int, np.ndarray, float]] = []

    def _on_rollout_start(self) -> None:
        self._bootstraps = []

    def _on_step(self) -> bool:
        model = cast(OnPolicyAlgorithm, self.model)
        for step, env, terminal in time_limit_truncations(model, self.locals):
            # What SB3 adds right after this hook, computed as it computes it.
            with th.no_grad():
                added = model.policy.predict_values(
                    th.as_tensor(terminal[None], device=model.device)
                )
            self._bootstraps.append((step, env, terminal, float(added[0, 0])))
        return True

    def own_rewards(self) -> np.ndarray:
        """The rollout's rewards, float64, shape (n_steps, n_envs), with the shadow's
        bootstraps at the truncations."""
        model = cast(OnPolicyAlgorithm, self.model)
        rewards = model.rollout_buffer.rewards.astype(np.float64)
        for step, env, terminal, added in self._bootstraps:
            own = self.value(terminal[None].astype(np.float64))[0]
            rewards[step, env] += float(model.gamma) * (own - added)
        return rewards


class OwnReturnsFeed(OwnBootstraps):
    """Feeds a shadow critic the GAE returns of every rollout computed with its own values, as
    PPO computes them for the critic it trains: ``A + V``, with ``V`` the shadow's values at the
    rollout's states and after its last step, and its own time-limit bootstraps
    (:class:`OwnBootstraps`).

    Parameters
    ----------
    learn : callable
        The shadow's :data:`Learner`, called once per rollout, env by env.
    value : callable
        The shadow's values (:data:`NumpyValue`), read at the rollout's end before it learns.
    """

    def _on_rollout_end(self) -> None:
        model = cast(OnPolicyAlgorithm, self.model)
        buffer, gamma = model.rollout_buffer, float(model.gamma)
        T, n_envs = buffer.rewards.shape
        rewards = self.own_rewards()
        obs = buffer.observations.reshape(T * n_envs, -1).astype(np.float64)
        values = self.value(obs).reshape(T, n_envs)
        last = self.value(np.asarray(model._last_obs, dtype=np.float64).reshape(n_envs, -1))
        last_dones = np.asarray(model._last_episode_starts, dtype=np.float64)
        lam = float(model.gae_lambda)
        advantages = gae(rewards, values, buffer.episode_starts, last, last_dones, gamma, lam)
        x, y, starts = per_env(buffer.observations, advantages + values, buffer.episode_starts)
        self.learn(th.as_tensor(x), th.as_tensor(y), th.as_tensor(starts))


class MonteCarloFeed(OwnBootstraps):
    """Feeds a shadow critic the Monte Carlo returns of the episodes each rollout completes, as
    :class:`~sb3_geogp.GPValueCallback` with ``target="monte_carlo"`` feeds the run's GP critic
    (:func:`~sb3_geogp.targets.completed_returns`: episodes stitched across rollouts per env),
    but with the shadow's own values wherever a return bootstraps: at time-limit truncations
    (:class:`OwnBootstraps`) and at the ``horizon`` cut. Runs beside a critic of any kind.

    Parameters
    ----------
    learn : callable
        The shadow's :data:`Learner`, called at each rollout end that completes an episode.
    value : callable
        The shadow's values (:data:`NumpyValue`), read at the rollout's end before it learns.
    horizon : int or None
        As :class:`~sb3_geogp.GPValueCallback`'s.
    """

    def __init__(self, learn: Learner, value: NumpyValue, horizon: int | None) -> None:
        super().__init__(learn, value)
        self.horizon = horizon
        self._pending: list[Segment] = []

    def _init_callback(self) -> None:
        buffer = cast(OnPolicyAlgorithm, self.model).rollout_buffer
        self._pending = [empty_segment(buffer.obs_shape)] * buffer.n_envs

    def _on_rollout_end(self) -> None:
        buffer = cast(OnPolicyAlgorithm, self.model).rollout_buffer
        x, y, starts = completed_returns(
            self._pending,
            buffer.observations,
            self.own_rewards(),
            buffer.episode_starts,
            np.asarray(self.locals["dones"], dtype=bool),
            float(buffer.gamma),
            self.horizon,
            self.value,
        )
        if len(y):  # no episode completed: nothing to learn, as for the run's GP critic
            self.learn(th.as_tensor(x), th.as_tensor(y), th.as_tensor(starts))


class TeeFeed(GPValueCallback):
    """:class:`~sb3_geogp.GPValueCallback` that gives every batch it feeds the run's GP critic
    to shadow critics too, right after it: with ``target="monte_carlo"`` (PPO's default feed)
    the shadows learn the same completed episodes' returns, when the run's critic does.

    Parameters
    ----------
    learners : sequence of callables
        Each called with ``(x, y, episode_starts)`` per batch (:data:`Learner`).
    target : {"returns", "monte_carlo"} or None
        As :class:`~sb3_geogp.GPValueCallback`'s (``None``: its default feed).
    """

    def __init__(self, learners: Sequence[Learner], target: Target | None) -> None:
        super().__init__(target=target)
        self.learners = list(learners)

    def on_fed(self, obs: np.ndarray, targets: np.ndarray, starts: np.ndarray) -> None:
        if len(targets):  # no episode completed: the run's critic learnt nothing either
            for learn in self.learners:
                learn(th.as_tensor(obs), th.as_tensor(targets), th.as_tensor(starts))


def own_feed(
    learn: Learner, value: NumpyValue, setting: Mapping[str, Any], model: OnPolicyAlgorithm
) -> OwnBootstraps:
    """What :class:`~sb3_geogp.GPValueCallback` would feed a GP shadow of ``setting`` (a
    :func:`ppo_spec` setting) if it were ``model``'s critic: the setting's ``"target"`` and
    ``"horizon"``, or where it names no target the algorithm's default feed
    (:func:`~sb3_geogp.callbacks.default_feed`), every return bootstrapped on the shadow's own
    values. SB3's returns (``"returns"``) are then the GAE returns of its values
    (:class:`OwnReturnsFeed`); Monte Carlo returns come from :class:`MonteCarloFeed`."""
    target, horizon = setting.get("target"), setting.get("horizon")
    if target is None:
        target, horizon = default_feed(type(model), float(model.rollout_buffer.gamma))
    if target == "returns":
        return OwnReturnsFeed(learn, value)
    return MonteCarloFeed(learn, value, horizon)


def numpy_value(fn: Callable[[Tensor], Tensor]) -> NumpyValue:
    """``fn`` (values of float64 states) as a function of numpy arrays."""
    return lambda s: fn(th.as_tensor(s, dtype=th.float64)).double().cpu().numpy()


def posterior_mean(gp: SparseOnlineGP) -> NumpyValue:
    """A GP critic's values: its posterior mean."""
    return numpy_value(lambda x: gp.predict(x, return_var=False)[0])


def own_value(model: OnPolicyAlgorithm) -> NumpyValue:
    """The values of a model's own critic: its GP's posterior mean, or SB3's value network."""
    policy = model.policy
    if isinstance(policy, GPActorCriticPolicy):
        return posterior_mean(policy.gp)
    return numpy_value(lambda x: policy.predict_values(x.float())[:, 0].detach())


def learn_with_shadows(
    model: OnPolicyAlgorithm,
    env_id: str,
    seed: int,
    timesteps: int,
    settings: Mapping[str, dict[str, Any]],
    checkpoints: Callable[[dict[str, NumpyValue]], BaseCallback],
    kernels: Mapping[str, Kernel] | None = None,
    target: Target | Literal["defaults"] = "returns",
) -> BaseCallback:
    """Train ``model`` (a comparison run of ``env_id`` and ``seed``) for ``timesteps`` with
    shadow critics learning from its rollouts: :class:`MLPShadow` and a :func:`gp_shadow` per
    entry of ``settings`` (name -> :func:`ppo_spec` setting), with the kernel instance that
    ``kernels`` gives the same name, if any.

    ``checkpoints(values)`` builds the callback that scores the critics: ``values`` maps
    :data:`OWN`, :data:`MLP` and each name of ``settings`` to the critic's values
    (:data:`NumpyValue`). It runs at each rollout end before any critic learns from the
    rollout (the run's own GP critic's values of the rollout are placeholders until then, read
    them through ``values``). The training environments are closed afterwards.

    ``target``: what every critic learns. ``"returns"``: SB3's returns of each rollout.
    ``"monte_carlo"``: the returns of completed episodes, uncut, as PPO's default feed gives
    them to a GP critic (the run's must be one); the MLP shadow then learns them too. The run's
    own GP critic is then fed by :class:`TeeFeed`, which hands each batch to the shadows; a run
    with SB3's MLP critic, by :class:`ShadowFeed`. ``"defaults"``: what each critic's own
    training gives it, so that every critic learns as it would train the agent: the run's own
    critic its training's feed (:class:`~sb3_geogp.GPValueCallback`'s default feed for a GP
    critic), each GP shadow what that callback would feed it with its setting's ``"target"``
    (unset: the default feed), bootstrapped on its own values (:func:`own_feed`), the MLP
    shadow the GAE returns of its own values (:class:`OwnReturnsFeed`), as PPO trains SB3's
    critic.

    Raises
    ------
    ValueError
        ``target="monte_carlo"`` for a model without a GP critic, or another ``target``.

    Returns
    -------
    BaseCallback
        The callback ``checkpoints`` built, after training.
    """
    if target not in ("returns", "monte_carlo", "defaults"):
        raise ValueError(f"target must be 'returns', 'monte_carlo' or 'defaults', got {target!r}")
    own_gp = isinstance(model.policy, GPActorCriticPolicy)
    if target == "monte_carlo" and not own_gp:
        raise ValueError(
            "target='monte_carlo' feeds the shadows what the run's GP critic is fed: train the "
            "run with a GP critic, or use target='returns' or 'defaults'"
        )
    mlp = MLPShadow(env_id, seed)
    kernels = kernels or {}
    gps = {
        name: gp_shadow(ppo_spec(env_id, seed, 1, s), kernels.get(name))
        for name, s in settings.items()
    }
    values: dict[str, NumpyValue] = {OWN: own_value(model), MLP: numpy_value(mlp.predict)}
    values.update({name: posterior_mean(gp) for name, gp in gps.items()})

    def learn_mlp(x: Tensor, y: Tensor, _starts: Tensor) -> None:
        # The rate PPO's train() is about to use: SB3 updates its progress only after the
        # rollout's end, where the shadows learn.
        progress = 1.0 - model.num_timesteps / model._total_timesteps
        mlp.learn(x, y, model.lr_schedule(progress))

    scorer = checkpoints(values)
    drift = ActorDrift()
    updates = {name: drift.learner(gp) for name, gp in gps.items()}
    feeds: list[BaseCallback]
    if target == "defaults":
        feeds = [
            *([GPValueCallback()] if own_gp else []),
            OwnReturnsFeed(learn_mlp, values[MLP]),
            *(own_feed(updates[name], values[name], settings[name], model) for name in gps),
        ]
    else:
        learners: list[Learner] = [learn_mlp, *updates.values()]
        feeds = [TeeFeed(learners, target) if own_gp else ShadowFeed(learners)]
    model.learn(timesteps, callback=CallbackList([scorer, drift, *feeds]))
    env = model.get_env()
    assert env is not None
    env.close()
    return scorer


def study_parser(
    description: str,
    actors: Sequence[str],
    timesteps: int,
    critics: Mapping[str, dict[str, Any]],
    out: Path,
) -> argparse.ArgumentParser:
    """The options every shadow study has: ``--actors`` (the critics that train the agent),
    ``--seeds``, ``--timesteps``, ``--critics`` (JSON ``{name: setting}`` of GP shadow
    critics, :func:`ppo_spec` settings) and ``--out``, with these defaults."""
    parser = argparse.ArgumentParser(description=description, formatter_class=DefaultsHelpFormatter)
    parser.add_argument("--actors", nargs="+", default=list(actors))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--timesteps", type=int, default=timesteps)
    parser.add_argument(
        "--critics",
        type=json.loads,
        default=dict(critics),
        help='JSON {name: setting} of GP shadow critics (e.g. {"RBF GP": {"kernel": "rbf"}})',
    )
    parser.add_argument("--out", type=Path, default=out)
    return parser


#: Arguments of every shadow study that say which runs to make or where, not how they run.
_WHICH_RUNS = ("actors", "seeds", "out")


def run_settings(args: argparse.Namespace, reading: Collection[str] = ()) -> dict[str, Any]:
    """The arguments that make a study's runs what they are, as JSON gives them back: all but
    :data:`_WHICH_RUNS` and ``reading`` (those that only read the runs)."""
    settings = {k: v for k, v in vars(args).items() if k not in {*_WHICH_RUNS, *reading}}
    return dict(json.loads(json.dumps(settings, default=str)))


def check_run_settings(args: argparse.Namespace, reading: Collection[str] = ()) -> None:
    """Refuse an ``--out`` whose finished runs were made with other settings (a run is kept by
    actor and seed alone and not run again): ``OUT/settings.json``, or for a folder written
    before it, the arguments in ``OUT/results.json``; settings neither names are not compared.
    Records the settings for the next call.

    Raises
    ------
    SystemExit
        Naming each setting that differs.
    """
    settings = run_settings(args, reading)
    stored, published = args.out / "settings.json", args.out / "results.json"
    saved: dict[str, Any] | None = None
    if stored.exists():
        saved = json.loads(stored.read_text())
    elif published.exists():
        saved = json.loads(published.read_text()).get("args")
    if saved is not None and any((args.out / "runs").glob("*.json")):
        common = [k for k in settings if k in saved]
        made, asked = {k: saved[k] for k in common}, {k: settings[k] for k in common}
        if made != asked:
            raise SystemExit(
                f"error: {args.out} holds runs made with other settings "
                f"({setting_differences(made, asked)}); pass another --out, or the same "
                "settings to add seeds or actors"
            )
    write_json_atomic(stored, settings)


def _distinct(records: list[Any]) -> list[Any]:
    """``records`` without repeats, in order of first appearance."""
    out: list[Any] = []
    for r in records:
        if r not in out:
            out.append(r)
    return out


def run_study(
    args: argparse.Namespace,
    run: Callable[[str, int, argparse.Namespace], dict[str, Any]],
    table: Callable[[StudyResults], str],
    plot: Callable[[StudyResults, Path], None],
    figure: str,
    reading: Collection[str] = (),
) -> StudyResults:
    """``run(actor, seed, args)`` for every actor and seed of ``args`` not yet in
    ``OUT/runs/`` (a finished run is kept there, with the provenance of the code that made it,
    and not run again; an ``--out`` whose runs were made with other settings is refused,
    :func:`check_run_settings`, ``reading`` naming the arguments that only read them), then
    ``table`` printed and written to ``OUT/table.md``, every result with the arguments to
    ``OUT/results.json`` (``provenance``: the distinct records of its runs, ``None`` for runs
    made before 0.31.5, which kept none), and ``plot`` to ``OUT/<figure>``."""
    check_run_settings(args, reading)
    (args.out / "runs").mkdir(parents=True, exist_ok=True)
    results: StudyResults = {a: {} for a in args.actors}
    jobs = [(a, s) for a in args.actors for s in args.seeds]
    for actor, seed in tqdm(jobs, unit="run", desc="PPO runs"):
        path = args.out / "runs" / f"{actor}__s{seed}.json"
        if not path.exists():
            write_json_atomic(path, {**run(actor, seed, args), "provenance": provenance()})
        results[actor][seed] = json.loads(path.read_text())
    text = table(results)
    print(text)
    (args.out / "table.md").write_text(text)
    write_json_atomic(
        args.out / "results.json",
        {
            "args": {**vars(args), "out": str(args.out)},
            "results": results,
            "provenance": _distinct(
                [r.get("provenance") for runs in results.values() for r in runs.values()]
            ),
        },
    )
    plot(results, args.out / figure)
    return results
