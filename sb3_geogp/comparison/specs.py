"""Runs and sweeps: :class:`RunSpec` defines one run, :class:`SweepConfig` a product of runs."""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from sb3_geogp.callbacks import Target, default_feed
from sb3_geogp.comparison.hyperparams import (
    ALGOS,
    CRITICS,
    ENVS,
    GP_KWARGS,
    HyperparamsFile,
    algo_kwargs,
    hyperparams,
    normalize_kwargs,
    normalizes_actor,
    threshold,
)
from sb3_geogp.comparison.results import env_file_name
from sb3_geogp.policies import default_adaptation

#: How a GP option names one setting of the adaptation (``adapt.prior_sd``)
ADAPT_PREFIX = "adapt."


def gp_kwargs_for(options: Sequence[tuple[str, Any]], algo: str) -> tuple[tuple[str, Any], ...]:
    """The GP critics' options under ``algo`` (a key of
    :data:`~sb3_geogp.comparison.hyperparams.ALGOS`), sorted: :data:`GP_KWARGS` with
    ``options`` on top (:func:`with_gp_options`).

    Raises
    ------
    ValueError
        If a setting is changed while ``adapt`` turns the adaptation off.
    """
    return tuple(sorted(with_gp_options(GP_KWARGS, options, algo).items()))


def with_gp_options(
    gp_kwargs: Mapping[str, Any], options: Sequence[tuple[str, Any]], algo: str
) -> dict[str, Any]:
    """``gp_kwargs`` with ``options`` on top, where a key ``"adapt.NAME"`` changes that one
    setting of the adaptation: of the settings ``adapt`` gives as a dict, else of ``algo``'s
    default (:func:`~sb3_geogp.policies.default_adaptation`; ``algo`` a key of
    :data:`~sb3_geogp.comparison.hyperparams.ALGOS`), so that a command line can say "PPO's
    default with ``prior_sd=None``" as ``adapt.prior_sd=None``.

    Raises
    ------
    ValueError
        If a setting is changed while ``adapt`` turns the adaptation off.
    """
    merged = dict(gp_kwargs)
    changes = {}
    for key, value in options:
        if key.startswith(ADAPT_PREFIX):
            changes[key.removeprefix(ADAPT_PREFIX)] = value
        else:
            merged[key] = value
    if changes:
        adapt = merged.get("adapt", True)
        if adapt is True:
            adapt = default_adaptation(ALGOS[algo]).as_dict()
        if not isinstance(adapt, Mapping):
            raise ValueError(
                f"adapt.{next(iter(changes))}=... changes a setting of the adaptation, and "
                f"adapt={adapt!r} gives none to change: drop one of them"
            )
        merged["adapt"] = {**adapt, **changes}
    return merged


def fed(
    target: Target | None, horizon: int | None, algo: str, critic: str, gamma: float | None = None
) -> tuple[Target, int | None]:
    """The target ``critic`` learns under ``algo`` (a key of
    :data:`~sb3_geogp.comparison.hyperparams.ALGOS`) with discount ``gamma`` (``None``: the
    algorithm's default) and where it is cut, when ``target`` and ``horizon`` are asked for:
    SB3's returns, uncut, for the MLP critic; else as asked, or where ``target`` is ``None``
    ``GPValueCallback``'s default (:func:`~sb3_geogp.callbacks.default_feed`)."""
    if critic == "mlp":
        return "returns", None
    if target is None:
        algorithm = ALGOS[algo]
        if gamma is None:
            gamma = inspect.signature(algorithm).parameters["gamma"].default
        return default_feed(algorithm, gamma)
    return target, horizon


def setting_differences(made: Any, asked: Any) -> str:
    """Where a recorded setting differs from the one asked for, for an error message: per key
    of two dicts, ``"key: <made> there, <asked> now"`` (``unset`` where a side lacks the key),
    joined by ``"; "``; other values as ``"<made> there, <asked> now"``."""
    if not (isinstance(made, dict) and isinstance(asked, dict)):
        return f"{made!r} there, {asked!r} now"

    def shown(d: dict[str, Any], key: str) -> str:
        return repr(d[key]) if key in d else "unset"

    keys = sorted(set(made) | set(asked), key=str)
    differ = [k for k in keys if k not in made or k not in asked or made[k] != asked[k]]
    return "; ".join(f"{k}: {shown(made, k)} there, {shown(asked, k)} now" for k in differ)


#: :class:`RunSpec` fields added after result files existed, and the value that runs made
#: before them had: a spec records them only where they differ from it.
_RECORDED_WHERE_SET: dict[str, Any] = {
    "target": "returns",
    "horizon": None,
    "feed_every": 1,
    "normalize": False,
    "actor_normalize": False,
}


@dataclass(frozen=True)
class RunSpec:
    """Everything that defines one run; equal specs give the same result file name.

    Attributes
    ----------
    algo : {"ppo", "a2c"}
    critic : str
        One of :data:`~sb3_geogp.comparison.hyperparams.ALL_CRITICS`: ``"mlp"``, or the GP
        critic's kernel (``"rbf"``, ``"geodesic"``, ``"laplacian"``).
    env_id : str
    seed : int
        Seed of the model and the training environments.
    total_timesteps : int
    n_checkpoints : int
        Evaluations at ``k * total_timesteps / n_checkpoints``, ``k = 0..n_checkpoints``
        (at the first rollout start at or after each), plus one at the end of training.
    n_eval_episodes : int
        Deterministic evaluation episodes per checkpoint.
    critic_every : int
        Critic accuracy at every ``critic_every``-th checkpoint (and the final one).
    n_probe_states : int
        Probe states of the critic-accuracy measurement.
    n_mc_rollouts : int
        Monte Carlo rollouts of the stochastic policy per probe state.
    gp_kwargs : tuple of (key, value)
        Options of the GP critic (ignored for ``mlp``), as sorted items.
    target : {"returns", "monte_carlo"}
        The value targets :class:`~sb3_geogp.GPValueCallback` feeds the GP critic (ignored
        for ``mlp``, which learns SB3's returns).
    horizon : int, optional
        ``GPValueCallback``'s ``horizon`` (with ``target="monte_carlo"``).
    feed_every : int
        ``GPValueCallback``'s ``feed_every`` (ignored for ``mlp``).
    normalize : bool
        Train in ``VecNormalize`` as rl-baselines3-zoo does where the entry has ``normalize``
        (:func:`~sb3_geogp.comparison.hyperparams.normalize_kwargs`). The evaluations and the
        probes then see observations normalised with the training statistics, and the
        critic's values are scaled back to returns. A GP critic then learns from observations
        and returns in moving units (``GPValueCallback`` warns).
    actor_normalize : bool
        A GP critic's policy normalises its actor's observations
        (``GPActorCriticPolicy(normalize_actor_obs=True)``), where the entry's ``normalize``
        normalises observations; the critic's observations and the rewards stay raw.
    hyperparams : dict
        The algorithm's hyperparameters, an entry in rl-baselines3-zoo's format
        (:func:`~sb3_geogp.comparison.hyperparams.algo_kwargs`).
    hyperparams_source : str
        Where they come from (:class:`~sb3_geogp.comparison.hyperparams.Hyperparams`).
    threshold : float
        Mean evaluation return that counts as solved (steps to threshold).
    """

    algo: str
    critic: str
    env_id: str
    seed: int
    total_timesteps: int
    n_checkpoints: int = 20
    n_eval_episodes: int = 10
    critic_every: int = 4
    n_probe_states: int = 32
    n_mc_rollouts: int = 4
    gp_kwargs: tuple[tuple[str, Any], ...] = field(
        default_factory=lambda: tuple(sorted(GP_KWARGS.items()))
    )
    target: Target = "returns"
    horizon: int | None = None
    feed_every: int = 1
    normalize: bool = False
    actor_normalize: bool = False
    hyperparams: dict[str, Any] = field(kw_only=True, hash=False)
    hyperparams_source: str = field(kw_only=True)
    threshold: float = field(kw_only=True)

    @property
    def run_id(self) -> str:
        """File-name stem, e.g. ``ppo__geodesic__sb3_geogp-WallMaze-v0__s3`` (without the
        module of a ``"module:EnvId"`` id)."""
        return f"{self.algo}__{self.critic}__{env_file_name(self.env_id)}__s{self.seed}"

    def as_dict(self) -> dict[str, Any]:
        """JSON-compatible view of the run settings (``gp_kwargs`` as a dict).

        Without ``hyperparams``, ``hyperparams_source`` and ``threshold``: a result file
        records them beside the spec (``hyperparams``, ``threshold``). ``target`` only where it
        is not ``"returns"``, ``horizon`` only where set, ``feed_every`` only where not 1,
        ``normalize`` and ``actor_normalize`` only where true, so that the files of runs made
        before they existed still match.
        """
        d = dataclasses.asdict(self)
        d["gp_kwargs"] = dict(self.gp_kwargs)
        for name, default in _RECORDED_WHERE_SET.items():
            if d[name] == default:
                del d[name]
        for recorded_beside in ("hyperparams", "hyperparams_source", "threshold"):
            del d[recorded_beside]
        return d


@dataclass(frozen=True)
class SweepConfig:
    """A sweep: the product of its lists, with common run settings.

    Attributes
    ----------
    algos, critics, envs : tuple of str
        ``envs``: gymnasium ids, ``"module:EnvId"`` to import the module that registers one.
    seeds : tuple of int
    timesteps_scale : float
        Multiplies the budgets (:data:`~sb3_geogp.comparison.hyperparams.TIMESTEPS`, or a
        file's ``n_timesteps``); each run gets at least two rollouts.
    timesteps : int, optional
        Budget of every run instead (``timesteps_scale`` then does not apply).
    thresholds : tuple of (env id, float)
        Steps-to-threshold levels replacing the default ones
        (:func:`~sb3_geogp.comparison.hyperparams.threshold`).
    hyperparams_files : tuple of (algo, HyperparamsFile)
        The hyperparameters of these algorithms come from these files instead of the
        built-in tables.
    n_checkpoints, n_eval_episodes, critic_every, n_probe_states, n_mc_rollouts : int
        As :class:`RunSpec`.
    gp_options : tuple of (key, value)
        Options of the GP critic on top of :data:`GP_KWARGS` (e.g. ``(("forgetting", 0.9),)``),
        the same for every kernel; ``("adapt.NAME", value)`` changes one setting of each
        algorithm's adaptation (:func:`gp_kwargs_for`).
    target : {"returns", "monte_carlo"}, optional
        As :class:`RunSpec`; ``None`` (default): ``GPValueCallback``'s default target and
        horizon for each algorithm (:func:`~sb3_geogp.callbacks.default_feed`).
    horizon : int, optional
        As :class:`RunSpec`. The MLP critic's runs, which learn SB3's returns, record
        ``target="returns"`` and no horizon whatever these are.
    feed_every : int
        As :class:`RunSpec`; the MLP critic's runs record 1.
    mlp_normalize, gp_normalize : bool
        SB3's MLP critic, and the GP critics, train in ``VecNormalize`` where the zoo's entry
        normalises (:attr:`RunSpec.normalize`).
    gp_actor_normalize : bool
        The GP critics' policies normalise their actors' observations where the zoo's entry
        normalises observations (:attr:`RunSpec.actor_normalize`); not with ``gp_normalize``.
    """

    algos: tuple[str, ...] = tuple(ALGOS)
    critics: tuple[str, ...] = CRITICS
    envs: tuple[str, ...] = ENVS
    seeds: tuple[int, ...] = (0, 1, 2, 3, 4)
    timesteps_scale: float = 1.0
    n_checkpoints: int = 20
    n_eval_episodes: int = 10
    critic_every: int = 4
    n_probe_states: int = 32
    n_mc_rollouts: int = 4
    gp_options: tuple[tuple[str, Any], ...] = ()
    target: Target | None = None
    horizon: int | None = None
    feed_every: int = 1
    mlp_normalize: bool = False
    gp_normalize: bool = False
    gp_actor_normalize: bool = False
    timesteps: int | None = None
    thresholds: tuple[tuple[str, float], ...] = ()
    hyperparams_files: tuple[tuple[str, HyperparamsFile], ...] = ()

    @classmethod
    def quick(cls, seeds: Sequence[int] = (0, 1)) -> SweepConfig:
        """The ``--quick`` smoke sweep: 5 % budgets, 3 evaluation episodes, small probes."""
        return cls(
            seeds=tuple(seeds),
            timesteps_scale=0.05,
            n_checkpoints=4,
            n_eval_episodes=3,
            critic_every=2,
            n_probe_states=8,
            n_mc_rollouts=2,
        )

    def specs(self) -> list[RunSpec]:
        """One :class:`RunSpec` per run, environments outermost, seeds innermost.

        Raises
        ------
        ValueError
            If an environment has no hyperparameters, a bad one, no budget or no threshold,
            or with both ``gp_normalize`` and ``gp_actor_normalize``.
        """
        if self.gp_normalize and self.gp_actor_normalize:
            raise ValueError(
                "gp_normalize puts the GP critics' environments in VecNormalize, "
                "gp_actor_normalize normalises their actors' observations alone: choose one"
            )
        files = dict(self.hyperparams_files)
        levels = dict(self.thresholds)
        out = []
        for env_id in self.envs:
            level = threshold(env_id, levels.get(env_id))
            for algo in self.algos:
                hp = hyperparams(algo, env_id, files.get(algo))
                try:
                    n_envs, kwargs, _ = algo_kwargs(algo, hp.values)
                    # Read only when asked for: without it every critic drops normalize.
                    normalises = (self.mlp_normalize or self.gp_normalize) and (
                        normalize_kwargs(hp.values) is not None
                    )
                    actor_normalises = self.gp_actor_normalize and normalizes_actor(hp.values)
                except ValueError as err:
                    raise ValueError(f"{hp.source}, {algo} on {env_id}: {err}") from None
                rollout = n_envs * int(kwargs.get("n_steps", 2048 if algo == "ppo" else 5))
                steps = max(2 * rollout, self._budget(algo, env_id, hp.n_timesteps))
                gamma = kwargs.get("gamma")
                gp_kwargs = gp_kwargs_for(self.gp_options, algo)
                for critic in self.critics:
                    target, horizon = fed(self.target, self.horizon, algo, critic, gamma)
                    for seed in self.seeds:
                        out.append(
                            RunSpec(
                                algo=algo,
                                critic=critic,
                                env_id=env_id,
                                seed=seed,
                                total_timesteps=int(steps),
                                n_checkpoints=self.n_checkpoints,
                                n_eval_episodes=self.n_eval_episodes,
                                critic_every=self.critic_every,
                                n_probe_states=self.n_probe_states,
                                n_mc_rollouts=self.n_mc_rollouts,
                                gp_kwargs=gp_kwargs,
                                target=target,
                                horizon=horizon,
                                feed_every=1 if critic == "mlp" else self.feed_every,
                                normalize=normalises
                                and (self.mlp_normalize if critic == "mlp" else self.gp_normalize),
                                actor_normalize=actor_normalises and critic != "mlp",
                                hyperparams=hp.values,
                                hyperparams_source=hp.source,
                                threshold=level,
                            )
                        )
        return out

    def _budget(self, algo: str, env_id: str, n_timesteps: float | None) -> int:
        if self.timesteps is not None:
            return self.timesteps
        if n_timesteps is None:
            raise ValueError(
                f"no budget for {algo} on {env_id}: pass --timesteps N, or set n_timesteps in "
                "its --hyperparams file"
            )
        return round(n_timesteps * self.timesteps_scale)
