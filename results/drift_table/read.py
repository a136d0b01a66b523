"""``drift_forgetting=12.6`` in issue 13's table's seven PPO cells: the registered reading
(session 75).

``PREREGISTRATION.md`` fixes the runs (``run.sh``: the drift arm on the table's 50 seeds, one
folder per cell and block of seeds) and the rule read here: issue 13's table with the drift
arm's runs in place of 0.35.0's default in every PPO cell (the table's rule, family-wise at
42). Secondary: drift − 0.35.0's default by cell, paired by seed. A partial sweep decides
nothing and replaces nothing.

    python results/drift_table/read.py --plot results/drift_table/table.png \
        > results/drift_table/read.md
    python results/drift_table/read.py --metric mean_return > results/drift_table/auc.md
    python results/drift_table/read.py --metric critic_rmse > results/drift_table/rmse.md
    python results/drift_table/read.py --steps > results/drift_table/steps.md

``--steps`` (a secondary reading defined after the runs): steps to the threshold as
``results/table50/read.py --steps`` reads them, with the drift arm in the PPO cells.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import plot_difference_panels
from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

HERE = Path(__file__).resolve().parent
REFRESH = load_script(HERE.parent / "mcc_refresh" / "read.py", "mcc_refresh")
WHOLE = REFRESH.WHOLE
POOL30 = WHOLE.POOL30
SEEDS_PER_CELL = 50
PPO_CELLS = 7
#: the cells whose lead rule 2 keeps, and 0.35.0's count of cells better family-wise (rule 3)
KEPT_LEADS = ("CartPole-v1", "Pendulum-v1")
FW_BETTER_TODAY = 9


def is_ppo_default(run: dict[str, Any]) -> bool:
    """Whether ``run`` is one of PPO's default GP critic's (the arm's, or 0.35.0's)."""
    s = run["spec"]
    return (s["algo"], s["critic"]) == ("ppo", "laplacian")


def drift_runs(folder: Path = HERE) -> list[dict[str, Any]]:
    """The runs of the sweeps ``<cell>_s<first seed>`` in ``folder`` (by default the drift
    arm's) of the cells where all 50 seeds finished."""
    folders = sorted(f for f in folder.glob("*_s*") if f.is_dir())
    runs = pool_sweeps(folders) if folders else []
    per_cell = Counter(r["spec"]["env_id"] for r in runs)
    return [r for r in runs if per_cell[r["spec"]["env_id"]] == SEEDS_PER_CELL]


def paired(
    drift: list[dict[str, Any]], today: list[dict[str, Any]], metric: str, label: str
) -> dict[tuple[str, str], dict[str, Any]]:
    """Print and return drift − 0.35.0's default by cell on ``metric``, family-wise over the
    seven."""
    drift, default = WHOLE.TABLE50.VERDICT.H200.READING.TABLE40.on_common_seeds(
        drift, [r for r in today if is_ppo_default(r)]
    )
    print(f"## drift − 0.35.0's default, {label}, paired by seed (family-wise over 7)\n")
    rows = POOL30.against_baseline(drift, default, metric, PPO_CELLS)
    POOL30.print_table(rows, label, "drift − default")
    print()
    return rows


def plot(sets: dict[str, dict[tuple[str, str], dict[str, Any]]], label: str, path: str) -> None:
    """Each PPO cell's differences: 0.35.0's default and the drift arm against SB3's MLP
    critic, and the drift arm against 0.35.0's default."""
    cells = sorted(k for k in sets["drift − default"] if k[1] == "ppo")
    panels = [{"env": env, "algo": algo, **{k: t.get((env, algo)) for k, t in sets.items()}}
              for env, algo in cells]  # fmt: skip
    title = f"PPO's GP critic with drift_forgetting=12.6, {label}, issue 13's table's seeds"
    ticks = [name.replace(" − ", "\n− ") for name in sets]
    plot_difference_panels(panels, list(sets), path, title, 4, (2.6, 2.8), ticks)


def rules(table: dict[tuple[str, str], dict[str, Any]], complete: bool) -> list[tuple[str, str]]:
    """The registered rule's three conditions on the table with the drift arm."""
    fw_worse = [env for (env, _), c in table.items() if c["fw_verdict"] == "worse"]
    lost = [env for env in KEPT_LEADS if table[(env, "ppo")]["fw_verdict"] != "better"]
    fw_better = sum(c["fw_verdict"] == "better" for c in table.values())
    states = [
        ("1. no cell worse than SB3's MLP critic family-wise", WHOLE._holds(fw_worse)),
        ("2. PPO CartPole-v1 and Pendulum-v1 stay better family-wise", WHOLE._holds(lost)),
        (
            f"3. at least {FW_BETTER_TODAY} cells better family-wise",
            "holds" if fw_better >= FW_BETTER_TODAY else f"fails ({fw_better})",
        ),
    ]
    return [(text, state if complete else PARTIAL) for text, state in states]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=tuple(WHOLE.LABELS), default="final_return")
    parser.add_argument("--plot", metavar="PNG", help="draw each PPO cell's three differences")
    parser.add_argument("--steps", action="store_true", help="steps to the threshold")
    args = parser.parse_args()
    label = WHOLE.LABELS[args.metric]
    published = WHOLE.TABLE50.published_and_fresh()
    today = REFRESH.table_runs(published, REFRESH.fresh_runs())
    drift = drift_runs()
    cells = sorted({r["spec"]["env_id"] for r in drift})
    if args.steps:
        kept = [r for r in today if not (is_ppo_default(r) and r["spec"]["env_id"] in cells)]
        WHOLE.TABLE50.VERDICT.print_steps(kept + drift, "50 seeds, the drift arm where it finished")
        return
    print(f"Cells with all {SEEDS_PER_CELL} seeds of the drift arm: {len(cells)} of {PPO_CELLS} "
          f"({', '.join(cells) or 'none'}).\n")  # fmt: skip
    if not drift:
        return
    against_default = paired(drift, today, args.metric, label)
    done = set(cells)
    kept = [r for r in today if not (is_ppo_default(r) and r["spec"]["env_id"] in done)]
    table = POOL30.mlp_rows(kept + drift, args.metric)
    print(f"## Issue 13's table with the drift arm where it finished (the table's rule, "
          f"family-wise at 42), {label}\n")  # fmt: skip
    POOL30.print_table(table, label)
    print(f"\n## Issue 13's table with 0.35.0's default (`results/mcc_refresh`), {label}\n")
    before = POOL30.mlp_rows(today, args.metric)
    POOL30.print_table(before, label)
    if args.plot:
        sets = {"0.35 − MLP": before, "drift − MLP": table, "drift − default": against_default}
        plot(sets, label, args.plot)
    if args.metric == "final_return":
        print("\n## The registered rule\n")
        adopted = "adopt `drift_forgetting=12.6` as PPO's default"
        kept_text = "PPO's default keeps `drift_forgetting=0`"
        print(registered_decision(rules(table, len(cells) == PPO_CELLS), kept_text, adopted))


if __name__ == "__main__":
    main()
