"""``PLAN.md``'s reading: Monte Carlo returns cut after 50 steps against 0.35.0's default (the
published ``docs/critic_fit_0_35``), issue 13's critic-fit score, paired by seed::

python results/horizon_fit/read.py > results/horizon_fit/read.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
WHOLE = load_script(ROOT / "results" / "whole_batch" / "read.py", "whole_batch")
ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")


def main() -> None:
    print("`horizon=50` against 0.35.0's default, PPO 30,000 steps (exploratory, PLAN.md).\n")
    arms = ("docs/critic_fit_0_35", "results/horizon_fit/h50")
    reading = "PLAN.md (exploratory) reads Acrobot-v1's per-rollout score, 95 % t interval"
    WHOLE.fit_table(ROOT, range(10), ENVS, reading, arms, ("default", "horizon 50"))


if __name__ == "__main__":
    main()
