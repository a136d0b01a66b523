"""The reading of this folder's studies (session 74)::

    python results/drift_forgetting/read.py > results/drift_forgetting/read.md

1. ``PLAN.md``'s screen (exploratory): ``drift_forgetting=12.6`` against the default critic's
   stored runs on seeds 883-892 (``s74_screen/report/vs_baseline.json``), and on the critic
   RMSE against session 73's fixed forgetting 0.5 on the same seeds.
2. ``PREREGISTRATION.md``'s rule, read mechanically by ``results/forgetting_ppo/read.py``'s
   reader (the same rule), once the registered sweep has finished; then, decided on by
   nothing, the GP critic's share of the training time in both arms.
3. Figures: drift − default per cell, the screen's and the registered test's intervals side by
   side, for the final return and the final critic RMSE (``final_return.png``,
   ``critic_rmse.png`` here).
4. ``PLAN.md``'s addendum (exploratory): issue 13's critic-fit score with the option against
   the published default's ``docs/critic_fit_0_35``, paired by seed
   (``results/whole_batch/read.py``'s ``fit_table``, as ``results/forgetting_ppo/read.py``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.report import plot_difference_panels
from sb3_geogp.comparison.results import comparisons, group_runs, load_results
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
FORGETTING = load_script(ROOT / "results" / "forgetting_ppo" / "read.py", "forgetting_ppo")


def verdict_table(rows: list[dict[str, Any]], metrics: tuple[str, ...], title: str) -> None:
    print(f"## {title}\n")
    print("| env | metric | difference [95 %] | at 95 % | family-wise |")
    print("|---|---|---:|---|---|")
    for r in rows:
        if r["metric"] in metrics:
            interval = f"{r['diff']:+.3g} [{r['low']:+.3g}, {r['high']:+.3g}]"
            print(
                f"| {r['env']} | {r['metric']} | {interval} | {r['verdict']} | {r['fw_verdict']} |"
            )
    print()


def screen() -> None:
    rows = json.loads((HERE / "s74_screen" / "report" / "vs_baseline.json").read_text())
    verdict_table(
        rows,
        FORGETTING.HARM_METRICS,
        "The screen (PLAN.md, exploratory): drift forgetting − default, seeds 883-892",
    )
    fixed = load_results(ROOT / "results" / "forgetting_ppo" / "s73_forget05")
    against = comparisons(load_results(HERE / "s74_screen"), baseline=fixed)
    verdict_table(
        against,
        ("critic_rmse",),
        "The screen beside session 73's fixed forgetting 0.5: drift − fixed, seeds 883-892",
    )


def critic_share(
    folder: Path = HERE, arms: dict[str, list[str]] | None = None, title: str = "sequential sweeps"
) -> None:
    """Mean share of the training time spent in the GP critic, per cell and arm: each arm
    (a column) pools the sweeps named for it in ``folder``; by default the registered sweeps
    ``reg_default`` and ``reg_drift``."""
    arms = arms or {"default": ["reg_default"], "drift": ["reg_drift"]}
    grouped = {
        label: group_runs([r for sweep in sweeps for r in load_results(folder / sweep)])
        for label, sweeps in arms.items()
    }
    print(f"## The GP critic's share of the training time (secondary; {title})\n")
    print("| env | " + " | ".join(grouped) + " |")
    print("|---|" + "---:|" * len(grouped))
    first = next(iter(grouped.values()))
    for key in sorted(first):
        shares = [np.mean([r["critic_share"] for r in runs[key]]) for runs in grouped.values()]
        print(f"| {key[0]} | " + " | ".join(f"{x:.3f}" for x in shares) + " |")
    print()


def figures() -> None:
    sweeps = {"screen": "s74_screen", "registered": "reg_drift"}
    rows = {
        arm: json.loads((HERE / sweep / "report" / "vs_baseline.json").read_text())
        for arm, sweep in sweeps.items()
    }
    for metric, label in (("final_return", "final return"), ("critic_rmse", "final critic RMSE")):
        panels = [
            {"env": r["env"], "algo": r["algo"]}
            | {
                arm: next(x for x in rows[arm] if x["env"] == r["env"] and x["metric"] == metric)
                for arm in sweeps
            }
            for r in rows["registered"]
            if r["metric"] == metric
        ]
        title = f"drift_forgetting=12.6 − default, {label} (screen: seeds 883-892; registered: 913-932)"
        plot_difference_panels(panels, list(sweeps), HERE / f"{metric}.png", title, 4, (3.2, 2.4))


def main() -> None:
    screen()
    rows = json.loads((HERE / "reg_drift" / "report" / "vs_baseline.json").read_text())
    FORGETTING.registered(
        rows,
        label="drift forgetting 12.6 − default, seeds 913-932",
        script="results/drift_forgetting/run.sh",
        outcome="PREREGISTRATION.md: in a later session that re-runs issue 13's table's PPO rows",
    )
    critic_share()
    figures()
    print("## Critic fit (PLAN.md's addendum, exploratory)\n")
    arms = ("docs/critic_fit_0_35", "results/drift_forgetting/critic_fit")
    envs = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")
    reading = "PLAN.md's addendum (exploratory), 95 % t interval"
    FORGETTING.WHOLE.fit_table(ROOT, range(10), envs, reading, arms, ("default", "drift 12.6"))


if __name__ == "__main__":
    main()
