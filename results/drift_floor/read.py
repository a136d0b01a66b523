"""The reading of ``PLAN.md``'s screen (session 76, exploratory)::

    python results/drift_floor/read.py > results/drift_floor/read.md

Floor − 0.37's default per cell, paired by seed (95 % bootstrap of the mean per-seed
difference), on the final return, the area under the curve (mean evaluation return) and the
final critic RMSE; beside it the comparison's own interval (the two groups resampled
separately, as ``report/vs_baseline.json``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.report import comparison_cell
from sb3_geogp.comparison.results import METRICS, comparisons, load_results, verdict
from sb3_geogp.toolbox.stats import bootstrap_ci

HERE = Path(__file__).resolve().parent
SCREEN_CELLS = ("CartPole-v1", "Pendulum-v1", "MountainCarContinuous-v0")
READ = ("final_return", "mean_return", "critic_rmse")
LABELS = {
    "final_return": "final return",
    "mean_return": "area under the curve",
    "critic_rmse": "final critic RMSE",
}


def paired_difference(
    runs: list[dict[str, Any]], default: list[dict[str, Any]], metric: str, level: float = 0.95
) -> tuple[float, float, float, str]:
    """Mean per-seed difference runs − default, its bootstrap interval at ``level`` and the
    interval's verdict (every seed of ``runs`` must be in ``default``)."""
    of_run = METRICS[metric].of_run
    by_seed = {r["spec"]["seed"]: of_run(r) for r in default}
    diffs = np.array([of_run(r) - by_seed[r["spec"]["seed"]] for r in runs])
    d, low, high = (float(x) for x in bootstrap_ci(diffs, level=level))
    return d, low, high, verdict(low, high, METRICS[metric].higher_is_better)


def paired(runs: list[dict[str, Any]], default: list[dict[str, Any]], metric: str) -> str:
    """Mean per-seed difference runs − default with its 95 % bootstrap interval."""
    d, low, high, word = paired_difference(runs, default, metric)
    return f"{d:+.3g} [{low:+.3g}, {high:+.3g}] {word}"


def screen_table(folder: Path, cells: tuple[str, ...], arm: str) -> None:
    """One row per cell: ``folder/<arm>_<env>`` − ``folder/default_<env>`` (``env`` without
    its ``sb3_geogp/`` prefix), paired by seed and as the comparison reads it."""
    print("| env | seeds | " + " | ".join(LABELS.values()) + " |")
    print("|---|---:|" + "---:|" * len(READ))
    for env in cells:
        name = env.removeprefix("sb3_geogp/")
        runs, default = (load_results(folder / f"{a}_{name}") for a in (arm, "default"))
        rows = {r["metric"]: r for r in comparisons(runs, baseline=default)}
        entries = [f"{paired(runs, default, m)}<br>({comparison_cell(rows[m])})" for m in READ]
        print(f"| {env} | {len(runs)} | " + " | ".join(entries) + " |")
    print()


def screen() -> None:
    print("## The screen (PLAN.md, exploratory): drift_floor=0.5 − 0.37's default\n")
    print("Paired by seed; in brackets below each, the comparison's interval (groups resampled")
    print("separately, `report/vs_baseline.json`; one cell per sweep, so its bold verdicts are at")
    print("95 %).\n")
    screen_table(HERE, SCREEN_CELLS, "floor")


def main() -> None:
    screen()


if __name__ == "__main__":
    main()
