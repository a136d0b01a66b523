"""What the adaptation costs and what its schedule buys: settings replayed on the same data.

Issue 13 asks for adaptation at most 10% of the GP critic's time. Cheaper settings
(:class:`~sb3_geogp.adaptation.Adaptation`'s ``max_gap``, ``score_points``, ``fold_points``,
``steps``, ``fit_points``) trade fit for time; this script measures both on identical data, so
that a setting is the only thing that changes:

1. **Record.** One PPO run per environment and seed, the comparison's run
   (:func:`~sb3_geogp.comparison.run.build_model`: zoo hyperparameters, the GP critic with the
   comparison's options, here adaptive with its defaults, fed SB3's returns as
   :func:`~sb3_geogp.comparison.shadow.ppo_spec` says), for ``--timesteps`` steps; every
   batch the GP critic is fed (states, returns, episode starts) is kept in
   ``OUT/streams/`` or ``--streams`` (an interrupted call resumes from the streams already
   there; another call can replay other settings on them).
2. **Replay.** For each setting, a fresh GP critic built as the policy builds it (same
   observation bounds) is fed the recorded batches in order. Before each batch it predicts the
   batch: its out-of-sample explained variance ``1 - Var(y - mu) / Var(y)``, outside the
   clock. The clock times its ``update`` calls (one torch thread) and, inside them, what only
   an adaptive GP does (out-of-sample statistics and forgetting scores, the summary of points
   leaving the window, the adaptation proper), as ``examples/benchmark_training.py`` does.

``--same-policy`` asks whether a critic's fit is limited by the change of policy from one
rollout to the next: each batch is split at the environment boundary in its middle (the
callback feeds it env by env), and its second half is scored twice, by the critic before it
learns from the batch (the next-rollout fit above, on half the points), and by a copy of it
that has first learnt the batch's first half, other environments of the *same* policy
(:func:`same_policy`; the first setting's GP critic, and SB3's MLP critic with ``--mlp``;
untimed). Written to ``OUT/same_policy.md`` and ``same_policy`` in ``OUT/results.json``.

References, scored on the same batches and untimed: ``--mlp``, SB3's MLP critic trained on
them as PPO trains it (:func:`replay_mlp`); ``--batch``, the default GP critic's basis refitted
in batch on each newest batch alone, with its kernel and with the Euclidean Laplacian kernel,
and with its kernel at the on-line GP's own hyperparameters (:func:`replay_batch`), which
separates what the basis and the kernel allow from what the on-line GP makes of them;
``--exact`` (the ``bench`` extra), exact GPs without a basis on the newest batch or two, their
hyperparameters fitted by maximum likelihood or the on-line GP's own (:func:`replay_exact`,
:data:`EXACT`), which separates what the model allows from what the basis loses.

Writes ``OUT/results.json`` (per environment, seed and setting: update and adaptation
seconds, explained variance per batch), ``OUT/table.md`` (adaptation share of the update
time; explained variance over the last 20% of batches, mean over seeds, and its paired
difference from the first setting with a 95% t interval) and ``OUT/frontier.png``.

    python examples/adaptation_schedule.py --seeds 0 1 2 --out docs/adaptation_schedule
    python examples/adaptation_schedule.py --settings '{"default": {}, "gap4": {"max_gap": 4}}'
    python examples/adaptation_schedule.py --envs sb3_geogp/PaperPendulum-v0 --mlp --batch
    python examples/adaptation_schedule.py --envs Acrobot-v1 --timesteps 30000 \
        --settings '{"default": {}}' --exact
    python examples/adaptation_schedule.py --envs Acrobot-v1 --settings '{"default": {}}' \
        --mlp --same-policy

Time it on an otherwise idle machine: the replays run one after another.
"""

from __future__ import annotations

import argparse
import copy
import functools
import hashlib
import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from tqdm.auto import tqdm

from sb3_geogp import GPValueCallback, SparseOnlineGP
from sb3_geogp.comparison.run import build_model, write_json_atomic
from sb3_geogp.comparison.shadow import MLPShadow, gp_critic, gp_shadow, ppo_spec
from sb3_geogp.kernels import LaplacianKernel
from sb3_geogp.studies.exact_gp import exact_gp
from sb3_geogp.studies.pendulum.batch_check import batch_sparse_gp, online_hyper
from sb3_geogp.toolbox.benchmarks import GPClock
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg
from sb3_geogp.toolbox.stats import mean_ci

ENVS = ("CartPole-v1", "Acrobot-v1", "Pendulum-v1", "sb3_geogp/PaperPendulum-v0")
#: The settings replayed by default (merged into the comparison's ``adapt``).
SETTINGS: dict[str, dict[str, Any]] = {
    "default": {},
    "thin 512": {"score_points": 512, "fold_points": 512},
    "thin 512, gap 2": {"score_points": 512, "fold_points": 512, "max_gap": 2},
    "thin 512, gap 4": {"score_points": 512, "fold_points": 512, "max_gap": 4},
    "thin 512, gap 16": {"score_points": 512, "fold_points": 512, "max_gap": 16},
    "thin 512, 2 steps": {"score_points": 512, "fold_points": 512, "steps": 2},
}
#: Name of the reference row of ``--mlp``: SB3's MLP critic replayed on the same batches.
MLP = "SB3 MLP critic"
#: Reference rows of ``--batch``: the default GP's basis fitted in batch, with its kernel and
#: with the Euclidean Laplacian kernel (the geodesic kernel's profile without the graph), and
#: with its kernel at the on-line GP's own hyperparameters (no fit).
BATCH = "batch sparse GP, newest batch"
BATCH_EUCLIDEAN = "batch sparse GP, newest batch, Euclidean Laplacian kernel"
BATCH_ONLINE = "batch sparse GP, newest batch, the on-line GP's hyperparameters"
#: Reference rows of ``--exact``: exact GPs (no basis) on the newest batch or two.
EXACT = {
    "exact GP, newest batch, Laplacian, its own hyperparameters": {},
    "exact GP, newest batch, RBF, its own hyperparameters": {"kernel": "rbf"},
    "exact GP, two newest batches, Laplacian, its own hyperparameters": {"history": 2},
    "exact GP, newest batch, the on-line GP's hyperparameters": {"online": True},
    "exact GP, two newest batches, the on-line GP's hyperparameters": {
        "online": True,
        "history": 2,
    },
}
#: Points of each ``--exact`` maximum-likelihood fit (its cost is cubic in them).
EXACT_FIT_POINTS = 1024
#: L-BFGS iterations of each ``--batch`` fit (from the on-line GP's hyperparameters).
BATCH_ITERS = 30
#: Share of the last batches whose explained variance is averaged (as in critic_fit.py).
LAST = 0.2


class StreamRecorder(BaseCallback):
    """Keeps every batch the GP critic is fed, with the drift it was fed with
    (``drift_forgetting``): wraps its ``update`` for the run, calling ``before``, if given,
    first (before the critic learns the batch)."""

    def __init__(self, gp: SparseOnlineGP, before: Callable[[], None] | None = None) -> None:
        super().__init__()
        self.batches: list[tuple[th.Tensor, th.Tensor, th.Tensor | None, float]] = []
        original = gp.update

        def update(x: Any, y: Any, episode_starts: Any = None, drift: float = 0.0) -> None:
            if before is not None:
                before()
            starts = None if episode_starts is None else th.as_tensor(episode_starts).clone()
            batch = (th.as_tensor(x).clone(), th.as_tensor(y).clone(), starts, float(drift))
            self.batches.append(batch)
            original(x, y, episode_starts, drift)

        gp.update = update  # type: ignore[method-assign]

    def _on_step(self) -> bool:
        return True


def record(
    env_id: str,
    seed: int,
    timesteps: int,
    path: Path,
    setting: dict[str, Any] | None = None,
    watch: Callable[[Any], Callable[[], None]] | None = None,
) -> list[Any]:
    """The batches of one PPO run's GP critic (from ``path`` if recorded before), the critic of
    ``setting`` (:func:`~sb3_geogp.comparison.shadow.ppo_spec`; the comparison's geodesic
    critic fed SB3's returns by default). ``watch(model)``, if given, returns what to call
    before each feed (e.g. to copy the actor); it is not called for a recorded ``path``."""
    if path.exists():
        return th.load(path, weights_only=False)
    th.set_num_threads(1)
    spec = ppo_spec(env_id, seed, timesteps, setting or {})
    model = build_model(spec)
    recorder = StreamRecorder(gp_critic(model), None if watch is None else watch(model))
    feed = GPValueCallback(target=spec.target, horizon=spec.horizon)
    model.learn(timesteps, callback=CallbackList([feed, recorder]))
    env = model.get_env()
    assert env is not None
    env.close()
    path.parent.mkdir(parents=True, exist_ok=True)
    # written whole or not at all: a half-written stream would break every later replay
    partial = path.with_suffix(".partial")
    th.save(recorder.batches, partial)
    partial.replace(path)
    return recorder.batches


#: A learner's step: ``learn(x, y, episode_starts, drift)`` (the drift the GP critic was fed
#: with the batch, :meth:`~sb3_geogp.SparseOnlineGP.update`'s; other critics ignore it).
Learn = Callable[[th.Tensor, th.Tensor, th.Tensor | None, float], None]


def batch_parts(batch: tuple[Any, ...]) -> tuple[Any, Any, Any, float]:
    """A recorded batch as ``(x, y, episode_starts, drift)``: older streams hold no drift, and
    their critics were fed none (the recorder refused the keyword)."""
    x, y, starts, *drift = batch
    return x, y, starts, float(drift[0]) if drift else 0.0


def _scored(
    batches: list[Any], predict: Callable[[th.Tensor], th.Tensor], learn: Learn
) -> dict[str, Any]:
    """Feed ``batches`` to ``learn`` in order, each first scored by the explained variance of
    ``predict``'s values for it; the scores and their mean over the last :data:`LAST` of them."""
    explained = []
    for i, batch in enumerate(batches):
        x, y, starts, drift = batch_parts(batch)
        if i > 0 and x.shape[0] > 1:
            explained.append(_explained(y, predict(x)))
        learn(x, y, starts, drift)
    return dict(explained_variance=explained, tail=_tail(explained), n_batches=len(batches))


def _explained(y: th.Tensor, value: th.Tensor) -> float:
    """Explained variance of the targets ``y`` by the values ``value``, in float64."""
    target = y.double()
    return 1.0 - float((target - value.double()).var() / target.var())


def _tail(scores: list[float]) -> float:
    """Mean of the last :data:`LAST` of ``scores``."""
    return float(np.mean(scores[int(np.floor((1 - LAST) * len(scores))) :]))


class _GPLearner:
    """A GP critic as :func:`same_policy` uses it (deep-copyable, untimed)."""

    def __init__(self, gp: SparseOnlineGP) -> None:
        self.gp = gp

    def predict(self, x: th.Tensor) -> th.Tensor:
        return self.gp.predict(x, return_var=False)[0]

    def learn(
        self, x: th.Tensor, y: th.Tensor, starts: th.Tensor | None, drift: float = 0.0
    ) -> None:
        self.gp.update(x, y, starts, drift)


class _MLPLearner(MLPShadow):
    """:class:`~sb3_geogp.comparison.shadow.MLPShadow` with the learners' signature."""

    def learn(  # type: ignore[override]
        self, x: th.Tensor, y: th.Tensor, starts: th.Tensor | None = None, drift: float = 0.0
    ) -> None:
        super().learn(x, y)

    def __deepcopy__(self, memo: dict[int, Any]) -> _MLPLearner:
        # gSDE keeps its exploration weights as non-leaf tensors, which torch refuses to
        # deep-copy; the value function never uses them, and they are resampled anyway.
        dist = self.model.policy.action_dist
        for name, value in list(vars(dist).items()):
            if isinstance(value, th.Tensor):
                setattr(dist, name, value.detach())
            elif isinstance(value, th.distributions.Normal):
                setattr(
                    dist, name, th.distributions.Normal(value.loc.detach(), value.scale.detach())
                )
        twin = _MLPLearner.__new__(_MLPLearner)
        memo[id(self)] = twin
        twin.__dict__.update(copy.deepcopy(self.__dict__, memo))
        return twin


def same_policy(batches: list[Any], learner: Any) -> dict[str, Any]:
    """Fit to the next rollout against fit to other environments of the same rollout.

    ``learner`` (``predict(x)``, ``learn(x, y, starts, drift)``, deep-copyable) is fed
    ``batches`` in order. Each batch after the first is split at the environment boundary in
    its middle; its second half is scored by the explained variance of ``learner``'s values
    before it learns from the batch (``next``), and of a copy's after the copy has learnt the
    first half (``same``). Their difference is what the change of policy between rollouts
    costs the fit.

    Raises
    ------
    ValueError
        If a batch's middle is not an environment boundary (``episode_starts`` there False).
    """
    scores: dict[str, list[float]] = {"next": [], "same": []}
    for i, batch in enumerate(batches):
        x, y, starts, drift = batch_parts(batch)
        half = x.shape[0] // 2
        if starts is None or not bool(starts[half]):
            raise ValueError(
                f"batch {i}: row {half} (its middle) does not start an environment's stretch; "
                "--same-policy needs an even number of environments, fed env by env"
            )
        if i > 0:
            scores["next"].append(_explained(y[half:], learner.predict(x[half:])))
            fork = copy.deepcopy(learner)
            fork.learn(x[:half], y[:half], starts[:half], drift)
            scores["same"].append(_explained(y[half:], fork.predict(x[half:])))
        learner.learn(x, y, starts, drift)
    return {**scores, "tail_next": _tail(scores["next"]), "tail_same": _tail(scores["same"])}


def same_policy_table(results: dict[str, Any]) -> str:
    """Markdown: per environment and critic, the tail fit to the next rollout and to the same
    rollout's other environments (means over seeds), and their paired difference."""
    lines = [
        f"| env | critic | next rollout (last {LAST:.0%}) | same rollout, other envs | "
        "same − next [95% CI] | seeds |",
        "|---|---|---:|---:|---|---:|",
    ]
    for env_id, by_critic in results.items():
        for critic, by_seed in by_critic.items():
            runs = [by_seed[s] for s in sorted(by_seed)]
            diff = np.asarray([r["tail_same"] - r["tail_next"] for r in runs])
            mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
            nxt = np.mean([r["tail_next"] for r in runs])
            same = np.mean([r["tail_same"] for r in runs])
            lines.append(
                f"| `{env_id}` | {critic} | {nxt:.3f} | {same:.3f} | "
                f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}] | {len(runs)} |"
            )
    return "\n".join(lines) + "\n"


def replay(env_id: str, seed: int, batches: list[Any], setting: dict[str, Any]) -> dict[str, Any]:
    """Feed ``batches`` to a fresh GP critic with ``setting``
    (:func:`~sb3_geogp.comparison.shadow.ppo_spec`); time it and score each batch."""
    gp = gp_shadow(ppo_spec(env_id, seed, 1, setting))
    seconds = GPClock(gp).seconds

    def predict(x: th.Tensor) -> th.Tensor:  # the class's method: not timed
        return SparseOnlineGP.predict(gp, x, return_var=False)[0]

    scores = _scored(batches, predict, gp.update)
    return dict(
        update=seconds["update"],
        adaptation=seconds["adaptation"],
        share=seconds["adaptation"] / seconds["update"],
        n_basis=gp.n_basis,
        **scores,
    )


def replay_mlp(env_id: str, seed: int, batches: list[Any]) -> dict[str, Any]:
    """Feed ``batches`` to SB3's own MLP critic as PPO trains it, for reference
    (:class:`~sb3_geogp.comparison.shadow.MLPShadow`, at the initial learning rate); each batch
    is scored first, as :func:`replay` does."""
    mlp = MLPShadow(env_id, seed)
    return dict(
        update=None,
        adaptation=None,
        share=None,
        n_basis=0,
        **_scored(batches, mlp.predict, lambda x, y, _starts, _drift: mlp.learn(x, y)),
    )


def replay_batch(
    env_id: str,
    seed: int,
    batches: list[Any],
    euclidean: bool = False,
    refit: bool = True,
    recorded: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The default GP critic's basis and kernel, refitted in batch on the newest batch alone.

    A fresh default GP critic is fed the batches as in :func:`replay`. Each batch is predicted
    by :func:`~sb3_geogp.studies.pendulum.batch_check.batch_sparse_gp` fitted on every point
    of the batch before it: the on-line GP's basis vectors as inducing points and its kernel
    (for the geodesic kernel, its tree), the hyperparameters at the optimum of the collapsed
    bound of that batch (:data:`BATCH_ITERS` L-BFGS iterations from the on-line GP's own).
    What this reference scores above the on-line GP, the basis and the kernel allow; the
    on-line GP loses it to what it keeps of older batches and to its few Adam steps. The GP
    critic is that of ``recorded``, the setting the batches were recorded with
    (:func:`record`). With ``refit=False`` the hyperparameters are the on-line GP's own (no
    iteration): the basis alone then separates it from :func:`replay_exact`'s exact GP. With
    ``euclidean``, the kernel is instead a :class:`~sb3_geogp.kernels.LaplacianKernel` with the
    on-line GP's lengthscales: the same basis without the graph.
    """
    gp = gp_shadow(ppo_spec(env_id, seed, 1, recorded or {}))
    newest: dict[str, np.ndarray] = {}

    def predict(x: th.Tensor) -> th.Tensor:
        z = gp.basis_inputs.clone()
        n_factors, _ = gp.kernel.correlation_fn(z[:1], z)
        start = online_hyper(gp, n_factors, float(np.std(newest["y"], ddof=1)))
        kernel = gp.kernel
        if euclidean:
            kernel = LaplacianKernel(gp.kernel.lengthscale.tolist())
            kernel.bind(z.shape[1], z.shape[0])
        fit = batch_sparse_gp(
            kernel, newest["x"], newest["y"], z, x.double().numpy(), (start,), BATCH_ITERS * refit
        )
        return th.as_tensor(fit.mean)

    def learn(x: th.Tensor, y: th.Tensor, starts: th.Tensor | None, drift: float) -> None:
        gp.update(x, y, starts, drift)
        newest.update(x=x.double().numpy(), y=y.double().numpy())

    return dict(
        update=None,
        adaptation=None,
        share=None,
        n_basis=gp.n_basis,
        **_scored(batches, predict, learn),
    )


def replay_exact(
    env_id: str,
    seed: int,
    batches: list[Any],
    kernel: str = "laplacian",
    history: int = 1,
    online: bool = False,
    recorded: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """An exact GP on the ``history`` newest batches (:func:`~sb3_geogp.studies.exact_gp.exact_gp`).

    Each batch is predicted by the exact posterior on every point of the ``history`` batches
    before it, with the hyperparameters at the optimum of the exact marginal likelihood on
    :data:`EXACT_FIT_POINTS` of those points, or with ``online`` the recorded GP critic's own
    at that moment (a fresh one of the ``recorded`` setting, :func:`record`'s, fed the
    batches as in :func:`replay`; lengthscales, and its noise to signal ratio): no basis, no
    summary of older batches, so what scores above the on-line GP here its approximations
    lose. The distance is Euclidean: for a geodesic critic the graph goes too.
    """
    gp = gp_shadow(ppo_spec(env_id, seed, 1, recorded or {})) if online else None
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    learnt = [0]  # batches learnt so far: each fit draws its points with its own seed

    def predict(x: th.Tensor) -> th.Tensor:
        inputs = np.concatenate([k[0] for k in kept])
        targets = np.concatenate([k[1] for k in kept])
        fixed = None
        if gp is not None:
            ratio = float(gp.noise_var) / float(gp.kernel.variance)
            fixed = (gp.kernel.lengthscale.double().numpy(), 1.0, ratio)
        fit = exact_gp(inputs, targets, kernel, EXACT_FIT_POINTS, seed=learnt[0], fixed=fixed)
        return th.as_tensor(fit.predict(x.double().numpy()))

    def learn(x: th.Tensor, y: th.Tensor, starts: th.Tensor | None, drift: float) -> None:
        if gp is not None:
            gp.update(x, y, starts, drift)
        kept.append((x.double().numpy(), y.double().numpy()))
        del kept[:-history]
        learnt[0] += 1

    return dict(
        update=None, adaptation=None, share=None, n_basis=0, **_scored(batches, predict, learn)
    )


def table(results: dict[str, Any], settings: Sequence[str]) -> str:
    """Markdown: per environment and setting, the adaptation's share of the update time and
    the tail explained variance (means over seeds; difference from the first setting, paired
    by seed, with a 95% t interval)."""
    base = settings[0]
    lines = [
        "| env | setting | adaptation / update | update s | explained variance (last "
        f"{LAST:.0%}) | − {base} [95% CI] |",
        "|---|---|---:|---:|---:|---|",
    ]
    for env_id, by_seed in results.items():
        seeds = sorted(by_seed)
        for name in settings:
            runs = [by_seed[s][name] for s in seeds]
            timed = runs[0]["share"] is not None
            share = np.mean([r["share"] for r in runs]) if timed else None
            seconds = np.mean([r["update"] for r in runs]) if timed else None
            tail = np.mean([r["tail"] for r in runs])
            diff = [by_seed[s][name]["tail"] - by_seed[s][base]["tail"] for s in seeds]
            mean, half = (float(v) for v in mean_ci(np.asarray(diff), nan_policy="propagate"))
            ci = "–" if name == base else f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]"
            cost = f"{share:.0%} | {seconds:.2f}" if timed else "– | –"
            lines.append(f"| `{env_id}` | {name} | {cost} | {tail:.3f} | {ci} |")
    return "\n".join(lines) + "\n"


def plot(results: dict[str, Any], settings: Sequence[str], path: Path) -> None:
    """Tail explained variance against the adaptation's share, one panel per environment."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    envs = list(results)
    fig, axes = plt.subplots(1, len(envs), figsize=(4.2 * len(envs) + 3.5, 3.8), squeeze=False)
    for ax, env_id in zip(axes[0], envs, strict=True):
        by_seed = results[env_id]
        for k, name in enumerate(settings):
            runs = [by_seed[s][name] for s in sorted(by_seed)]
            if runs[0]["share"] is None:  # an untimed reference: a level, not a point
                mean_tail = max(float(np.mean([r["tail"] for r in runs])), -1.0)
                ax.axhline(mean_tail, color=f"C{k}", ls="--", lw=1.2, label=name)
                continue
            shares = [100 * r["share"] for r in runs]
            tails = [max(r["tail"], -1.0) for r in runs]
            colour = f"C{k}"
            ax.scatter(shares, tails, color=colour, alpha=0.35, s=14)
            mean_tail = max(float(np.mean([r["tail"] for r in runs])), -1.0)
            ax.scatter(np.mean(shares), mean_tail, color=colour, s=60, label=name)
        ax.axvline(10, color="k", ls=":", lw=1)
        ax.set(title=env_id.split("/")[-1], xlabel="adaptation / GP update time (%)")
        ax.set_xlim(0, 100)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"expl. variance, last {LAST:.0%} (clipped at -1)")
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle("Adaptation settings replayed on the same PPO streams (dots: seeds; large: mean)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def stream_path(
    streams: Path, env_id: str, seed: int, timesteps: int, record: dict[str, Any]
) -> Path:
    """Where the stream of ``env_id`` and ``seed`` is kept: the budget in the name, and a
    digest of the recorded setting (``--record``) where it is not the default (another
    critic's stream is another stream)."""
    name = f"{env_id.replace('/', '-')}__s{seed}__t{timesteps}"
    if record:
        canonical = json.dumps(record, sort_keys=True).encode()
        name += f"__{hashlib.sha256(canonical).hexdigest()[:10]}"
    return streams / f"{name}.pt"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--envs", nargs="+", default=list(ENVS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument(
        "--timesteps", type=count_arg, default=60_000, help="steps of each recording"
    )
    parser.add_argument(
        "--settings",
        type=json.loads,
        default=SETTINGS,
        help='JSON {name: Adaptation settings [, "gp_options": {...}] [, "kernel": "rbf"]}; '
        "the first is the reference",
    )
    parser.add_argument(
        "--mlp", action="store_true", help=f"also replay SB3's MLP critic ({MLP!r}) for reference"
    )
    parser.add_argument(
        "--batch",
        action="store_true",
        help="also score the default GP's basis fitted in batch "
        f"({BATCH!r}, {BATCH_EUCLIDEAN!r}, {BATCH_ONLINE!r})",
    )
    parser.add_argument(
        "--exact",
        action="store_true",
        help="also score exact GPs on the newest batch or two (needs the bench extra): "
        + "; ".join(EXACT),
    )
    parser.add_argument(
        "--same-policy",
        action="store_true",
        help="also score each critic's fit to other environments of the same rollout "
        "(the first setting's GP critic; the MLP's with --mlp)",
    )
    parser.add_argument("--out", type=Path, default=Path("runs/adaptation_schedule"))
    parser.add_argument(
        "--streams", type=Path, default=None, help="recorded streams (default: OUT/streams)"
    )
    parser.add_argument(
        "--record",
        type=json.loads,
        default={},
        help="JSON setting of the recorded critic, as --settings' entries, plus "
        '"target"/"horizon" (null: the drop-in policy\'s feed); {} is the comparison\'s '
        "geodesic critic fed SB3's returns. --batch and --exact build their GP from it; "
        "--settings are replayed as given",
    )
    args = parser.parse_args(argv)
    for env_id in args.envs:
        # Each batch is scored before it is learnt, so the first is never scored.
        zoo = ppo_spec(env_id, 0, 1, {}).hyperparams
        rollout = int(zoo.get("n_steps", 2048)) * int(zoo.get("n_envs", 1))
        if args.timesteps < 2 * rollout:
            parser.error(
                f"--timesteps {args.timesteps} records fewer than two rollouts of {env_id} "
                f"({rollout} steps each) and no batch would be scored: pass at least "
                f"{2 * rollout}"
            )
    streams: Path = args.streams or args.out / "streams"
    settings: dict[str, dict[str, Any]] = args.settings
    record_ = provenance()
    jobs = [(e, s) for e in args.envs for s in args.seeds]
    results: dict[str, dict[int, dict[str, Any]]] = {e: {} for e in args.envs}
    references = {MLP: replay_mlp} if args.mlp else {}
    recorded = {"recorded": args.record}
    if args.batch:
        references[BATCH] = functools.partial(replay_batch, **recorded)
        references[BATCH_EUCLIDEAN] = functools.partial(replay_batch, euclidean=True, **recorded)
        references[BATCH_ONLINE] = functools.partial(replay_batch, refit=False, **recorded)
    if args.exact:
        references.update(
            {k: functools.partial(replay_exact, **v, **recorded) for k, v in EXACT.items()}
        )
    first = next(iter(settings))
    learners: dict[str, Callable[[str, int], Any]] = {}
    if args.same_policy:
        learners[f"GP critic, {first}"] = lambda env_id, seed: _GPLearner(
            gp_shadow(ppo_spec(env_id, seed, 1, settings[first]))
        )
        if args.mlp:
            learners[MLP] = _MLPLearner
    same: dict[str, dict[str, dict[int, Any]]] = {e: {c: {} for c in learners} for e in args.envs}
    per_job = 1 + len(settings) + len(references) + len(learners)
    bar = tqdm(total=len(jobs) * per_job, unit="run", desc="record + replay")
    for env_id, seed in jobs:
        stream = stream_path(streams, env_id, seed, args.timesteps, args.record)
        batches = record(env_id, seed, args.timesteps, stream, args.record)
        bar.update()
        results[env_id][seed] = {}
        for name, setting in settings.items():
            r = replay(env_id, seed, batches, setting)
            results[env_id][seed][name] = r
            bar.set_postfix_str(f"{env_id} s{seed} {name}: {r['share']:.0%}, {r['tail']:.3f}")
            bar.update()
        for name, reference in references.items():
            results[env_id][seed][name] = reference(env_id, seed, batches)
            bar.update()
        for critic, make in learners.items():
            same[env_id][critic][seed] = same_policy(batches, make(env_id, seed))
            bar.update()
    bar.close()
    names = list(settings) + list(references)
    text = table(results, names)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "table.md").write_text(text)
    write_json_atomic(
        args.out / "results.json",
        {
            "args": {**vars(args), "out": str(args.out), "streams": str(streams)},
            "results": results,
            "same_policy": same,
            "provenance": record_,
        },
    )
    plot(results, names, args.out / "frontier.png")
    if learners:
        text = same_policy_table(same)
        print(text)
        (args.out / "same_policy.md").write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
