"""The screen of ``PLAN.md``: A2C's default GP critic with its actor's statistics frozen after a
warm-up, against the option as 0.32 has it and against no normalisation (session 63)::

    python results/actor_norm_warmup/read.py --plot results/actor_norm_warmup/read.png \\
        > results/actor_norm_warmup/read.md

Each reading compares two arms on the cells where both have all 20 seeds, by the table's rule
(difference of means, 95 % percentile bootstrap), family-wise over the screen's 3 cells.
"""

from __future__ import annotations

import argparse
import functools
import statistics
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import plot_difference_panels
from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
POOL30 = load_script(HERE.parent / "replication_0_15" / "pool30.py", "pool30")
SCREEN = load_script(HERE / "screen.py", "actor_norm_warmup_screen")
READINGS = (("actor", "default"), ("frozen", "default"), ("frozen", "actor"))
#: ``ADDENDUM.md``'s reading: the option on PaperPendulum with gSDE off.
NO_SDE = ("no_sde_actor", "no_sde_default")
LABELS = {"final_return": "final return", "mean_return": "area under the curve"}
Runs = list[dict[str, Any]]


@functools.cache  # every reading reads the same files
def arm(name: str) -> Runs:
    """The arm's runs, in the cells where all of the screen's seeds have finished."""
    runs = load_results(HERE / name)
    seeds = sorted(SCREEN.SEEDS)
    whole = {
        env
        for env in SCREEN.ENVS
        if sorted(r["spec"]["seed"] for r in runs if r["spec"]["env_id"] == env) == seeds
    }
    return [r for r in runs if r["spec"]["env_id"] in whole]


def reading(a: str, b: str, metric: str) -> dict[tuple[str, str], dict[str, Any]]:
    """``a − b`` on ``metric`` in the cells both arms have whole."""
    runs, baseline = arm(a), arm(b)
    both = {r["spec"]["env_id"] for r in runs} & {r["spec"]["env_id"] for r in baseline}
    runs, baseline = ([r for r in x if r["spec"]["env_id"] in both] for x in (runs, baseline))
    if not runs:
        return {}
    return POOL30.against_baseline(runs, baseline, metric, family=len(SCREEN.ENVS))


def file_check() -> bool:
    """Whether ``sde_a2c.yml``'s run of seed 154 equals the screen's built-in ``default`` run of
    that seed, evaluation by evaluation."""
    (checked,) = load_results(HERE / "sde_check")
    built_in = [r for r in arm("default") if r["spec"]["env_id"] == checked["spec"]["env_id"]]
    (same,) = [r for r in built_in if r["spec"]["seed"] == checked["spec"]["seed"]]
    return bool(checked["eval"] == same["eval"])


def plot(path: str) -> None:
    """Each cell's final-return difference, one point per reading."""
    sets = {f"{a} − {b}": reading(a, b, "final_return") for a, b in READINGS}
    cells = sorted({cell for rows in sets.values() for cell in rows})
    panels = [
        {"env": env, "algo": algo, **{name: rows[(env, algo)] for name, rows in sets.items()}}
        for env, algo in cells
        if all((env, algo) in rows for rows in sets.values())
    ]
    title = "A2C's default GP critic: the actor's statistics frozen after 2,000 steps, final return"
    plot_difference_panels(panels, list(sets), path, title, n_cols=3, panel_size=(3.2, 2.6))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG", help="draw each cell's final-return readings")
    args = parser.parse_args()
    print("# The actor's statistics frozen after a warm-up: the screen's reading\n")
    for metric, label in LABELS.items():
        for a, b in READINGS:
            rows = reading(a, b, metric)
            if rows:
                print(f"## {a} − {b}, {label}\n")
                POOL30.print_table(rows, label, f"{a} − {b}")
                print()
    if (HERE / NO_SDE[0]).is_dir() and (rows := reading(*NO_SDE, "final_return")):
        print("## Addendum: the option without gSDE (PaperPendulum), final return\n")
        POOL30.print_table(rows, "final return", "option − default, no gSDE")
        print(f"\nthe hyperparameter file reproduces the built-in entry: {file_check()}")
        for name in NO_SDE:
            finals = [r["final_return"] for r in arm(name)]
            spread = statistics.stdev(finals)
            print(f"\n{name}: mean final return {statistics.mean(finals):.1f} (sd {spread:.1f})")
        print()
    print("## Mean final return over seeds\n")
    print("| env | " + " | ".join(SCREEN.ARMS) + " |")
    print("|---|" + "---:|" * len(SCREEN.ARMS))
    means = {name: arm(name) for name in SCREEN.ARMS}
    for env in SCREEN.ENVS:
        cells = []
        for runs in means.values():
            finals = [r["final_return"] for r in runs if r["spec"]["env_id"] == env]
            cells.append(f"{sum(finals) / len(finals):.1f}" if finals else "")
        print(f"| `{env}` | " + " | ".join(cells) + " |")
    if args.plot:
        plot(args.plot)


if __name__ == "__main__":
    main()
