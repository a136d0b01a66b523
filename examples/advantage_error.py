"""Do the GP critics give PPO worse advantages than SB3's MLP critic on the paper's pendulum?

PaperPendulum PPO is the cell in which the default GP critic has been worse than the MLP
critic in every run since 0.6 (docs/results.md): its agents fall behind between about 12,000
and 24,000 steps, while its values at fixed probe states are about as accurate as the MLP's.
The actor learns from advantages, not from values at probe states; this script measures the
advantages themselves (:mod:`sb3_geogp.studies.advantage_error`):

1. One PPO run per actor and seed, built as the comparison builds its runs (zoo
   hyperparameters, ``--timesteps`` steps): ``--actors laplacian`` trains with the default GP
   critic, ``mlp`` with SB3's MLP critic.
2. Beside it, shadow critics learn from every rollout the run's critic learns from: SB3's MLP
   critic trained as PPO trains it (:class:`~sb3_geogp.comparison.shadow.MLPShadow`) and GP
   critics with the settings of ``--critics``. All of them learn SB3's returns of each rollout
   (the run's own GP critic too); with ``--target monte_carlo`` all learn the returns of
   completed episodes instead, as PPO's default feed gives them to a GP critic
   (:class:`~sb3_geogp.comparison.shadow.TeeFeed`; the run's own critic must be a GP).
3. At every rollout's end, before any critic learns from it: ``V^pi`` of the current policy at
   every state of the rollout (and the states after its last step and at its truncations), by
   Monte Carlo (``--rollouts`` rollouts of ``--horizon`` steps from each, the policy's gSDE
   noise resampled as in training); then each critic's GAE advantages of the rollout (its own
   values in the TD errors and at the truncations' bootstrap) against those of ``V^pi``:
   their correlation, and the critic's value RMSE at the rollout's states.

Writes ``OUT/results.json``, ``OUT/table.md`` (per actor and critic the mean over seeds, and
the paired difference from the MLP shadow, or from the critic ``--against`` names, with a 95 %
t interval) and ``OUT/advantage_error.png``. A finished actor and seed is kept in
``OUT/runs/``.

    python examples/advantage_error.py --seeds 0 1 2 3 4 --out docs/advantage_error

``--env`` runs the same design on a WallMaze task (30,000 steps, as the pendulum), whose states
restart from their observations (:data:`~sb3_geogp.studies.value_ceiling.TASKS`); there the
Monte Carlo rollouts run until at most 1 of a return is left (``--horizon`` overrides it) and
``--critics`` names the GP shadows (the defaults are the pendulum's); a geodesic shadow with
``"walls": true`` in its setting gets the wall study's oracle kernel for the maze's layout
(:class:`~sb3_geogp.studies.wall.oracle.WallAwareGeodesicKernel`: no attachment across an
interior wall). It also runs on issue 13's critic-fit environments, Pendulum-v1, CartPole-v1
and Acrobot-v1 (there "1 of a return" is in units of the task's largest reward).

``--target defaults`` (since 0.35.3) gives every critic what its own training gives it, so
that the critics compare as the agent would train them, on the same rollouts: the GP critics
:class:`~sb3_geogp.GPValueCallback`'s default feed (PPO's Monte Carlo returns; the run's own
GP critic is built as the drop-in's; a GP shadow gets the feed with its own bootstraps,
:class:`~sb3_geogp.comparison.shadow.MonteCarloFeed`, or with ``"target": "returns"`` in its
setting the GAE returns of its own values), and the MLP shadow the GAE returns of
its own values (:class:`~sb3_geogp.comparison.shadow.OwnReturnsFeed`), as PPO trains SB3's
critic. The GP critic trains the agent::

    python examples/advantage_error.py --env Acrobot-v1 --actors laplacian --critics '{}' \
        --target defaults --seeds 0 1 2 3 4 --out docs/critic_fit_same_data/Acrobot-v1

or SB3's MLP critic does, and a GP shadow built as the drop-in's critic learns beside it (since
0.35.4)::

    python examples/advantage_error.py --env Acrobot-v1 --actors mlp \
        --critics '{"Laplacian GP (PPO default)": {"kernel": "laplacian"}}' --target defaults \
        --against "run's own critic" --seeds 0 1 2 3 4 \
        --out docs/critic_fit_same_data_mlp/Acrobot-v1
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from sb3_geogp.callbacks import time_limit_truncations
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
from sb3_geogp.envs.wall_maze import WALL_MAZE_DISCRETE_ID, WALL_MAZE_ID
from sb3_geogp.kernels import Kernel
from sb3_geogp.studies.advantage_error import advantage_scores, gae
from sb3_geogp.studies.value_ceiling import TASKS, horizon, model_returns
from sb3_geogp.studies.wall.oracle import WallAwareGeodesicKernel
from sb3_geogp.toolbox.scripts import count_arg
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.tables import estimate_cell

ENV = "sb3_geogp/PaperPendulum-v0"
#: ``--env`` choices: the pendulum, the mazes and issue 13's critic-fit environments, all with
#: the pendulum's budget (30,000 steps).
ENVS = (ENV, WALL_MAZE_ID, WALL_MAZE_DISCRETE_ID, "Pendulum-v1", "CartPole-v1", "Acrobot-v1")
#: Steps of a pendulum Monte Carlo rollout unless ``--horizon`` says otherwise.
PENDULUM_HORIZON = 80
#: The critics that train the agent by default, one PPO run each per seed.
ACTORS = ("mlp", "laplacian")
#: GP shadow critics by default (settings as :func:`~sb3_geogp.comparison.shadow.ppo_spec`).
CRITICS: dict[str, dict[str, Any]] = {
    "Laplacian GP (PPO default)": {"kernel": "laplacian"},
    "Laplacian GP, 0.11-0.13's PPO default": {
        "kernel": "laplacian",
        "gp_options": {"forgetting": 1.0},
    },
}
METRICS = ("correlation", "value_rmse")
#: The parts of the scores (:func:`~sb3_geogp.studies.advantage_error.advantage_scores`), which
#: ``--metrics`` can put in the table too; rows written before 0.35.5 lack them.
PARTS = ("value_bias", "value_spread", "advantage_slope", "advantage_residual", "error_gain")


class AdvantageCheckpoints(BaseCallback):
    """At every rollout end, scores every critic's advantages against those of the Monte Carlo
    ``V^pi``. Pass it before the callbacks that let a critic learn from the rollout."""

    def __init__(self, critics: dict[str, NumpyValue], args: argparse.Namespace, seed: int) -> None:
        super().__init__()
        self.critics, self.args, self.seed = critics, args, seed
        self.rows: list[dict[str, Any]] = []
        self.truncations: list[tuple[int, int, np.ndarray]] = []

    def _on_rollout_start(self) -> None:
        self.truncations = []

    def _on_step(self) -> bool:
        self.truncations += time_limit_truncations(self.model, self.locals)
        return True

    def _returns(self, states: np.ndarray) -> np.ndarray:
        """Monte Carlo returns from ``states``, shape (n, rollouts), the policy's noise drawn
        from its own generator: the run's random streams and exploration matrices stay as
        they were."""
        env, steps = self.args.env, self.args.horizon
        if steps is None:
            tail = 1.0 / TASKS[env].reward_bound  # at most 1 of a return left
            steps = PENDULUM_HORIZON if env == ENV else horizon(float(self.model.gamma), tail)
        seed = self.seed * 1000 + len(self.rows)
        return model_returns(self.model, TASKS[env], states, steps, self.args.rollouts, seed)

    def _on_rollout_end(self) -> None:
        model = self.model
        buffer = model.rollout_buffer
        T, n_envs = buffer.rewards.shape
        obs = buffer.observations.reshape(T * n_envs, -1).astype(np.float64)
        last = np.asarray(model._last_obs, dtype=np.float64).reshape(n_envs, -1)  # type: ignore[arg-type]
        last_dones = np.asarray(model._last_episode_starts, dtype=np.float64)
        terminal = np.array([t for _, _, t in self.truncations]).reshape(-1, obs.shape[1])
        at = tuple(np.array([(s, e) for s, e, _ in self.truncations], dtype=int).reshape(-1, 2).T)
        everything = np.concatenate([obs, last, terminal])
        gamma, lam = float(model.gamma), float(model.gae_lambda)
        # SB3 added gamma V_own(terminal) to the rewards at truncations: replace it per critic
        own = self.critics[OWN](terminal) if len(terminal) else np.zeros(0)
        raw = buffer.rewards.astype(np.float64).copy()
        raw[at] -= gamma * own

        def advantages(v: np.ndarray) -> np.ndarray:
            values, last_v, term_v = np.split(v, [T * n_envs, T * n_envs + n_envs])
            rewards = raw.copy()
            rewards[at] += gamma * term_v
            starts = buffer.episode_starts
            return gae(rewards, values.reshape(T, n_envs), starts, last_v, last_dones, gamma, lam)

        returns = self._returns(everything)
        true_v = returns.mean(axis=1)
        reference = advantages(true_v).ravel()
        # split-half agreement of the reference (Spearman-Brown to all rollouts): the ceiling
        # its Monte Carlo noise puts on every critic's correlation alike
        halves = [advantages(returns[:, k::2].mean(axis=1)).ravel() for k in (0, 1)]
        half = float(np.corrcoef(*halves)[0, 1])
        row: dict[str, Any] = dict(step=int(self.num_timesteps), reliability=2 * half / (1 + half))
        for name, value in self.critics.items():
            v = value(everything)
            scores = advantage_scores(
                reference, advantages(v).ravel(), true_v[: T * n_envs], v[: T * n_envs]
            )
            row[name] = {k: None if s != s else s for k, s in scores.items()}
        self.rows.append(row)


def oracle_kernels(env_id: str, critics: dict[str, dict[str, Any]]) -> dict[str, Kernel]:
    """The oracle kernels of the shadows whose setting says ``"walls": true`` (geodesic ones,
    on a maze), by name."""
    walled = [name for name, setting in critics.items() if setting.get("walls")]
    if not walled:
        return {}
    if env_id not in TASKS or any(critics[n].get("kernel") != "geodesic" for n in walled):
        raise ValueError('"walls": true is for geodesic shadows on a maze')
    layout = gym.make(env_id).unwrapped.layout  # type: ignore[attr-defined]
    return {name: WallAwareGeodesicKernel(None, layout) for name in walled}


def run(actor: str, seed: int, args: argparse.Namespace) -> dict[str, Any]:
    """One PPO run with ``actor``'s critic and the shadow critics; every rollout's scores."""
    th.set_num_threads(1)
    # With each critic's own feed the run's GP critic is built as the drop-in's.
    feed = {"target": None} if args.target == "defaults" else {}
    model = build_model(ppo_spec(args.env, seed, args.timesteps, {"kernel": actor, **feed}))
    settings = {
        name: {k: v for k, v in setting.items() if k != "walls"}
        for name, setting in args.critics.items()
    }
    scorer = learn_with_shadows(
        model,
        args.env,
        seed,
        args.timesteps,
        settings,
        lambda values: AdvantageCheckpoints(values, args, seed),
        oracle_kernels(args.env, args.critics),
        args.target,
    )
    assert isinstance(scorer, AdvantageCheckpoints)
    return dict(actor=actor, seed=seed, rows=scorer.rows)


def per_seed(runs: list[dict[str, Any]], metric: str, skip: int) -> dict[str, np.ndarray]:
    """Per critic, ``metric`` averaged over each run's rollouts after the first ``skip``."""
    names = [k for k, v in runs[0]["rows"][0].items() if isinstance(v, dict)]
    return {
        n: np.array(
            [np.nanmean([r[n][metric] for r in run["rows"][skip:]], dtype=float) for run in runs]
        )
        for n in names
    }


def correlation_ceiling(rows: list[dict[str, Any]]) -> np.ndarray:
    """Per rollout, the highest correlation a critic's advantages can reach with a reference
    of the rollout's reliability ``r`` (attenuation by its Monte Carlo noise): ``sqrt(r)``, 0
    where the split halves disagree (``r <= 0``), NaN where the reference is constant."""
    reliability = np.array([r["reliability"] for r in rows], dtype=float)
    return np.sqrt(np.clip(reliability, 0.0, None))


def table(
    results: dict[str, dict[int, Any]],
    skip: int,
    against: str = MLP,
    metrics: Sequence[str] = METRICS,
) -> str:
    """Markdown: per actor and critic, each of ``metrics``' mean over seeds and its paired
    difference from the critic ``against`` (the MLP shadow by default) [95 % t interval]."""
    head = " | ".join(f"{m} | − {against} [95 % CI]" for m in metrics)
    lines = [
        f"| actor's critic | critic | {head} | seeds |",
        "|---|---|" + "---:|---|" * len(metrics) + "---:|",
    ]
    for actor, by_seed in results.items():
        runs = list(by_seed.values())
        scored = set.intersection(*(set(row[OWN]) for run in runs for row in run["rows"]))
        if missing := [m for m in metrics if m not in scored]:
            raise ValueError(
                f"{actor}'s runs have no {missing}: they were run before the parts were "
                "scored (0.35.5); run them again in a new --out"
            )
        scores = {m: per_seed(runs, m, skip) for m in metrics}
        for name in scores[metrics[0]]:
            cells = []
            for m in metrics:
                values, diff = scores[m][name], scores[m][name] - scores[m][against]
                mean, half = (float(v) for v in mean_ci(diff, nan_policy="omit"))
                interval = f"[{mean - half:+.3f}, {mean + half:+.3f}]"
                n = int(np.isfinite(diff).sum())
                ci = "–" if name == against else estimate_cell(f"{mean:+.3f}", interval, n)
                cells.append(f"{np.nanmean(values):.3f} | {ci}")
            lines.append(f"| {actor} | {name} | {' | '.join(cells)} | {len(runs)} |")
        ceiling = np.nanmean(np.concatenate([correlation_ceiling(r["rows"][skip:]) for r in runs]))
        lines.append(
            f"| {actor} | ceiling of the correlation (Monte Carlo noise) | {ceiling:.3f} |"
            + " |" * (2 * len(metrics))
        )
    return "\n".join(lines) + "\n"


def plot(results: dict[str, dict[int, Any]], path: Path, env: str = ENV) -> None:
    """Per rollout, mean over seeds: advantage correlation (top) and value RMSE (bottom), a
    column per actor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        2, len(results), figsize=(5.2 * len(results) + 3.4, 7.0), squeeze=False
    )
    for col, (actor, by_seed) in enumerate(results.items()):
        runs = list(by_seed.values())
        steps = [r["step"] for r in runs[0]["rows"]]
        for k, name in enumerate(n for n, v in runs[0]["rows"][0].items() if isinstance(v, dict)):
            style = dict(lw=4, alpha=0.35) if name == OWN else dict(lw=1.5, ms=3, marker="o")
            for row, metric in enumerate(METRICS):
                vals = np.array([[r[name][metric] for r in run["rows"]] for run in runs], float)
                axes[row][col].plot(
                    steps, np.nanmean(vals, axis=0), color=f"C{k}", label=name, **style
                )
        ceiling = np.nanmean([correlation_ceiling(run["rows"]) for run in runs], axis=0)
        axes[0][col].plot(steps, ceiling, "k:", lw=1.2, label="ceiling (Monte Carlo noise)")
        axes[0][col].set(
            title=f"PPO with the {actor} critic", ylabel="advantage correlation with V^pi's"
        )
        axes[1][col].set(
            xlabel="environment steps (rollout end)",
            ylabel="value RMSE at the rollout's states",
            yscale="log",
        )
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle(f"{env} PPO: each critic's GAE advantages against those of V^pi (Monte Carlo)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    parser = study_parser(
        __doc__.split("\n\n")[0], ACTORS, TIMESTEPS[ENV], CRITICS, Path("runs/advantage_error")
    )
    parser.add_argument("--env", choices=ENVS, default=ENV)
    parser.add_argument(
        "--rollouts", type=count_arg, default=16, help="Monte Carlo rollouts per state"
    )
    parser.add_argument(
        "--horizon",
        type=int,
        default=None,
        help=f"steps per Monte Carlo rollout (default: {PENDULUM_HORIZON} on the pendulum; "
        "elsewhere until at most 1 of a return is left, in units of the task's largest reward)",
    )
    parser.add_argument("--skip", type=int, default=1, help="first rollouts left out of the table")
    parser.add_argument(
        "--metrics",
        nargs="+",
        choices=(*METRICS, *PARTS),
        default=list(METRICS),
        help="the table's scores (default: %(default)s); the parts of the advantages' and "
        "values' errors are in sb3_geogp.studies.advantage_error's docstring",
    )
    parser.add_argument(
        "--target",
        choices=("returns", "monte_carlo", "defaults"),
        default="returns",
        help="what every critic learns: SB3's returns of each rollout (default), or the "
        "returns of completed episodes, as PPO's default feed gives them to a GP critic (the "
        "run's own critic must be a GP); defaults: each critic what training gives it, the GP "
        "critics what GPValueCallback feeds them (its default feed, or a shadow setting's "
        "target; a shadow's returns bootstrapped on its own values), the MLP shadow the "
        "GAE returns of its own values",
    )
    parser.add_argument(
        "--against",
        default=MLP,
        help=f"the critic of the paired differences (default: {MLP!r}; or a --critics name)",
    )
    args = parser.parse_args(argv)
    if args.against not in (OWN, MLP, *args.critics):
        parser.error(f"--against {args.against!r} is none of {[OWN, MLP, *args.critics]}")
    try:
        oracle_kernels(args.env, args.critics)
    except ValueError as error:
        parser.error(str(error))
    if args.target == "monte_carlo" and "mlp" in args.actors:
        parser.error("--target monte_carlo feeds what the run's GP critic is fed: no mlp actor")
    run_study(
        args,
        run,
        lambda results: table(results, args.skip, args.against, args.metrics),
        lambda results, path: plot(results, path, args.env),
        "advantage_error.png",
        reading=("skip", "against", "metrics"),
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
