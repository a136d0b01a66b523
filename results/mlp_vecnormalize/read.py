"""SB3's MLP critic in the zoo's ``VecNormalize`` against the default GP critic: the registered
reading of ``PREREGISTRATION.md`` (session 61).

The GP critic's runs are issue 13's 50-seed table's (``results/table50/read.py``); the MLP
critic's are this folder's (``run.sh``: ``sb3-geogp compare --critics mlp --mlp-normalize``),
on the same seeds. Only cells with all 50 MLP runs are read::

    python results/mlp_vecnormalize/read.py --plot results/mlp_vecnormalize/read.png \\
        > results/mlp_vecnormalize/read.md
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.report import plot_difference_panels
from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
TABLE50 = load_script(RESULTS / "table50" / "read.py", "table50_read")
POOL30 = TABLE50.POOL30
#: The cells whose zoo entry normalises (``normalize: true``); the last, whose entry is the
#: zoo's Pendulum-v1 one, was added in session 62 (``ADDENDUM.md``).
CELLS = (
    ("MountainCarContinuous-v0", "ppo"),
    ("Acrobot-v1", "ppo"),
    ("Pendulum-v1", "a2c"),
    ("MountainCarContinuous-v0", "a2c"),
    ("Acrobot-v1", "a2c"),
    ("sb3_geogp/PaperPendulum-v0", "a2c"),
)
SEEDS_PER_CELL = 50
LABELS = {"final_return": "final return", "mean_return": "area under the curve"}


def _cell(run: dict[str, Any]) -> tuple[str, str]:
    return run["spec"]["env_id"], run["spec"]["algo"]


@functools.cache  # every reading reads the same files
def arms() -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """The table's GP runs and MLP runs, and this folder's MLP runs in ``VecNormalize``, in the
    cells where all 50 of the latter have finished (and on the same seeds as the table's)."""
    folders = [f for f in (HERE / "ppo", HERE / "a2c") if (f / "runs").is_dir()]
    normalised = pool_sweeps(folders) if folders else []
    assert all(r["spec"].get("normalize") is True for r in normalised)
    table = [r for r in TABLE50.published_and_fresh() if _cell(r) in CELLS]
    whole = set()
    for cell in CELLS:
        seeds = sorted(r["spec"]["seed"] for r in normalised if _cell(r) == cell)
        table_seeds = sorted(
            r["spec"]["seed"] for r in table if _cell(r) == cell and r["spec"]["critic"] == "mlp"
        )
        if len(seeds) == SEEDS_PER_CELL:
            assert seeds == table_seeds, cell
            whole.add(cell)
    gp = [r for r in table if _cell(r) in whole and r["spec"]["critic"] != "mlp"]
    mlp = [r for r in table if _cell(r) in whole and r["spec"]["critic"] == "mlp"]
    return gp, mlp, [r for r in normalised if _cell(r) in whole]


def readings(metric: str) -> dict[str, dict[tuple[str, str], dict[str, Any]]]:
    """GP − MLP without and with ``VecNormalize`` (the table's rule and family), and MLP with
    − without it (a family of the cells)."""
    gp, mlp, normalised = arms()
    return {
        "GP − MLP (the table)": POOL30.mlp_rows(gp + mlp, metric),
        "GP − MLP in VecNormalize": POOL30.mlp_rows(gp + normalised, metric),
        "MLP in VecNormalize − MLP": POOL30.against_baseline(
            normalised, mlp, metric, family=len(CELLS)
        ),
    }


def cell_means(
    runs: list[dict[str, Any]], value: Callable[[dict[str, Any]], float]
) -> dict[tuple[str, str], float]:
    """Mean over seeds of ``value(run)``, per cell."""
    per_cell: dict[tuple[str, str], list[float]] = {}
    for r in runs:
        per_cell.setdefault(_cell(r), []).append(value(r))
    return {cell: float(np.mean(v)) for cell, v in per_cell.items()}


def critic_rmse(runs: list[dict[str, Any]]) -> dict[tuple[str, str], float]:
    """Mean over seeds of the final critic RMSE against Monte Carlo returns, per cell."""
    return cell_means(runs, lambda r: r["critic_accuracy"]["rmse"][-1])


def plot(sets: dict[str, dict[tuple[str, str], dict[str, Any]]], metric: str, path: str) -> None:
    """Each cell's GP − MLP without and with the MLP critic's ``VecNormalize``."""
    shown = {"table": sets["GP − MLP (the table)"], "VecNorm": sets["GP − MLP in VecNormalize"]}
    title = (
        f"default GP critic − SB3's MLP critic, {metric}: the MLP critic as in issue 13's "
        "table (without VecNormalize) and in the zoo's VecNormalize"
    )
    plot_cells(shown, path, title)


def partial(cells: set[tuple[str, str]]) -> str:
    """A heading's note where only some of :data:`CELLS` are read."""
    return "" if len(cells) == len(CELLS) else f" (partial: {len(cells)} of {len(CELLS)} cells)"


def print_readings(
    sets: dict[str, dict[tuple[str, str], dict[str, Any]]],
    metric: str,
    against_mlp: Callable[[str], bool],
    other: str = "with − without",
) -> None:
    """Each reading of ``sets`` on ``metric`` as a table; ``against_mlp(name)`` tells a
    critic − MLP reading from the others, whose difference is labelled ``other``."""
    for name, rows in sets.items():
        print(f"## {name}, {LABELS[metric]}\n")
        difference = "critic − MLP" if against_mlp(name) else other
        POOL30.print_table(rows, LABELS[metric], difference)
        print()


def plot_cells(
    shown: dict[str, dict[tuple[str, str], dict[str, Any]]], path: str, title: str
) -> None:
    """One panel per cell of :data:`CELLS` that every reading of ``shown`` has, one point
    (with its interval) per reading."""
    panels = [{"env": env, "algo": algo, **{k: t[(env, algo)] for k, t in shown.items()}}
              for env, algo in CELLS if all((env, algo) in t for t in shown.values())]  # fmt: skip
    plot_difference_panels(panels, list(shown), path, title, n_cols=3, panel_size=(3.2, 2.6))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG", help="draw each cell's final-return readings")
    args = parser.parse_args()
    gp, mlp, normalised = arms()
    cells = {_cell(r) for r in normalised}
    print(f"# SB3's MLP critic in the zoo's VecNormalize: the registered reading{partial(cells)}\n")
    for metric in ("final_return", "mean_return"):
        sets = readings(metric)
        print_readings(sets, metric, lambda name: name.startswith("GP"))
        if metric == "final_return" and args.plot:
            plot(sets, LABELS[metric], args.plot)
    print("## Final critic RMSE against Monte Carlo returns (mean over seeds; lower is better)\n")
    print("| env | algo | GP | MLP | MLP in VecNormalize |")
    print("|---|---|---:|---:|---:|")
    columns = [critic_rmse(arm) for arm in (gp, mlp, normalised)]
    for cell in CELLS:
        if cell in cells:
            rmse = " | ".join(f"{c[cell]:.2f}" for c in columns)
            print(f"| `{cell[0]}` | {cell[1]} | {rmse} |")


if __name__ == "__main__":
    main()
