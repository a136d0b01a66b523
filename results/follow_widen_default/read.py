"""The reading of PLAN.md's test A: PPO CartPole-v1, PPO's default with
``follow_spread="widen"`` minus the stored 0.39 default runs of issue 13's table, paired by
seed over all 50 table seeds (session 83, registered), and issue 13's table with these runs in
its PPO CartPole-v1 cell (``--table``; the other cells are 0.39's table's)::

    python results/follow_widen_default/read.py > results/follow_widen_default/read.md
    python results/follow_widen_default/read.py --table > results/follow_widen_default/table.md
    python results/follow_widen_default/read.py --fit > results/follow_widen_default/fit.md
    python results/follow_widen_default/read.py --curves docs/verdict_table/curves.png

``--fit`` reads issue 13's critic-fit score on PPO CartPole-v1: seeds 0-9 (exploratory, after
the decision) against 0.39's default's runs (``results/fit_spacing/fit_spaced``), then
``PLAN_fit.md``'s check on fresh seeds 1093-1122 against 0.42's default.

Test B (InvertedPendulum-v5) is read by ``results/heldout_noise/read.py``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import sb3_geogp.envs  # noqa: F401  (registers the table's own environments)
from sb3_geogp.comparison.report import difference_title, plot_cell_curves, sweep_cells
from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.defaults import bounds_lengthscale
from sb3_geogp.policies import _feature_bounds
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
#: Session 82's reading, whose table and run files this one shares.
SPREAD = load_script(HERE.parent / "follow_spread_default" / "read.py", "follow_spread_default")
#: 0.39's table (issue 13's, as ``results/fit_spacing/read.py`` assembles it).
SPACING = load_script(HERE.parent / "fit_spacing" / "read.py", "fit_spacing")
BLOCKS = (0, 150, 570)
SEEDS = (*range(20), *range(150, 170), *range(570, 580))


def candidate(seed: int) -> dict[str, Any]:
    return SPREAD.run(HERE / f"s{SPREAD.block(seed)}", seed)


def widened_table() -> list[dict[str, Any]]:
    """Issue 13's table's runs (0.39's) with this folder's in PPO CartPole-v1."""
    widen = pool_sweeps([HERE / f"s{block}" for block in BLOCKS])
    assert len(widen) == len(SEEDS)
    table = SPACING.today_spaced()
    kept = [r for r in table if not is_replaced(r)]
    assert len(table) - len(kept) == len(SEEDS)
    return kept + widen


def table() -> None:
    """Issue 13's table (final return, GP − MLP) with this folder's runs in PPO CartPole-v1."""
    runs = widened_table()
    print("# Issue 13's table with `follow_spread=\"widen\"` in PPO's default (session 83)\n")
    print("PPO CartPole-v1: this folder's 50 runs; every other cell as 0.39's table")
    print("(`results/fit_spacing/registered.md`). The change acts only on inputs that are")
    print("unbounded (and given no lengthscale); per PPO cell, how many the GP critic has:\n")
    for env_id in sorted({r["spec"]["env_id"] for r in runs}):
        print(f"- {env_id}: {unbounded_inputs(env_id)}")
    print()
    SPACING.POOL30.print_table(SPACING.POOL30.mlp_rows(runs))


def curves(path: str) -> None:
    """The same table as learning curves, a panel per cell (PPO's above A2C's)."""
    runs = widened_table()
    titles = {cell: difference_title(c) for cell, c in SPACING.POOL30.mlp_rows(runs).items()}
    plot_cell_curves(runs, path, sweep_cells(runs, ("ppo", "a2c")), titles)


def unbounded_inputs(env_id: str) -> int:
    """How many of the GP critic's inputs on ``env_id`` have no bounds (the policy's rule)."""
    space = gym.make(env_id).observation_space
    return int(np.isnan(bounds_lengthscale(*_feature_bounds(space))).sum())


def is_replaced(run: dict[str, Any]) -> bool:
    """Whether a run of 0.39's table is one this folder's runs replace."""
    return SPACING.TABLE.is_ppo_default(run) and run["spec"]["env_id"] == "CartPole-v1"


def fit() -> None:
    """Issue 13's critic-fit score on CartPole-v1, the widening default against 0.39's (seeds
    0-9, exploratory), then against 0.42's on fresh seeds (``PLAN_fit.md``)."""
    fit_table = SPACING.TABLE.WHOLE.fit_table
    cells = ("CartPole-v1",)
    note = "exploratory, run after the decision; no rule reads it"
    arms = ("../fit_spacing/fit_spaced", "fit_widen")
    fit_table(HERE, range(10), cells, note, arms, ("0.39", "widen"))
    print()
    note = "PLAN_fit.md's rule reads the per-rollout row's Wilcoxon p and paired median"
    arms = ("fit_fresh_042", "fit_fresh_widen")
    fit_table(HERE, range(1093, 1123), cells, note, arms, ("0.42", "widen"))


def reading() -> None:
    print('# `follow_spread="widen"` in PPO\'s default: PPO CartPole-v1 (session 83, registered)\n')
    print("## All 50 table seeds (paired): 0-19, 150-169, 570-579\n")
    print("| reading | `widen` | 0.39 default | difference [95 % t] | verdict |")
    print("|---|---|---|---|---|")
    print("\n".join(SPREAD.rows(SEEDS, candidate)))
    commits = {candidate(s)["provenance"]["git_commit"][:8] for s in SEEDS}
    print(f"\nThe candidate runs were made at commit(s) {', '.join(sorted(commits))}.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--table", action="store_true", help="issue 13's table with these runs")
    parser.add_argument("--fit", action="store_true", help="the critic-fit score on CartPole-v1")
    parser.add_argument("--curves", metavar="PNG", help="draw the table's learning curves")
    args = parser.parse_args()
    if args.curves:
        curves(args.curves)
    else:
        table() if args.table else fit() if args.fit else reading()


if __name__ == "__main__":
    main()
