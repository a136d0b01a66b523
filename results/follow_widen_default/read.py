"""The reading of PLAN.md's test A: PPO CartPole-v1, PPO's default with
``follow_spread="widen"`` minus the stored 0.39 default runs of issue 13's table, paired by
seed over all 50 table seeds (session 83, registered)::

    python results/follow_widen_default/read.py > results/follow_widen_default/read.md

Test B (InvertedPendulum-v5) is read by ``results/heldout_noise/read.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
#: Session 82's reading, whose table and run files this one shares.
SPREAD = load_script(HERE.parent / "follow_spread_default" / "read.py", "follow_spread_default")

SEEDS = (*range(20), *range(150, 170), *range(570, 580))


def candidate(seed: int) -> dict[str, Any]:
    block = 0 if seed < 150 else 150 if seed < 570 else 570
    return SPREAD.run(HERE / f"s{block}", seed)


def main() -> None:
    print('# `follow_spread="widen"` in PPO\'s default: PPO CartPole-v1 (session 83, registered)\n')
    print("## All 50 table seeds (paired): 0-19, 150-169, 570-579\n")
    print("| reading | `widen` | 0.39 default | difference [95 % t] | verdict |")
    print("|---|---|---|---|---|")
    print("\n".join(SPREAD.rows(SEEDS, candidate)))
    commits = {candidate(s)["provenance"]["git_commit"][:8] for s in SEEDS}
    print(f"\nThe candidate runs were made at commit(s) {', '.join(sorted(commits))}.")


if __name__ == "__main__":
    main()
