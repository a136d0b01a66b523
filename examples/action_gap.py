"""Does the critic rank CartPole's actions? GP and MLP critics on the same PPO data.

The GP critics lose to SB3's MLP critic on CartPole-v1 under PPO (docs/results.md) although they
predict the returns of the next rollout at least as well (explained variance, replayed on the
same streams). The actor does not learn from that fit but from advantages, to which a critic
contributes the one-step gap ``gamma (V(s'_1) - V(s'_0))`` between the two successors of a
state (:mod:`sb3_geogp.studies.action_gap`). This script measures how often each critic gets
its sign right:

1. One PPO run per actor and seed, built as the comparison builds its runs (zoo
   hyperparameters, ``--timesteps`` steps): ``--actors geodesic`` trains with the geodesic GP
   critic (the comparison's ``geodesic`` critic, PPO's default before 0.6), ``mlp`` with SB3's
   MLP critic. Building the shadows re-seeds the global random
   streams after the model is built, so a run is not the comparison's run of that seed (it is
   as reproducible).
2. Beside it, shadow critics learn from every rollout the run's critic learns from (SB3's
   returns, env by env): SB3's MLP critic trained as PPO trains it, at the run's current
   learning rate (:class:`~sb3_geogp.comparison.shadow.MLPShadow`), and GP critics built as the
   policy builds them with the settings of ``--critics``
   (:func:`~sb3_geogp.comparison.shadow.gp_shadow`; a shadow with the run's own settings
   reproduces the run's critic exactly).
3. At every ``--every``-th rollout end, before any critic learns from that rollout:
   ``--states`` states of the rollout, their true action gaps under the current stochastic
   policy by Monte Carlo (``--rollouts`` per successor, ``--horizon`` steps, common random
   numbers), and every critic's one-step gap (out of sample).

Writes ``OUT/results.json`` (every checkpoint's scores), ``OUT/table.md`` (sign accuracy on
decisive states over the second half of training, mean over seeds, and each critic's paired
difference from the MLP shadow with a 95% t interval) and ``OUT/action_gap.png``.

    python examples/action_gap.py --seeds 0 1 2 3 4 5 --out docs/action_gap
    python examples/action_gap.py --actors geodesic --critics '{"RBF GP": {"kernel": "rbf"}}'

``--against NAME`` takes the paired differences from the critic ``NAME`` instead of the MLP
shadow (e.g. an option's shadow against the default's, on the same data).

A finished actor and seed is kept in ``OUT/runs/`` and not run again.
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from sb3_geogp.comparison.hyperparams import TIMESTEPS
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.shadow import (
    MLP,
    OWN,
    NumpyValue,
    learn_with_shadows,
    ppo_spec,
    run_study,
    study_parser,
)
from sb3_geogp.studies.action_gap import action_gaps, gap_scores
from sb3_geogp.toolbox.scripts import count_arg
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.tables import estimate_cell

ENV = "CartPole-v1"
#: The critics that train the agent by default, one PPO run each per seed.
ACTORS = ("geodesic", "mlp")
#: GP shadow critics by default (settings as :func:`~sb3_geogp.comparison.shadow.ppo_spec`).
CRITICS: dict[str, dict[str, Any]] = {
    # named when the geodesic critic was PPO's default (session 14); the published runs use it
    "geodesic GP (default)": {},
    "RBF GP": {"kernel": "rbf"},
    "Laplacian GP, novelty_tol 0.1": {"kernel": "laplacian", "gp_options": {"novelty_tol": 0.1}},
    "RBF GP, lengthscales fixed": {"kernel": "rbf", "lengthscale_range": [1.0, 1.0]},
}
#: Scores averaged over checkpoints after this share of training.
LATE = 0.5


class GapCheckpoints(BaseCallback):
    """At every ``--every``-th rollout end, scores every critic's one-step gaps against Monte
    Carlo gaps on ``--states`` states of the rollout. Pass it before the callbacks that let a
    critic learn from the rollout."""

    def __init__(self, critics: dict[str, NumpyValue], args: argparse.Namespace, seed: int) -> None:
        super().__init__()
        self.critics, self.args = critics, args
        self.rng = np.random.default_rng(seed)
        self.rollouts = 0
        self.rows: list[dict[str, Any]] = []

    def _on_step(self) -> bool:
        return True

    def _p_right(self, states: np.ndarray) -> np.ndarray:
        obs = th.as_tensor(states, dtype=th.float32, device=self.model.device)
        with th.no_grad():
            probs = self.model.policy.get_distribution(obs).distribution.probs  # type: ignore[attr-defined]
        return probs[:, 1].double().cpu().numpy()

    def _on_rollout_end(self) -> None:
        self.rollouts += 1
        if self.rollouts % self.args.every:
            return
        obs = self.model.rollout_buffer.observations.reshape(-1, 4).astype(np.float64)
        states = obs[self.rng.choice(len(obs), min(self.args.states, len(obs)), replace=False)]
        gamma = float(self.model.gamma)
        truth = action_gaps(
            self._p_right, states, gamma, self.args.rollouts, self.args.horizon, self.rollouts
        )
        row: dict[str, Any] = dict(step=int(self.num_timesteps))
        for name, value in self.critics.items():
            scores = gap_scores(truth.gap, truth.stderr, truth.critic_gap(value, gamma))
            # JSON has no NaN (no decisive state, a constant critic): stored as null
            row[name] = {k: None if v != v else v for k, v in scores.items()}
        self.rows.append(row)


def run(actor: str, seed: int, args: argparse.Namespace) -> dict[str, Any]:
    """One PPO run with ``actor``'s critic and the shadow critics; its checkpoints' scores."""
    th.set_num_threads(1)
    model = build_model(ppo_spec(ENV, seed, args.timesteps, {"kernel": actor}))
    scorer = learn_with_shadows(
        model, ENV, seed, args.timesteps, args.critics, lambda v: GapCheckpoints(v, args, seed)
    )
    assert isinstance(scorer, GapCheckpoints)
    return dict(actor=actor, seed=seed, rows=scorer.rows)


def late_scores(result: dict[str, Any], timesteps: int, metric: str) -> dict[str, float]:
    """Per critic, the mean of ``metric`` over the checkpoints after :data:`LATE` of training
    (null scores, of checkpoints without a decisive state, left out)."""
    rows = [r for r in result["rows"] if r["step"] > LATE * timesteps]
    names = [k for k in rows[0] if k != "step"] if rows else []
    return {n: float(np.nanmean(np.array([r[n][metric] for r in rows], float))) for n in names}


def table(results: dict[str, dict[int, Any]], timesteps: int, against: str = MLP) -> str:
    """Markdown: per actor and critic, late sign accuracy (mean over seeds [lowest, highest])
    and the paired difference from the critic ``against`` (the MLP shadow by default) [95% t
    interval, over the seeds where both have a score]."""
    lines = [
        f"| actor's critic | critic | sign accuracy, decisive states (last {1 - LATE:.0%}) "
        f"| weighted by the gap | − {against} [95% CI] | seeds |",
        "|---|---|---:|---:|---|---:|",
    ]
    for actor, by_seed in results.items():
        scores = [late_scores(r, timesteps, "sign_accuracy") for r in by_seed.values()]
        weighted = [late_scores(r, timesteps, "weighted_sign_accuracy") for r in by_seed.values()]
        for name in scores[0]:
            values = np.array([s[name] for s in scores])
            diff = values - np.array([s[against] for s in scores])
            mean, half = (float(v) for v in mean_ci(diff, nan_policy="omit"))
            interval = f"[{mean - half:+.3f}, {mean + half:+.3f}]"
            n = int(np.isfinite(diff).sum())
            ci = "–" if name == against else estimate_cell(f"{mean:+.3f}", interval, n)
            w = np.nanmean([s[name] for s in weighted])
            spread = f"{np.nanmean(values):.3f} [{np.nanmin(values):.2f}, {np.nanmax(values):.2f}]"
            lines.append(f"| {actor} | {name} | {spread} | {w:.3f} | {ci} | {len(values)} |")
    return "\n".join(lines) + "\n"


def plot(results: dict[str, dict[int, Any]], path: Path) -> None:
    """Sign accuracy on decisive states over training, mean over seeds, a panel per actor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        1, len(results), figsize=(5.2 * len(results) + 3.2, 3.8), squeeze=False
    )
    for ax, (actor, by_seed) in zip(axes[0], results.items(), strict=True):
        runs = list(by_seed.values())
        steps = [r["step"] for r in runs[0]["rows"]]
        for k, name in enumerate(n for n in runs[0]["rows"][0] if n != "step"):
            acc = np.array([[row[name]["sign_accuracy"] for row in r["rows"]] for r in runs], float)
            # the run's own critic under its shadow twin (they coincide for a GP run): wide
            style = dict(lw=4, alpha=0.35) if name == OWN else dict(lw=1.5, ms=3, marker="o")
            ax.plot(steps, np.nanmean(acc, axis=0), color=f"C{k}", label=name, **style)
        ax.axhline(0.5, color="k", ls=":", lw=1)
        ax.set(title=f"PPO with the {actor} critic", xlabel="environment steps", ylim=(0, 1))
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("sign accuracy, decisive states")
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle(f"{ENV}: does the critic order the two actions as the true Q does? (0.5 = chance)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    parser = study_parser(
        __doc__.split("\n\n")[0], ACTORS, TIMESTEPS[ENV], CRITICS, Path("runs/action_gap")
    )
    parser.add_argument("--every", type=count_arg, default=12, help="rollouts between checkpoints")
    parser.add_argument("--states", type=int, default=256, help="states per checkpoint")
    parser.add_argument(
        "--rollouts", type=count_arg, default=16, help="Monte Carlo rollouts per action"
    )
    parser.add_argument("--horizon", type=count_arg, default=250, help="steps per rollout")
    parser.add_argument(
        "--against",
        default=MLP,
        help=f"the critic of the paired differences (default: {MLP!r}; or a --critics name)",
    )
    args = parser.parse_args(argv)
    if args.rollouts < 2:
        parser.error(f"--rollouts must be at least 2 (for a standard error), got {args.rollouts}")
    if args.against not in (OWN, MLP, *args.critics):
        parser.error(f"--against {args.against!r} is none of {[OWN, MLP, *args.critics]}")
    tabled = functools.partial(table, timesteps=args.timesteps, against=args.against)
    run_study(args, run, tabled, plot, "action_gap.png", reading=("against",))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
