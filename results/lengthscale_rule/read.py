"""The registered reading of ``PLAN.md`` (session 85): ``lengthscale_rule="distance"`` against
PPO's default GP critic (``"spread"``) on HalfCheetah-v5 and Hopper-v5, seeds 1143-1152::

    python results/lengthscale_rule/read.py > results/lengthscale_rule/read.md
    python results/lengthscale_rule/read.py --curves results/lengthscale_rule/curves.png

Per cell and metric, ``distance`` − ``spread`` paired by seed (the mean of the per-seed
differences, 95 % percentile bootstrap over seeds); then each GP critic − SB3's MLP critic in
final return under the table's rule (groups resampled apart), also pooled with session 84's
runs of seeds 1133-1142 (``results/heldout2/normalized``). ``--dir`` reads another folder of
the same layout (a frozen worktree's runs). Where ``no_prior`` holds them, the runs of the
plan's addendum 1 follow. Where ``table_screen`` holds the exploratory runs of
``table_screen.sh``, they follow: issue 13's seven PPO cells, seeds 0-9, paired the same way
with the stored runs of PPO's default critic.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.report import pyplot
from sb3_geogp.comparison.results import METRICS, load_results, stack_curves
from sb3_geogp.toolbox.stats import bootstrap_ci, difference_ci

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
#: Runs by seed
Runs = dict[int, dict[str, Any]]

#: The plan's cells and their inputs; each cell's final-return reading (PLAN.md): its role, and
#: its verdict from the paired interval ``(low, high)``
DECISIONS: dict[str, tuple[int, str, Callable[[float, float], str]]] = {
    "HalfCheetah-v5": (
        17,
        "primary",
        lambda low, high: "confirmed" if low > 0 else "not confirmed",
    ),
    "Hopper-v5": (11, "guard", lambda low, high: "worse" if high < 0 else "not worse"),
}
SEEDS = tuple(range(1143, 1153))
#: The ten more seeds of PLAN.md's addendum 2
MORE_SEEDS = tuple(range(1153, 1163))
#: Session 84's runs of the same protocol on seeds 1133-1142
HELDOUT2_DIR, HELDOUT2_SEEDS = RESULTS / "heldout2/normalized", tuple(range(1133, 1143))
#: Issue 13's PPO cells, their inputs, and the stored runs of 0.43's default critic on seeds
#: 0-19 (CartPole-v1's from its registered test of widening, the others unchanged since
#: fit_spacing's)
TABLE = {
    "Pendulum-v1": (3, "fit_spacing/table/Pendulum-v1_s0"),
    "CartPole-v1": (4, "follow_widen_default/s0"),
    "Acrobot-v1": (6, "fit_spacing/table/Acrobot-v1_s0"),
    "sb3_geogp/PaperPendulum-v0": (2, "fit_spacing/table/PaperPendulum-v0_s0"),
    "MountainCarContinuous-v0": (2, "fit_spacing/table/MountainCarContinuous-v0_s0"),
    "sb3_geogp/WallMaze-v0": (2, "fit_spacing/table/WallMaze-v0_s0"),
    "sb3_geogp/WallMazeDiscrete-v0": (2, "fit_spacing/table/WallMazeDiscrete-v0_s0"),
}
TABLE_SEEDS = tuple(range(10))
#: The metrics read paired by seed, as the tables name them
LABELS = {
    "final_return": "final return",
    "mean_return": "area under the curve",
    "critic_rmse": "final critic RMSE",
}


def runs_of(folder: Path, env: str, critic: str, seeds: tuple[int, ...]) -> Runs:
    """The runs of ``critic`` on ``env`` in ``folder`` (empty: not run) whose seed is in
    ``seeds``."""
    if not (folder / "runs").is_dir():
        return {}
    return {r["spec"]["seed"]: r for r in load_results(folder)
            if r["spec"]["env_id"] == env and r["spec"]["critic"] == critic
            and r["spec"]["seed"] in seeds}  # fmt: skip


def final_returns(*runs: Runs) -> np.ndarray:
    """The final returns of every run of ``runs``."""
    return np.array([r["final_return"] for by_seed in runs for r in by_seed.values()])


def interval(estimate: Any, low: Any, high: Any) -> str:
    return f"{float(estimate):+.1f} [{float(low):+.1f}, {float(high):+.1f}]"


def paired(a: Runs, b: Runs, metric: str) -> tuple[list[str], float, float]:
    """``metric`` on the seeds both ran: the count and the means of ``b`` and ``a`` as table
    cells, then their mean difference ``a - b`` as a cell and its 95 % percentile bootstrap
    interval."""
    seeds = sorted(set(a) & set(b))
    x = np.array([METRICS[metric].of_run(a[s]) for s in seeds])
    y = np.array([METRICS[metric].of_run(b[s]) for s in seeds])
    est, low, high = bootstrap_ci(x - y)
    cells = [str(len(seeds)), f"{y.mean():.1f}", f"{x.mean():.1f}", interval(est, low, high)]
    return cells, float(low), float(high)


def registered(root: Path) -> None:
    print("## `distance` − `spread`, paired by seed\n")
    print("| env | inputs | metric | seeds | spread | distance | distance − spread [95 %] | "
          "reading |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for env, (inputs, role, verdict) in DECISIONS.items():
        new = runs_of(root / "distance", env, "laplacian", SEEDS)
        old = runs_of(root / "spread", env, "laplacian", SEEDS)
        if not set(new) & set(old):
            print(f"| {env} | {inputs} | | 0 | | | not run | |")
            continue
        for metric, label in LABELS.items():
            cells, low, high = paired(new, old, metric)
            reading = f"{verdict(low, high)} ({role})" if metric == "final_return" else ""
            print(f"| {env} | {inputs} | {label} | {' | '.join(cells)} | {reading} |")
    print()
    print("## Each GP critic − SB3's MLP critic (`VecNormalize`), final return, table's rule\n")
    print("| env | MLP (seeds) | spread − MLP [95 %] | distance − MLP [95 %] |")
    print("|---|---|---|---|")
    for env in DECISIONS:
        mlp = final_returns(runs_of(root / "spread", env, "mlp", SEEDS))
        if not len(mlp):
            continue
        cells = []
        for arm in ("spread", "distance"):
            gp = final_returns(runs_of(root / arm, env, "laplacian", SEEDS))
            cells.append(interval(*difference_ci(gp, mlp)) if len(gp) else "not run")
        print(f"| {env} | {mlp.mean():.1f} ({len(mlp)}) | {cells[0]} | {cells[1]} |")
    print()
    pooled(root)


def pooled(root: Path) -> None:
    print("## The default GP critic − SB3's MLP critic, pooled with session 84's seeds 1133-1142\n")
    print("| env | seeds per critic | default GP | MLP | default − MLP [95 %] |")
    print("|---|---|---|---|---|")
    for env in DECISIONS:
        gp, mlp = (
            final_returns(runs_of(root / "spread", env, critic, SEEDS),
                          runs_of(HELDOUT2_DIR, env, critic, HELDOUT2_SEEDS))
            for critic in ("laplacian", "mlp")
        )  # fmt: skip
        if len(gp) and len(mlp):
            diff = interval(*difference_ci(gp, mlp))
            means = f"{gp.mean():.1f} | {mlp.mean():.1f}"
            print(f"| {env} | {len(gp)} / {len(mlp)} | {means} | {diff} |")
    print()


def no_prior(root: Path) -> None:
    """PLAN.md's addenda 1 and 2: ``prior_sd=None`` against the default on HalfCheetah-v5, on
    seeds 1143-1152, then (addendum 2) pooled with seeds 1153-1162 and on those alone."""
    env = "HalfCheetah-v5"

    def gp(folder: str, seeds: tuple[int, ...]) -> Runs:
        return runs_of(root / folder, env, "laplacian", seeds)

    print("## Addendum 1: no hyperprior (`adapt.prior_sd=None`) − `spread`, paired by seed\n")
    new = gp("no_prior", SEEDS)
    no_prior_table(env, new, gp("spread", SEEDS))
    mlp = final_returns(runs_of(root / "spread", env, "mlp", SEEDS))
    diff = interval(*difference_ci(final_returns(new), mlp))
    print(f"No prior − SB3's MLP critic, final return (table's rule): {diff}.\n")
    if not (root / "no_prior_more" / "runs").is_dir():
        return
    print("## Addendum 2: the same, seeds 1143-1162 pooled (primary)\n")
    more_new, more_old = gp("no_prior_more", MORE_SEEDS), gp("spread_more", MORE_SEEDS)
    no_prior_table(env, {**new, **more_new}, {**gp("spread", SEEDS), **more_old})
    print("## Addendum 2: seeds 1153-1162 alone (secondary)\n")
    no_prior_table(env, more_new, more_old)


def no_prior_table(env: str, new: Runs, old: Runs) -> None:
    """``new`` (no hyperprior) − ``old`` (the default) paired by seed on every metric, the
    final return read as the plan's addenda read it."""
    if not set(new) & set(old):
        print("No seed has run in both arms yet.\n")
        return
    print("| env | metric | seeds | spread | no prior | no prior − spread [95 %] | reading |")
    print("|---|---|---|---|---|---|---|")
    for metric, label in LABELS.items():
        cells, low, _ = paired(new, old, metric)
        reading = ""
        if metric == "final_return":
            reading = "confirmed" if low > 0 else "not confirmed"
        print(f"| {env} | {label} | {' | '.join(cells)} | {reading} |")
    print()


def table_screen(root: Path) -> None:
    print("## Exploratory: issue 13's PPO cells, `distance` − the stored default runs\n")
    print(f"Seeds {TABLE_SEEDS[0]}-{TABLE_SEEDS[-1]} (`table_screen.sh`), paired by seed, "
          "95 % percentile bootstrap; not registered.\n")  # fmt: skip
    print("| env | inputs | metric | seeds | default | distance | distance − default [95 %] |")
    print("|---|---|---|---|---|---|---|")
    for env, (inputs, folder) in TABLE.items():
        new = runs_of(root / "table_screen", env, "laplacian", TABLE_SEEDS)
        old = runs_of(RESULTS / folder, env, "laplacian", TABLE_SEEDS)
        if not set(new) & set(old):
            continue
        for metric, label in LABELS.items():
            cells, _, _ = paired(new, old, metric)
            print(f"| {env} | {inputs} | {label} | {' | '.join(cells)} |")
    print()


#: The curves' arms: (folder, critic, legend, colour)
CURVES = (
    ("spread", "mlp", "SB3's MLP critic (VecNormalize)", "tab:gray"),
    ("spread", "laplacian", "default GP critic (spread)", "tab:green"),
    ("distance", "laplacian", "lengthscale_rule='distance'", "tab:orange"),
)


def draw_arm(ax: Any, runs: Runs, legend: str, colour: str) -> None:
    """One arm's evaluation return against timesteps on ``ax``: the mean over its seeds and its
    95 % percentile bootstrap band (nothing where it has no run)."""
    if not runs:
        return
    t, values = stack_curves(list(runs.values()))
    est, low, high = bootstrap_ci(values)
    ax.plot(t, est, color=colour, label=f"{legend}, {len(runs)} seeds")
    ax.fill_between(t, low, high, color=colour, alpha=0.2, linewidth=0)


def style_panel(ax: Any, title: str) -> None:
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("timesteps", fontsize=8)
    ax.tick_params(labelsize=7)


def save_figure(fig: Any, axes: Any, title: str, path: Path) -> None:
    """Label the panels' return axis, title ``fig``, write it to ``path`` and close it."""
    axes[0][0].set_ylabel("evaluation return", fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    pyplot().close(fig)


def curves(root: Path, path: Path) -> None:
    """Each arm's evaluation return against timesteps in each cell of the plan: the mean over
    seeds and its 95 % percentile bootstrap band."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(DECISIONS), figsize=(9, 3.4), squeeze=False)
    for ax, env in zip(axes[0], DECISIONS, strict=True):
        for folder, critic, legend, colour in CURVES:
            draw_arm(ax, runs_of(root / folder, env, critic, SEEDS), legend, colour)
        style_panel(ax, f"PPO {env}")
    axes[0][0].legend(fontsize=7, loc="upper left")
    save_figure(fig, axes, "Seeds 1143-1152: mean and 95 % bootstrap band over seeds", path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", type=Path, default=HERE)
    parser.add_argument("--curves", type=Path, metavar="PNG", help="draw the learning curves")
    args = parser.parse_args()
    if args.curves:
        curves(args.dir, args.curves)
        return
    print("# Lengthscales that grow with the number of inputs: the registered reading "
          "(session 85)\n")  # fmt: skip
    print("PPO, 50,000 steps, seeds 1143-1152, the held-out studies' primary protocol "
          "(`results/lengthscale_rule/PLAN.md`).\n")  # fmt: skip
    registered(args.dir)
    if (args.dir / "no_prior" / "runs").is_dir():
        no_prior(args.dir)
    if (args.dir / "table_screen" / "runs").is_dir():
        table_screen(args.dir)


if __name__ == "__main__":
    main()
