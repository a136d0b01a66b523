"""The reading of this folder's studies (session 76)::

    python results/a2c_drift/read.py > results/a2c_drift/read.md

1. ``PLAN.md``'s screen (exploratory): drift − default, seeds 186-195
   (``drift/report/vs_baseline.json``).
2. ``PREREGISTRATION.md``'s rule, read mechanically once its sweeps have finished
   (``reg_drift/report/vs_baseline.json``, family-wise over the 7 cells); then, decided on by
   nothing, the GP critic's share of the training time in both arms.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import comparison_cell
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
DRIFT = load_script(ROOT / "results" / "drift_forgetting" / "read.py", "drift_forgetting")
METRICS = {
    "final_return": "final return",
    "mean_return": "area under the curve",
    "critic_rmse": "final critic RMSE",
}
#: PREREGISTRATION.md's benefit: the screen's three signals, (cell, metric).
SIGNALS = (
    ("Pendulum-v1", "critic_rmse"),
    ("CartPole-v1", "mean_return"),
    ("sb3_geogp/WallMaze-v0", "final_return"),
)


def table(rows: list[dict[str, Any]], title: str) -> None:
    print(f"## {title}\n")
    print("| env | " + " | ".join(METRICS.values()) + " |")
    print("|---|" + "---:|" * len(METRICS))
    by_env: dict[str, dict[str, dict[str, Any]]] = {}
    for r in rows:
        by_env.setdefault(r["env"], {})[r["metric"]] = r
    for env, metrics in sorted(by_env.items()):
        print(f"| {env} | " + " | ".join(comparison_cell(metrics[m]) for m in METRICS) + " |")
    print("\n(verdicts at 95 %; bold: also family-wise over the 7 cells)\n")


def registered(rows: list[dict[str, Any]]) -> None:
    verdicts = {(r["env"], r["metric"]): r["fw_verdict"] for r in rows}
    benefit = [s for s in SIGNALS if verdicts[s] == "better"]
    harm = [k for k, v in verdicts.items() if k[1] in METRICS and v == "worse"]
    print("## The rule (PREREGISTRATION.md)\n")
    named = ", ".join(f"{e} {METRICS[m]}" for e, m in benefit) or "none"
    print(f"1. Benefit, signals better family-wise: {named} -> {'holds' if benefit else 'fails'}.")
    named = ", ".join(f"{e} {METRICS[m]}" for e, m in harm) or "none"
    print(f"2. No harm, cells worse family-wise: {named} -> {'fails' if harm else 'holds'}.\n")
    adopt = "adopt, in a later session that re-runs issue 13's table's A2C rows with it"
    print(f"**Decision: {adopt if benefit and not harm else 'A2C keeps no drift forgetting'}.**\n")


def main() -> None:
    screen = json.loads((HERE / "drift" / "report" / "vs_baseline.json").read_text())
    table(screen, "The screen (PLAN.md, exploratory): drift − default, A2C seeds 186-195")
    report = HERE / "reg_drift" / "report" / "vs_baseline.json"
    if not report.exists():
        print("## The registered test (PREREGISTRATION.md): not finished\n")
        return
    rows = json.loads(report.read_text())
    table(rows, "The registered test (PREREGISTRATION.md): drift − default, A2C seeds 196-215")
    registered(rows)
    DRIFT.critic_share(HERE)


if __name__ == "__main__":
    main()
