"""A2C CartPole-v1 with ``follow_spread="widen"`` (session 83, exploratory): A2C's default
adaptation with the widening, issue 13's table protocol, seeds 0-19, paired with the table's
stored runs of A2C's default (0.22's, unchanged since; ``repro0`` re-runs seed 0 with today's
code)::

    A='{"max_gap": 16, "settle": false, "follow_spread": "widen"}'   # over Adaptation()'s defaults
    sb3-geogp compare --algos a2c --envs CartPole-v1 --critics rbf --seeds 20 --first-seed 0 \
        --workers 2 --no-progress --no-plots --out results/a2c_widen/widen --gp-option "adapt=$A"
    sb3-geogp compare --algos a2c --envs CartPole-v1 --critics rbf --seeds 1 --first-seed 0 \
        --workers 1 --no-progress --no-plots --out results/a2c_widen/repro0
    python results/a2c_widen/read.py > results/a2c_widen/read.md
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
SPACING = load_script(HERE.parent / "fit_spacing" / "read.py", "fit_spacing")
#: Session 82's reading, whose paired rows (readings, intervals, verdicts) this one shares.
SPREAD = load_script(HERE.parent / "follow_spread_default" / "read.py", "follow_spread_default")


def by_seed(runs: Iterable[dict[str, Any]]) -> dict[int, dict[str, Any]]:
    return {r["spec"]["seed"]: r for r in runs}


def main() -> None:
    stored = by_seed(
        r
        for r in SPACING.today_spaced()
        if (r["spec"]["algo"], r["spec"]["env_id"], r["spec"]["critic"])
        == ("a2c", "CartPole-v1", "rbf")
    )
    widen = by_seed(load_results(HERE / "widen"))
    again = load_results(HERE / "repro0")[0]
    seeds = sorted(widen)
    print('# A2C CartPole-v1 with `follow_spread="widen"` (session 83, exploratory)\n')
    print(f"Seeds {seeds[0]}-{seeds[-1]}, paired with the table's stored A2C default runs.\n")
    print("| reading | widen | A2C default | difference [95 % t] | verdict |")
    print("|---|---|---|---|---|")
    print("\n".join(SPREAD.rows(tuple(seeds), widen.__getitem__, stored.__getitem__)))
    same = all(again[k] == stored[0][k] for k in ("eval", "critic_accuracy", "final_return"))
    print(f"\nThe stored default run of seed 0, re-run with today's code, is the same: {same}.")


if __name__ == "__main__":
    main()
