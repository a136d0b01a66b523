"""The reading of PLAN.md (session 79): training seconds to the threshold, the default GP
critic against SB3's MLP critic, in the six cells where runs reach it, and (a secondary
reading added after the runs) each critic's return in the same training time::

    python results/time_to_threshold/read.py > results/time_to_threshold/read.md

Also writes ``curves.png`` (each run's evaluation return against its training clock) and
checks the new runs' steps to the threshold against the stored runs of the same seeds
(issue 13's table: 0.39's PPO critic in ``results/fit_spacing/table``, the rest in
``results/table50``), which the same code and machine reproduce exactly.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.stats import bootstrap_ci

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
#: (algo, GP critic, environment), PLAN.md's order.
CELLS = (
    ("ppo", "laplacian", "CartPole-v1"),
    ("ppo", "laplacian", "Pendulum-v1"),
    ("ppo", "laplacian", "sb3_geogp/PaperPendulum-v0"),
    ("ppo", "laplacian", "Acrobot-v1"),
    ("a2c", "rbf", "CartPole-v1"),
    ("a2c", "rbf", "Acrobot-v1"),
)
#: PLAN.md's addendum: the cells read only for the return in the same training time.
MORE_CELLS = (
    ("ppo", "laplacian", "sb3_geogp/WallMaze-v0"),
    ("ppo", "laplacian", "sb3_geogp/WallMazeDiscrete-v0"),
    ("a2c", "rbf", "MountainCarContinuous-v0"),
    ("a2c", "rbf", "Pendulum-v1"),
    ("a2c", "rbf", "sb3_geogp/PaperPendulum-v0"),
    ("a2c", "rbf", "sb3_geogp/WallMaze-v0"),
    ("a2c", "rbf", "sb3_geogp/WallMazeDiscrete-v0"),
)
SEEDS = range(570, 580)
Runs = dict[tuple[str, str, str, int], dict[str, Any]]


def index(results: list[dict[str, Any]]) -> Runs:
    """Runs by (algo, critic, environment, seed)."""
    return {
        (s["algo"], s["critic"], s["env_id"], s["seed"]): r for r in results for s in (r["spec"],)
    }


def stored(algo: str, critic: str, env: str) -> Path:
    """The folder of issue 13's table's stored runs of a cell on seeds 570-579."""
    if algo == "ppo" and critic != "mlp":
        return RESULTS / "fit_spacing" / "table" / f"{env.removeprefix('sb3_geogp/')}_s570"
    return RESULTS / "table50" / f"{algo}_s570"


@functools.cache
def stored_runs(folder: Path) -> Runs:
    """A stored folder's runs, read once: the table's A2C and MLP folders hold many cells."""
    return index(load_results(folder))


def median_ratio(ratios: list[float]) -> str:
    if not ratios:
        return "–"
    est, low, high = (float(x) for x in bootstrap_ci(np.array(ratios), stat="median", seed=0))
    return f"{est:.2f} [{low:.2f}, {high:.2f}] ({len(ratios)})"


def fmt_median(values: list[float | None], digits: int) -> str:
    """Median over runs, a run that never reached the threshold counted as never (as
    ``sb3-geogp compare``'s summary counts it), and how many reached it."""
    times = np.array([np.inf if v is None else v for v in values])
    median = float(np.median(times))
    shown = f"{median:,.{digits}f}" if np.isfinite(median) else "never"
    return f"{shown} ({int(np.isfinite(times).sum())} of {len(values)})"


def cell_row(runs: Runs, algo: str, gp: str, env: str) -> str | None:
    pairs = [(runs.get((algo, gp, env, s)), runs.get((algo, "mlp", env, s))) for s in SEEDS]
    pairs = [(g, m) for g, m in pairs if g is not None and m is not None]
    if not pairs:
        return None
    both = [(g, m) for g, m in pairs if g["seconds_to_threshold"] and m["seconds_to_threshold"]]
    seconds = [g["seconds_to_threshold"] / m["seconds_to_threshold"] for g, m in both]
    steps = [g["steps_to_threshold"] / m["steps_to_threshold"] for g, m in both]
    per_step = [g["train_seconds"] / m["train_seconds"] for g, m in pairs]
    cells = [
        f"{algo.upper()} {env.removeprefix('sb3_geogp/')}",
        str(len(pairs)),
        fmt_median([g["seconds_to_threshold"] for g, _ in pairs], 1),
        fmt_median([m["seconds_to_threshold"] for _, m in pairs], 1),
        median_ratio(seconds),
        fmt_median([g["steps_to_threshold"] for g, _ in pairs], 0),
        fmt_median([m["steps_to_threshold"] for _, m in pairs], 0),
        median_ratio(steps),
        f"{np.median(per_step):.2f}",
    ]
    return "| " + " | ".join(cells) + " |"


def complete_seeds(runs: Runs, cells: tuple[tuple[str, str, str], ...]) -> list[int]:
    """The seeds on which every run of ``cells`` finished (the addendum's stopping rule)."""
    return [
        seed
        for seed in SEEDS
        if all((algo, c, env, seed) in runs for algo, gp, env in cells for c in (gp, "mlp"))
    ]


def equal_time_row(runs: Runs, algo: str, gp: str, env: str) -> str | None:
    """The GP critic's return when its training clock reaches the MLP critic's whole training
    time (its last evaluation by then), against the MLP critic's final return, per seed (for
    the addendum's cells, the seeds on which all of them finished)."""
    diffs, gp_returns, mlp_returns = [], [], []
    more = (algo, gp, env) in MORE_CELLS
    for seed in complete_seeds(runs, MORE_CELLS) if more else SEEDS:
        g, m = runs.get((algo, gp, env, seed)), runs.get((algo, "mlp", env, seed))
        if g is None or m is None:
            continue
        clock = np.array(g["train_clock"]["seconds"])
        last = int(np.flatnonzero(clock <= m["train_seconds"])[-1])
        gp_returns.append(g["eval"]["mean_return"][last])
        mlp_returns.append(m["final_return"])
        diffs.append(gp_returns[-1] - mlp_returns[-1])
    if not diffs:
        return None
    est, low, high = (float(x) for x in bootstrap_ci(np.array(diffs), seed=0))
    return (
        f"| {algo.upper()} {env.removeprefix('sb3_geogp/')} | {len(diffs)} | "
        f"{np.mean(gp_returns):.1f} | {np.mean(mlp_returns):.1f} | "
        f"{est:+.1f} [{low:+.1f}, {high:+.1f}] |"
    )


def reproduction(runs: Runs) -> list[str]:
    """Per cell and critic: how many new runs give the stored run's evaluations exactly."""
    lines = []
    for algo, gp, env in CELLS + MORE_CELLS:
        for critic in (gp, "mlp"):
            keys = [(algo, critic, env, s) for s in SEEDS if (algo, critic, env, s) in runs]
            if not keys:
                continue
            old = stored_runs(stored(algo, critic, env))
            same = sum(old.get(k, {}).get("eval") == runs[k]["eval"] for k in keys)
            lines.append(
                f"| {algo.upper()} {env.removeprefix('sb3_geogp/')} | {critic} | "
                f"{same} of {len(keys)} |"
            )
    return lines


def plot(
    runs: Runs, cells: tuple[tuple[str, str, str], ...], seeds: Iterable[int], path: Path
) -> None:
    """Each run's evaluation return against its training clock, a panel per cell."""
    seeds = list(seeds)
    rows = -(-len(cells) // 3)
    fig, axes = plt.subplots(rows, 3, figsize=(13, 3.75 * rows), squeeze=False)
    for ax in axes.flat[len(cells) :]:
        ax.set_visible(False)
    for ax, (algo, gp, env) in zip(axes.flat, cells, strict=False):
        for critic, colour in ((gp, "tab:blue"), ("mlp", "tab:orange")):
            label = f"GP critic ({gp})" if critic != "mlp" else "SB3's MLP critic"
            for seed in seeds:
                r = runs.get((algo, critic, env, seed))
                if r is None:
                    continue
                ax.plot(
                    r["train_clock"]["seconds"],
                    r["eval"]["mean_return"],
                    color=colour,
                    alpha=0.45,
                    lw=1,
                    label=label,
                )
                label = None
        some = next((r for k, r in runs.items() if k[0] == algo and k[2] == env), None)
        if some is not None:
            ax.axhline(some["threshold"], color="k", ls="--", lw=0.8, label="threshold")
        ax.set_title(f"{algo.upper()} {env.removeprefix('sb3_geogp/')}")
        ax.set_xlabel("training seconds (evaluations excluded)")
        ax.set_ylabel("evaluation return")
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(
        f"Evaluation return against the training clock, seeds {seeds[0]}-{seeds[-1]}, "
        "one run at a time"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def table(
    runs: Runs,
    caption: str,
    header: str,
    row: Callable[..., str | None],
    cells: tuple[tuple[str, str, str], ...] = CELLS,
) -> None:
    """Print a caption and a table with ``row(runs, algo, gp, env)`` for each cell."""
    print(caption + "\n")
    print(header)
    for cell in cells:
        line = row(runs, *cell)
        if line is not None:
            print(line)


def main() -> None:
    runs = index([r for algo in ("ppo", "a2c") for r in load_results(HERE / algo)])
    print("# Training seconds to the threshold (PLAN.md; session 79)\n")
    table(
        runs,
        "Seconds: the training clock at the first evaluation whose mean return reaches the "
        "threshold (evaluations excluded); median over the cell's runs, a run that never "
        "reaches it counted as never, and how many reach it. GP / MLP: per seed where both "
        "reach it, median over those seeds [95 % bootstrap] (how many seeds). Per step: "
        "whole-run training seconds, GP / MLP, median over seeds.",
        "| cell | seeds | GP s | MLP s | GP / MLP, seconds | GP steps | MLP steps | "
        "GP / MLP, steps | per step |\n|---|---:|---:|---:|---|---:|---:|---|---:|",
        cell_row,
    )
    print("\n## Return at the MLP critic's training time (secondary, added after the runs)\n")
    table(
        runs,
        "The GP critic's evaluation return at its last evaluation within the MLP critic's "
        "whole training time on the same seed, against the MLP critic's final return: what "
        "each critic's agents reach in the same training seconds. Mean over seeds, GP − MLP "
        "[95 % bootstrap of the paired mean]. The GP critic's evaluations come every 1/20 of "
        "its budget, so its return is read up to one evaluation early (against it). The "
        "addendum's cells (the last seven) on the seeds whose runs all finished by its "
        f"stopping time: {complete_seeds(runs, MORE_CELLS)}.",
        "| cell | seeds | GP, mean | MLP, mean | GP − MLP |\n|---|---:|---:|---:|---|",
        equal_time_row,
        CELLS + MORE_CELLS,
    )
    print("\n## The new runs against the stored ones (evaluations equal)\n")
    print("| cell | critic | same evaluations |\n|---|---|---|")
    print("\n".join(reproduction(runs)))
    plot(runs, CELLS, SEEDS, HERE / "curves.png")
    print("\n![return against the training clock](curves.png)")
    if any((algo, gp, env, s) in runs for algo, gp, env in MORE_CELLS for s in SEEDS):
        plot(runs, MORE_CELLS, complete_seeds(runs, MORE_CELLS), HERE / "curves_more.png")
        print("\n![the addendum's cells](curves_more.png)")


if __name__ == "__main__":
    main()
