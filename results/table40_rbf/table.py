"""Issue 13's 40-seed table with 0.22's defaults, read as ``PREREGISTRATION.md`` fixes.

PPO rows: the seven of ``results/table40/pool40.md`` (PPO's default unchanged since 0.15). A2C
rows: 0.22's default (RBF kernel) − SB3's MLP critic on the table's A2C seeds (0-19, 30-39,
70-79), final return, 95 % percentile bootstrap, family-wise at the published 42 comparisons.
Only seeds that both critics of a cell have finished are compared, so a partial sweep reads on
its finished seeds (the pre-registration reads whole seed blocks only).

    python results/table40_rbf/table.py --plot results/table40_rbf/table.png \
        > results/table40_rbf/table.md
    python results/table40_rbf/table.py --without-screen > results/table40_rbf/without_screen.md
    python results/table40_rbf/table.py --metric mean_return > results/table40_rbf/auc.md
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "replication_0_15"))
from pool30 import mlp_rows, pooled_runs, print_table

from sb3_geogp.comparison.report import plot_difference_panels

#: The seed sets pooled with each A2C default's runs: the PPO seeds 160-169, and for 0.17 its
#: A2C seeds 70-79 (0.22's are among its own sources).
ADDED = {"0.17": ("fresh40",), "0.22": ("ppo160",)}
#: The A2C seeds of the screen that sent the RBF kernel to its test (``--without-screen``).
SCREEN_SEEDS = range(10)


def paired(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The runs whose seed every critic of their ``(env, algo)`` cell has."""
    seeds: dict[tuple[str, str], dict[str, set[int]]] = defaultdict(lambda: defaultdict(set))
    for r in runs:
        s = r["spec"]
        seeds[(s["env_id"], s["algo"])][s["critic"]].add(s["seed"])
    common = {cell: set.intersection(*by_critic.values()) for cell, by_critic in seeds.items()}
    return [
        r for r in runs if r["spec"]["seed"] in common[(r["spec"]["env_id"], r["spec"]["algo"])]
    ]


def table_runs(a2c: str, without_screen: bool) -> list[dict[str, Any]]:
    """The PPO runs of the 40-seed table and the A2C runs of default ``a2c``, paired."""
    runs = pooled_runs(a2c, ADDED[a2c])
    if without_screen:
        runs = [
            r
            for r in runs
            if not (r["spec"]["algo"] == "a2c" and r["spec"]["seed"] in SCREEN_SEEDS)
        ]
    return paired(runs)


def plot(metric: str, path: str) -> None:
    """Each A2C cell: 0.21's default (geodesic) and 0.22's (RBF) against the MLP critic."""
    sets = {
        "0.21 geodesic": mlp_rows(table_runs("0.17", False), metric),
        "0.22 RBF": mlp_rows(table_runs("0.22", False), metric),
    }
    cells = sorted(cell for cell in sets["0.22 RBF"] if cell[1] == "a2c")
    panels = [
        {"env": env, "algo": algo, **{k: t.get((env, algo)) for k, t in sets.items()}}
        for env, algo in cells
    ]
    title = f"A2C default GP critic − SB3's MLP critic, {metric}, issue 13's 40-seed table"
    plot_difference_panels(panels, list(sets), path, title, n_cols=7, panel_size=(2.2, 2.4))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--a2c",
        choices=("0.17", "0.22"),
        default="0.22",
        help="the A2C default measured (0.17: the geodesic default of 0.17-0.21)",
    )
    parser.add_argument(
        "--without-screen",
        action="store_true",
        help="leave out A2C seeds 0-9 (the RBF kernel's screen)",
    )
    parser.add_argument(
        "--metric",
        choices=("final_return", "mean_return"),
        default="final_return",
        help="mean_return: the area under the curve",
    )
    parser.add_argument("--plot", metavar="PNG", help="draw the A2C rows of 0.21 and 0.22")
    args = parser.parse_args()
    label = {"final_return": "final return", "mean_return": "area under the curve"}[args.metric]
    print_table(mlp_rows(table_runs(args.a2c, args.without_screen), args.metric), label)
    if args.plot:
        plot(args.metric, args.plot)


if __name__ == "__main__":
    main()
