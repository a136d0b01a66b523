"""Issue 13's verdict table on 50 seeds per cell: the registered reading (session 48).

``PREREGISTRATION.md`` fixes the runs (``run.sh``: today's defaults and SB3's MLP critic on
fresh seeds 570-579 in all 14 cells, ``ppo_s570`` and ``a2c_s570``) and the reading: the
published table's runs (``results/acrobot100k_cut/verdict.py``'s) pooled with them, the table's
rule (difference of means, 95 % percentile bootstrap, family-wise at the published 42); the
fresh seeds alone as a secondary reading. Only whole cells of the fresh seeds (both critics,
all 10 seeds) are pooled; a partial sweep replaces nothing.

    python results/table50/read.py --plot results/table50/table.png > results/table50/table.md
    python results/table50/read.py --metric mean_return > results/table50/auc.md
    python results/table50/read.py --steps > results/table50/steps.md

``--steps`` (session 50) reads the 50 seeds' steps to the threshold as
``results/acrobot100k_cut/verdict.py --steps`` reads the published 40 (a secondary reading
defined after those runs).
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import plot_difference_panels
from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
H200 = load_script(RESULTS / "ppo_horizon200" / "table.py", "ppo_horizon200")
POOL30 = load_script(RESULTS / "replication_0_15" / "pool30.py", "pool30")
VERDICT = load_script(RESULTS / "acrobot100k_cut" / "verdict.py", "acrobot100k_cut_verdict")
FRESH_SEEDS = set(range(570, 580))
CELLS = 14


def fresh_runs() -> list[dict[str, Any]]:
    """The fresh seeds' runs of the cells where both critics finished all 10 seeds."""
    folders = [f for f in (HERE / "ppo_s570", HERE / "a2c_s570") if f.is_dir()]
    runs = pool_sweeps(folders) if folders else []
    per_cell = Counter((r["spec"]["algo"], r["spec"]["env_id"]) for r in runs)
    whole = {cell for cell, n in per_cell.items() if n == 2 * len(FRESH_SEEDS)}
    return [r for r in runs if (r["spec"]["algo"], r["spec"]["env_id"]) in whole]


def published_and_fresh() -> list[dict[str, Any]]:
    """The 50 seeds' runs: the published table's 40 and the fresh 10."""
    published, _, _ = H200.table_runs((H200.MCC,))
    return published + fresh_runs()


def tables(metric: str) -> dict[str, dict[tuple[str, str], dict[str, Any]]]:
    """Default − MLP by cell: the published 40 seeds, the fresh 10 alone, the 50 pooled."""
    published, _, _ = H200.table_runs((H200.MCC,))
    fresh = fresh_runs()
    return {
        "40": POOL30.mlp_rows(published, metric),
        "fresh 10": POOL30.mlp_rows(fresh, metric),
        "50": POOL30.mlp_rows(published + fresh, metric),
    }


def plot(sets: dict[str, dict[tuple[str, str], dict[str, Any]]], metric: str, path: str) -> None:
    """Each cell's difference on the published seeds, the fresh ones and both."""
    cells = sorted(sets["40"], key=lambda k: (k[1], k[0]))
    panels = [{"env": env, "algo": algo, **{k: t.get((env, algo)) for k, t in sets.items()}}
              for env, algo in cells]  # fmt: skip
    title = f"default GP critic − SB3's MLP critic, {metric}, issue 13's table"
    plot_difference_panels(panels, list(sets), path, title, n_cols=7, panel_size=(2.2, 2.4))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=("final_return", "mean_return"), default="final_return")
    parser.add_argument("--plot", metavar="PNG", help="draw each cell: 40, fresh 10, 50 seeds")
    parser.add_argument("--steps", action="store_true", help="steps to the threshold, 50 seeds")
    args = parser.parse_args()
    if args.steps:
        published, _, _ = H200.table_runs((H200.MCC,))
        VERDICT.print_steps(published + fresh_runs(), "50 seeds")
        return
    label = H200.READING.LABELS[args.metric]
    sets = tables(args.metric)
    whole = len(sets["fresh 10"])
    state = "" if whole == CELLS else f" (partial: {whole} of {CELLS} cells; replaces nothing)"
    print(f"## Issue 13's table on 50 seeds per cell, {label}{state}\n")
    H200.print_table(sets["50"], label)
    print(f"\n## The 10 fresh seeds alone (570-579, secondary), {label}\n")
    H200.print_table(sets["fresh 10"], label)
    print(f"\n## The published 40 seeds, {label}\n")
    H200.print_table(sets["40"], label)
    if args.plot:
        plot(sets, label, args.plot)


if __name__ == "__main__":
    main()
