"""The readings of this folder's studies (session 77)::

    python results/fit_spacing/read.py > results/fit_spacing/read.md
    python results/fit_spacing/read.py --registered > results/fit_spacing/registered.md
    python results/fit_spacing/read.py --auc > results/fit_spacing/auc.md
    python results/fit_spacing/read.py --steps > results/fit_spacing/steps.md
    python results/fit_spacing/read.py --curves docs/verdict_table/curves.png

1. ``PLAN.md``'s screen (exploratory): spaced − 0.37's default per cell, paired by seed and as
   the comparison reads it (``results/drift_floor/read.py``'s table), the seed-983 check of
   Pendulum-v1 and Acrobot-v1 (expected identical, PLAN.md; Acrobot-v1's was not), the GP
   critic's share of the training time.
2. ``PREREGISTRATION.md``'s rule (``--registered``): issue 13's table with the spaced arm's
   runs (``table/``) in place of 0.37's default in the seven PPO cells, spaced − 0.37's
   default paired by seed, then the critic-fit score on CartPole-v1 and Acrobot-v1
   (secondary). A cell whose 50 seeds have not all finished stays out, and a rule it decides
   stays partial.
3. Secondary readings of the adopted default (0.39, session 78), defined after the decision:
   issue 13's table on the area under the curve (``--auc``) and the steps to the threshold
   (``--steps``, as ``results/table50/read.py --steps`` reads them), the spaced arm's runs in
   the seven PPO cells.
4. ``--curves PNG`` (session 80, docs/results.md's Bottom line): the table's learning curves,
   a panel per cell, each titled with its final-return difference and verdicts.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import difference_title, plot_cell_curves, sweep_cells
from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
FLOOR = load_script(RESULTS / "drift_floor" / "read.py", "drift_floor")
DRIFT = load_script(RESULTS / "drift_forgetting" / "read.py", "drift_forgetting")
TABLE = load_script(RESULTS / "drift_table" / "read.py", "drift_table")
POOL30 = TABLE.POOL30
LABELS = TABLE.WHOLE.LABELS
#: 0.37's table's count of cells better than SB3's MLP critic family-wise (rule 2)
FW_BETTER_TODAY = 10
#: The arms the registered reading compares: the change and the default it is read against.
NAMES = ("spaced", "0.37's default")
#: The table's PPO cells, in the screen's order (the last three: PLAN.md's addendum).
CELLS = (
    "CartPole-v1",
    "MountainCarContinuous-v0",
    "sb3_geogp/WallMaze-v0",
    "sb3_geogp/WallMazeDiscrete-v0",
    "Acrobot-v1",
    "Pendulum-v1",
    "sb3_geogp/PaperPendulum-v0",
)


def check() -> None:
    """Whether each check run's evaluations and critic accuracy probes are the default's."""
    print("## The check: PLAN.md expected the same runs (seed 983)\n")
    default, spaced = (load_results(HERE / f"check_{arm}") for arm in ("default", "spaced"))
    by_env = {r["spec"]["env_id"]: r for r in default}
    for run in spaced:
        env = run["spec"]["env_id"]
        same = all(run[k] == by_env[env][k] for k in ("eval", "critic_accuracy"))
        print(f"- {env}: {'identical' if same else 'DIFFERENT'}")
    print()


def screen() -> None:
    print("## The screen (PLAN.md, exploratory): fit_spacing=4096 − 0.37's default\n")
    print("Paired by seed; in brackets below each, the comparison's interval (groups resampled")
    print("separately, `report/vs_baseline.json`; one cell per sweep, so its bold verdicts are")
    print("at 95 %).\n")
    FLOOR.screen_table(HERE, CELLS, "spaced")
    check()
    arms = {
        arm: [f"{arm}_{env.removeprefix('sb3_geogp/')}" for env in CELLS]
        for arm in ("default", "spaced")
    }
    DRIFT.critic_share(HERE, arms, "each arm's sweeps one after the other, same seeds")


def table_today() -> list[dict[str, Any]]:
    """Issue 13's table with 0.37's default: ``results/drift_table``'s runs in every PPO cell."""
    published = TABLE.WHOLE.TABLE50.published_and_fresh()
    today = TABLE.REFRESH.table_runs(published, TABLE.REFRESH.fresh_runs())
    return [r for r in today if not TABLE.is_ppo_default(r)] + TABLE.drift_runs()


def against_default(
    spaced: list[dict[str, Any]],
    today: list[dict[str, Any]],
    metric: str,
    names: tuple[str, str] = NAMES,
) -> dict[str, str]:
    """Print spaced − the default (``today``'s PPO GP critic; ``names``: the two arms' names)
    by cell on ``metric``, paired by seed (per-seed differences, 95 % percentile bootstrap,
    family-wise over the seven PPO cells), beside the comparison's unpaired interval on the
    same seeds; return each cell's family-wise verdict."""
    default = [r for r in today if TABLE.is_ppo_default(r)]
    fw_level = 1 - 0.05 / len(CELLS)
    print(f"## {names[0]} − {names[1]}, {LABELS[metric]}, paired by seed\n")
    print("| env | seeds | paired, 95 % | paired, family-wise over 7 | unpaired (the table's "
          "`comparisons`) |")  # fmt: skip
    print("|---|---:|---|---|---|")
    verdicts = {}
    for env in sorted({r["spec"]["env_id"] for r in spaced}):
        runs = [r for r in spaced if r["spec"]["env_id"] == env]
        base = [r for r in default if r["spec"]["env_id"] == env]
        cells = [FLOOR.paired_difference(runs, base, metric, lv) for lv in (0.95, fw_level)]
        verdicts[env] = cells[1][3]
        unpaired = POOL30.against_baseline(runs, base, metric, len(CELLS))[(env, "ppo")]
        texts = [f"{d:+.3g} [{lo:+.3g}, {hi:+.3g}] {w}" for d, lo, hi, w in cells]
        texts.append(f"{unpaired['diff']:+.3g} [{unpaired['low']:+.3g}, {unpaired['high']:+.3g}]")
        print(f"| {env} | {len(runs)} | " + " | ".join(texts) + " |")
    print()
    return verdicts


def rules(
    table: dict[tuple[str, str], dict[str, Any]],
    harms: dict[str, dict[str, str]],
    complete: bool,
    names: tuple[str, str] = NAMES,
) -> list[tuple[str, str]]:
    """PREREGISTRATION.md's three rules on the table with the spaced arm and its differences
    to the default (``harms``, by metric; ``names``: the two arms' names)."""
    fw_worse = [env for (env, _), c in table.items() if c["fw_verdict"] == "worse"]
    fw_better = sum(c["fw_verdict"] == "better" for c in table.values())
    harmed = [f"{env} {LABELS[m]}" for m, cells in harms.items()
              for env, word in cells.items() if word == "worse"]  # fmt: skip
    states = [
        ("1. no cell worse than SB3's MLP critic family-wise", TABLE.WHOLE._holds(fw_worse)),
        (
            f"2. at least {FW_BETTER_TODAY} cells better family-wise",
            "holds" if fw_better >= FW_BETTER_TODAY else f"fails ({fw_better})",
        ),
        (f"3. {names[0]} no worse than {names[1]} family-wise", TABLE.WHOLE._holds(harmed)),
    ]
    if complete:
        return states
    # On part of the cells a cell found worse is final (rules 1 and 3); a count (rule 2) and a
    # rule that holds so far wait for every cell.
    final = ("1.", "3.")
    return [(t, st if st != "holds" and t.startswith(final) else PARTIAL) for t, st in states]


def table_rules(
    today: list[dict[str, Any]], arm: list[dict[str, Any]], names: tuple[str, str] = NAMES
) -> list[tuple[str, str]] | None:
    """Print ``arm`` (the change's runs of the cells where all 50 seeds finished) − the default
    (``today``'s PPO GP critic) by cell, and issue 13's table ``today`` with ``arm``'s runs in
    place of the default's; return the three rules' states (None: no cell finished)."""
    cells = sorted({r["spec"]["env_id"] for r in arm})
    print(f"Cells with all {TABLE.SEEDS_PER_CELL} seeds of the {names[0]} arm: {len(cells)} of "
          f"{len(CELLS)} ({', '.join(cells) or 'none'}).\n")  # fmt: skip
    if not arm:
        return None
    harms = {m: against_default(arm, today, m, names) for m in LABELS}
    kept = [r for r in today if not (TABLE.is_ppo_default(r) and r["spec"]["env_id"] in cells)]
    table = POOL30.mlp_rows(kept + arm)
    print(f"## Issue 13's table with the {names[0]} arm where it finished (the table's rule, "
          "family-wise at 42), final return\n")  # fmt: skip
    POOL30.print_table(table)
    return rules(table, harms, len(cells) == len(CELLS), names)


def registered() -> None:
    states = table_rules(table_today(), TABLE.drift_runs(HERE / "table"))
    if states is None:
        return
    print("\n## The registered rule\n")
    adopted = "adopt `fit_spacing=4096` in PPO's default adaptation"
    kept_text = "the option stays an option; PPO's default is unchanged"
    print(registered_decision(states, kept_text, adopted))
    print()
    arms = ("fit_default", "fit_spaced")
    note = "no rule reads this table"
    envs = ("CartPole-v1", "Acrobot-v1")
    TABLE.WHOLE.fit_table(HERE, range(10), envs, note, arms, ("default", "spaced"))


def today_spaced() -> list[dict[str, Any]]:
    """Issue 13's table with the spaced arm's runs (0.39's default) in every PPO cell."""
    today = [r for r in table_today() if not TABLE.is_ppo_default(r)]
    return today + TABLE.drift_runs(HERE / "table")


def curves(path: str) -> None:
    """Issue 13's table with 0.39's default as learning curves: PPO's cells above A2C's."""
    runs = today_spaced()
    titles = {cell: difference_title(c) for cell, c in POOL30.mlp_rows(runs).items()}
    plot_cell_curves(runs, path, sweep_cells(runs, ("ppo", "a2c")), titles)  # PPO first


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    reading = parser.add_mutually_exclusive_group()
    reading.add_argument("--registered", action="store_true", help="PREREGISTRATION.md's rule")
    reading.add_argument("--auc", action="store_true", help="the table on the area under the curve")
    reading.add_argument("--steps", action="store_true", help="steps to the threshold")
    reading.add_argument("--curves", metavar="PNG", help="the table's learning curves")
    args = parser.parse_args()
    if args.registered:
        registered()
    elif args.auc:
        label = LABELS["mean_return"]
        print(f"## Issue 13's table with 0.39's default (the spaced arm), {label}\n")
        POOL30.print_table(POOL30.mlp_rows(today_spaced(), "mean_return"), label)
    elif args.curves:
        curves(args.curves)
    elif args.steps:
        TABLE.WHOLE.TABLE50.VERDICT.print_steps(today_spaced(), "50 seeds, 0.39's default")
    else:
        screen()


if __name__ == "__main__":
    main()
