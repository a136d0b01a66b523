"""``PLAN.md``'s critic-fit reading: forgetting 0.5 per 4,096 points against 0.35.0's default
(the published ``docs/critic_fit_0_35``), issue 13's critic-fit score, paired by seed::

python results/forgetting_ppo/read_fit.py > results/forgetting_ppo/read_fit.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
WHOLE = load_script(ROOT / "results" / "whole_batch" / "read.py", "whole_batch")
ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")


def main() -> None:
    print("Forgetting 0.5 per 4,096 points against 0.35.0's default, PPO 30,000 steps")
    print("(exploratory, PLAN.md's addendum).\n")
    arms = ("docs/critic_fit_0_35", "results/forgetting_ppo/critic_fit")
    reading = "PLAN.md's addendum (exploratory), 95 % t interval"
    WHOLE.fit_table(ROOT, range(10), ENVS, reading, arms, ("default", "forgetting 0.5"))


if __name__ == "__main__":
    main()
