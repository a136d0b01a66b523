"""Issue 13's table with 0.35.0's default GP critic in every PPO cell (session 68).

The table's PPO MountainCarContinuous-v0 runs are 0.25's, which 0.34.1's default does not
reproduce (``results/whole_batch``'s addendum); ``run.sh`` re-runs the cell with 0.35.0's
default on the table's 50 seeds (``s<F>``). Read here: the re-run against the stored runs and
against SB3's MLP critic's stored runs (which no GP option touches), and the whole table with
0.35.0's runs in the five PPO cells re-run this session (the four of ``results/whole_batch``
and this one), the table's rule (family-wise at 42).

    python results/mcc_refresh/read.py > results/mcc_refresh/read.md
    python results/mcc_refresh/read.py --metric mean_return > results/mcc_refresh/auc.md
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
WHOLE = load_script(HERE.parent / "whole_batch" / "read.py", "whole_batch")
BLOCKS = (0, 10, 150, 160, 570)
MCC = "MountainCarContinuous-v0"


def is_default_mcc(run: dict[str, Any]) -> bool:
    s = run["spec"]
    return (s["algo"], s["critic"], s["env_id"]) == ("ppo", "laplacian", MCC)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=tuple(WHOLE.LABELS), default="final_return")
    args = parser.parse_args()
    label = WHOLE.LABELS[args.metric]
    published = WHOLE.TABLE50.published_and_fresh()
    fresh = fresh_runs()
    stored = [r for r in published if is_default_mcc(r)]
    fresh, stored = WHOLE.TABLE50.VERDICT.H200.READING.TABLE40.on_common_seeds(fresh, stored)
    print(f"## PPO {MCC}: 0.35.0's re-run − the stored 0.25 runs, {label} "
          f"({len(fresh)} seeds)\n")  # fmt: skip
    WHOLE.POOL30.print_table(
        WHOLE.POOL30.against_baseline(fresh, stored, args.metric, 1), label, "re-run − stored"
    )
    print(f"\n## Issue 13's table, every PPO cell 0.35.0's default where it was re-run, {label}\n")
    if len(fresh) < 10 * len(BLOCKS):
        print("Not every seed of the re-run finished: the table keeps the stored runs.\n")
        return
    WHOLE.POOL30.print_table(
        WHOLE.POOL30.mlp_rows(table_runs(published, fresh), args.metric), label
    )


def table_runs(
    published: list[dict[str, Any]], fresh: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """Issue 13's table's runs (``published``: the 50 seeds' stored runs) with 0.35.0's default
    where it was re-run: the four cells of ``results/whole_batch`` and MountainCarContinuous-v0
    (``fresh``, this folder's runs)."""
    whole = pool_sweeps([WHOLE.HERE / f"table_s{b}" for b in WHOLE.BLOCKS])
    others = [r for r in published if not (WHOLE.touched(r) or is_default_mcc(r))]
    return others + whole + fresh


def fresh_runs() -> list[dict[str, Any]]:
    """This folder's re-run of PPO MountainCarContinuous-v0."""
    return pool_sweeps([f for f in (HERE / f"s{b}" for b in BLOCKS) if f.is_dir()])


if __name__ == "__main__":
    main()
