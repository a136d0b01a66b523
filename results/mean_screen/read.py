"""``PLAN.md``'s reading: the linear prior mean against the published 0.35.0 runs, issue 13's
critic-fit score, paired by seed (the table of ``results/whole_batch/read.py``'s
``fit_table``)::

python results/mean_screen/read.py > results/mean_screen/read.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]
WHOLE = load_script(ROOT / "results" / "whole_batch" / "read.py", "whole_batch")
ENVS = ("Acrobot-v1", "CartPole-v1", "Pendulum-v1")


def main() -> None:
    print("PPO 30,000 steps, seeds 0-9 (exploratory, PLAN.md).\n")
    rule = "PLAN.md (exploratory) reads the per-rollout score, 95 % t interval"
    arms = ("docs/critic_fit_0_35", "results/mean_screen/linear")
    WHOLE.fit_table(ROOT, range(10), ENVS, rule, arms, ("constant", "linear"))


if __name__ == "__main__":
    main()
