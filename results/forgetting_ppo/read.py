"""The reading of this folder's two studies (session 73)::

    python results/forgetting_ppo/read.py > results/forgetting_ppo/read.md

1. ``PREREGISTRATION.md``'s rule, read mechanically from the registered sweep's comparison with
   its baseline (``reg_forget05/report/vs_baseline.json``): adopt or not.
2. ``PLAN.md``'s critic-fit reading (exploratory): the arm's runs against the published
   default's ``docs/critic_fit_0_35``, paired by seed (``results/whole_batch/read.py``'s
   ``fit_table``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
WHOLE = load_script(ROOT / "results" / "whole_batch" / "read.py", "whole_batch")
#: The cells whose critic error the screen saw fall; the rule's benefit needs two of them.
BENEFIT_CELLS = ("CartPole-v1", "Pendulum-v1", "sb3_geogp/PaperPendulum-v0")
#: ``mean_return``: the evaluation return averaged over the checkpoints (area under the curve).
HARM_METRICS = ("critic_rmse", "final_return", "mean_return")


def registered(
    rows: list[dict[str, Any]],
    label: str = "forget05 − default, seeds 893-912",
    script: str = "results/forgetting_ppo/run.sh",
    outcome: str = "PREREGISTRATION.md's result: not carried out",
) -> None:
    """Print every family-wise verdict the rule reads (the arm ``label`` against the default),
    then the rule's outcome (``outcome`` beside an adoption); refuse a sweep that has not
    finished (the rule reads 20 seeds per arm in each of the seven cells; ``script`` runs it)."""
    cells = {(r["env"], r["metric"]) for r in rows}
    if len(cells) != 7 * len(HARM_METRICS) or any({r["n_a"], r["n_b"]} != {20} for r in rows):
        raise SystemExit(f"the registered sweep has not finished: run {script}")
    print(f"## The registered rule (PREREGISTRATION.md), {label}\n")
    print("| env | metric | difference [95 %] | at 95 % | family-wise |")
    print("|---|---|---:|---|---|")
    for r in rows:
        interval = f"{r['diff']:+.3g} [{r['low']:+.3g}, {r['high']:+.3g}]"
        print(f"| {r['env']} | {r['metric']} | {interval} | {r['verdict']} | {r['fw_verdict']} |")
    better = [
        r["env"]
        for r in rows
        if r["metric"] == "critic_rmse"
        and r["env"] in BENEFIT_CELLS
        and r["fw_verdict"] == "better"
    ]
    harm = [
        f"{r['env']} {r['metric']}"
        for r in rows
        if r["metric"] in HARM_METRICS and r["fw_verdict"] == "worse"
    ]
    benefit_holds, no_harm = len(better) >= 2, not harm
    print(f"\n1. Benefit (critic RMSE better family-wise in >= 2 of {list(BENEFIT_CELLS)}): "
          f"{'holds' if benefit_holds else 'fails'} ({better or 'none'})")  # fmt: skip
    print(f"2. No harm (no cell worse family-wise in {list(HARM_METRICS)}): "
          f"{'holds' if no_harm else 'fails'} ({harm or 'none worse'})")  # fmt: skip
    if benefit_holds and no_harm:
        print(f"\n**The rule's decision: adopt** ({outcome}).\n")
    else:
        print("\n**The rule's decision: not adopted; the default is unchanged.**\n")


def main(sweep: str = "reg_forget05") -> None:
    rows = json.loads((HERE / sweep / "report" / "vs_baseline.json").read_text())
    registered(rows)
    print("## Critic fit (PLAN.md's addendum, exploratory)\n")
    arms = ("docs/critic_fit_0_35", "results/forgetting_ppo/critic_fit")
    envs = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")
    reading = "PLAN.md's addendum (exploratory), 95 % t interval"
    WHOLE.fit_table(ROOT, range(10), envs, reading, arms, ("default", "forgetting 0.5"))


if __name__ == "__main__":
    main()
