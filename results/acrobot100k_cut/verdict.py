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
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
H200 = load_script(HERE.parent / "ppo_horizon200" / "table.py", "ppo_horizon200")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=("final_return", "mean_return"), default="final_return")
    args = parser.parse_args()
    print(
        "## Issue 13's table, PPO's returns cut where gamma ** 200 >= 0.5 (MountainCarContinuous)\n"
    )
    H200.verdict(args.metric, cut=(H200.MCC,))


if __name__ == "__main__":
    main()
