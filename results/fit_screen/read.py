"""``PLAN.md``'s reading: each arm against the control, issue 13's critic-fit score, paired by
seed (the table of ``results/whole_batch/read.py``'s ``fit_table``); the ``returns`` arm of its
second addendum against the published 0.35.0 runs, which the control equals::

python results/fit_screen/read.py > results/fit_screen/read.md
"""

from __future__ import annotations

import json
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
WHOLE = load_script(ROOT / "results" / "whole_batch" / "read.py", "whole_batch")
ENVS = ("Acrobot-v1", "Pendulum-v1")
SEEDS = range(10)
ARMS = ("slow_forget", "noise_floor", "prior_03", "steps_20", "fit_2048", "basis_512", "steps_2")
PUBLISHED = ROOT / "docs" / "critic_fit_0_35" / "runs"


def control_reproduces() -> bool:
    """Whether every control run's per-rollout scores equal the published run's."""
    key = "explained_variance"
    return all(
        json.loads((HERE / "control" / "runs" / p.name).read_text())[key]
        == json.loads(p.read_text())[key]
        for env in ENVS
        for p in (PUBLISHED / f"laplacian__{env}__s{s}.json" for s in SEEDS)
    )


def main() -> None:
    print("PPO 30,000 steps, seeds 0-9 (exploratory, PLAN.md).\n")
    print(f"Control equals `docs/critic_fit_0_35` rollout by rollout: {control_reproduces()}\n")
    rule = "PLAN.md (exploratory) reads Acrobot-v1's per-rollout score, 95 % t interval"
    for arm in ARMS:
        print(f"**Arm `{arm}`**\n")
        WHOLE.fit_table(HERE, SEEDS, ENVS, rule, ("control", arm), ("control", arm))
    print("**Arm `returns`** (addendum 2), against the published runs, which the control equals\n")
    arms = ("docs/critic_fit_0_35", "results/fit_screen/returns")
    WHOLE.fit_table(ROOT, SEEDS, (*ENVS, "CartPole-v1"), rule, arms, ("default", "returns"))


if __name__ == "__main__":
    main()
