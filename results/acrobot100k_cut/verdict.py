"""Issue 13's verdict table under addendum 1's rule: PPO's Monte Carlo returns cut after 200
steps only where ``gamma ** 200 >= 0.5`` (session 45).

Of the table's PPO cells the rule cuts only MountainCarContinuous-v0 (``gamma`` 0.9999), whose
runs are 0.25's (``results/ppo_horizon200/mcc_s<F>``); Acrobot-v1 (0.99) and CartPole-v1 (0.98)
get 0.24's uncut returns, whose runs are the published ones (``results/ppo_mc_targets``); the
other cells' episodes last at most 200 steps, where nothing is cut either way. The machinery is
``results/ppo_horizon200/table.py``'s ``verdict``.

    python results/acrobot100k_cut/verdict.py > results/acrobot100k_cut/verdict.md
    python results/acrobot100k_cut/verdict.py --metric mean_return \\
        > results/acrobot100k_cut/verdict_auc.md

``--steps`` reads the same runs for steps to the threshold (session 46; a secondary reading
defined after the runs, not part of the registered verdicts): per cell the threshold, how many
runs of each critic reach it within the budget, the median steps to it (a run that never
reaches it counts as later than every run that does; "–" where fewer than half reach it), and a
two-sided Mann-Whitney U test of the steps with the runs that never reach it tied last (every
run has the same budget, so they are censored at the same point), family-wise over the 14
cells (Bonferroni):

    python results/acrobot100k_cut/verdict.py --steps > results/acrobot100k_cut/steps.md
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
H200 = load_script(HERE.parent / "ppo_horizon200" / "table.py", "ppo_horizon200")


CELLS = 14


def steps(runs: list[dict[str, Any]]) -> np.ndarray:
    """Steps to the threshold, ``inf`` where a run never reaches it."""
    return np.array([np.inf if r["steps_to_threshold"] is None else r["steps_to_threshold"]
                     for r in runs])  # fmt: skip


def median_steps(s: np.ndarray) -> str:
    median = np.median(s)
    return f"{median:,.0f}" if np.isfinite(median) else "–"


def print_steps(runs: list[dict[str, Any]] | None = None, seeds: str = "40 seeds") -> None:
    """Steps to the threshold, the default GP critic against SB3's MLP critic, by cell
    (``runs``: the published table's by default)."""
    if runs is None:
        runs, _, _ = H200.table_runs((H200.MCC,))
    cells: dict[tuple[str, str], dict[str, list[dict[str, Any]]]] = {}
    for r in runs:
        spec = r["spec"]
        arm = "mlp" if spec["critic"] == "mlp" else "gp"
        cells.setdefault((spec["algo"], spec["env_id"]), {}).setdefault(arm, []).append(r)
    print(f"## Issue 13's table, {seeds}: steps to the threshold (secondary, defined after the "
          "runs)\n")  # fmt: skip
    print("| algo | env | threshold | reached: GP / MLP | median steps: GP / MLP | "
          "Mann-Whitney p (two-sided) | faster at 95 % | family-wise |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---|---|")
    for (algo, env), arms in sorted(cells.items(), key=lambda kv: (kv[0][0] != "ppo", kv[0])):
        gp, mlp = steps(arms["gp"]), steps(arms["mlp"])
        both = np.concatenate([gp, mlp])
        same = not np.isfinite(both).any()
        # Never reaching it ranks last, all such runs tied (the same budget censors them).
        ranks = sps.rankdata(both)
        p = sps.mannwhitneyu(ranks[: len(gp)], ranks[len(gp) :]).pvalue
        faster = "GP" if ranks[: len(gp)].mean() < ranks[len(gp) :].mean() else "MLP"
        verdict = ["–" if same or q >= 0.05 else faster for q in (p, p * CELLS)]
        print(f"| {algo.upper()} | {env} | {arms['gp'][0]['threshold']:g} | "
              f"{int(np.isfinite(gp).sum())} / {int(np.isfinite(mlp).sum())} of {len(gp)} | "
              f"{median_steps(gp)} / {median_steps(mlp)} | "
              f"{'–' if same else f'{p:.2g}'} | {verdict[0]} | {verdict[1]} |")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=("final_return", "mean_return"), default="final_return")
    parser.add_argument("--steps", action="store_true", help="steps to the threshold")
    args = parser.parse_args()
    if args.steps:
        print_steps()
        return
    print(
        "## Issue 13's table, PPO's returns cut where gamma ** 200 >= 0.5 (MountainCarContinuous)\n"
    )
    H200.verdict(args.metric, cut=(H200.MCC,))


if __name__ == "__main__":
    main()
