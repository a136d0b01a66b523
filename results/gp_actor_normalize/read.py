"""The GP critic with its actor's observations normalised against SB3's MLP critic in the zoo's
``VecNormalize``: the registered reading of ``PREREGISTRATION.md`` (session 62).

This folder's runs (``run.sh``: ``sb3-geogp compare --gp-actor-normalize``) against session
61's MLP runs in ``VecNormalize`` (``results/mlp_vecnormalize``) and issue 13's 50-seed table
(``results/table50``), on the same seeds. Only cells with all 50 runs of each arm are read::

    python results/gp_actor_normalize/read.py --plot results/gp_actor_normalize/read.png \\
        > results/gp_actor_normalize/read.md
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
MLPV = load_script(HERE.parent / "mlp_vecnormalize" / "read.py", "mlp_vecnormalize_read")
POOL30, TABLE50 = MLPV.POOL30, MLPV.TABLE50
CELLS, LABELS = MLPV.CELLS, MLPV.LABELS
Runs = list[dict[str, Any]]
Rows = dict[tuple[str, str], dict[str, Any]]
PRIMARY = "GP, actor normalised − MLP in VecNormalize"


@functools.cache  # every reading reads the same files
def arms() -> tuple[Runs, Runs, Runs, Runs]:
    """This folder's GP runs, the table's GP and MLP runs and the MLP runs in
    ``VecNormalize``, in the cells where all four arms have their 50 seeds."""
    folders = [f for f in (HERE / "ppo", HERE / "a2c") if (f / "runs").is_dir()]
    actor = pool_sweeps(folders) if folders else []
    assert all(r["spec"].get("actor_normalize") is True for r in actor)
    gp, mlp, normalised = MLPV.arms()
    ready = {MLPV._cell(r) for r in normalised}
    whole = set()
    for cell in ready:
        seeds = sorted(r["spec"]["seed"] for r in actor if MLPV._cell(r) == cell)
        if len(seeds) == MLPV.SEEDS_PER_CELL:
            assert seeds == sorted(r["spec"]["seed"] for r in gp if MLPV._cell(r) == cell), cell
            whole.add(cell)
    return tuple([r for r in arm if MLPV._cell(r) in whole] for arm in (actor, gp, mlp, normalised))  # type: ignore[return-value]


def rerun(cells: set[tuple[str, str]]) -> Runs:
    """``ADDENDUM.md``'s runs of the default GP critic with this code, in ``cells`` where all
    50 seeds have finished (the seeds of the table's cell)."""
    folders = [f for f in (HERE / "default" / "ppo", HERE / "default" / "a2c") if f.is_dir()]
    runs = pool_sweeps(folders) if folders else []
    assert not any(r["spec"].get("actor_normalize") for r in runs)
    _, gp, _, _ = arms()
    whole = {
        cell
        for cell in cells
        if sorted(r["spec"]["seed"] for r in runs if MLPV._cell(r) == cell)
        == sorted(r["spec"]["seed"] for r in gp if MLPV._cell(r) == cell)
    }
    return [r for r in runs if MLPV._cell(r) in whole]


def addendum_readings(metric: str, default: Runs) -> dict[str, Rows]:
    """``ADDENDUM.md``'s readings, in the cells ``default`` (:func:`rerun`) covers."""
    cells = {MLPV._cell(r) for r in default}
    actor, gp, _, normalised = ([r for r in a if MLPV._cell(r) in cells] for a in arms())
    return {
        "GP, actor normalised − GP default re-run": POOL30.against_baseline(
            actor, default, metric, family=len(CELLS)
        ),
        "GP default re-run − the table's GP default": POOL30.against_baseline(
            default, gp, metric, family=len(CELLS)
        ),
        "GP default re-run − MLP in VecNormalize": POOL30.mlp_rows(default + normalised, metric),
    }


def readings(metric: str) -> dict[str, Rows]:
    """The primary reading (the table's rule and family) and the option's effect on the GP
    critic's agents (a family of the six cells)."""
    actor, gp, _, normalised = arms()
    return {
        PRIMARY: POOL30.mlp_rows(actor + normalised, metric),
        "GP, actor normalised − GP default": POOL30.against_baseline(
            actor, gp, metric, family=len(CELLS)
        ),
    }


def zoo_table(primary: Rows, metric: str) -> Rows:
    """Issue 13's 14 cells with each critic given the zoo's normalisation in the form it can
    use: the table's rows, the normalising cells' from the primary reading."""
    return {**POOL30.mlp_rows(TABLE50.published_and_fresh(), metric), **primary}


def plot(final: Rows, path: str) -> None:
    """Each cell's final-return difference: as in the table, the MLP in ``VecNormalize``, and
    the GP with its actor normalised against the latter."""
    gp, mlp, normalised = MLPV.arms()
    shown = {
        "table": POOL30.mlp_rows(gp + mlp, "final_return"),
        "MLP VecNorm": POOL30.mlp_rows(gp + normalised, "final_return"),
        "GP actor-norm": final,
    }
    title = (
        "GP critic − SB3's MLP critic, final return: the table (neither normalised), the MLP "
        "in the zoo's VecNormalize, and the GP critic with its actor's observations normalised"
    )
    MLPV.plot_cells(shown, path, title)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG", help="draw each cell's final-return readings")
    args = parser.parse_args()
    actor, gp, mlp, normalised = arms()
    cells = {MLPV._cell(r) for r in actor}
    state = MLPV.partial(cells)
    print(f"# The GP critic's actor normalised: the registered reading{state}\n")
    for metric in ("final_return", "mean_return"):
        sets = readings(metric)
        MLPV.print_readings(sets, metric, lambda name: name == PRIMARY)
        if metric == "final_return" and not state:
            print("## The 14 cells, each critic with the zoo's normalisation in its form\n")
            POOL30.print_table(zoo_table(sets[PRIMARY], metric), LABELS[metric])
            print()
            if args.plot:
                plot(sets[PRIMARY], args.plot)
    default = rerun(cells)
    if default:
        part = MLPV.partial({MLPV._cell(r) for r in default})
        print(f"# Addendum: the GP default re-run with this code{part}\n")
        for metric in ("final_return", "mean_return"):
            sets = addendum_readings(metric, default)
            MLPV.print_readings(sets, metric, lambda name: name.endswith("VecNormalize"), "a − b")
    shown = {"GP": gp, "GP, actor normalised": actor, "MLP": mlp, "MLP in VecNormalize": normalised}
    if default:
        shown["GP default re-run"] = default
    print_cell_table(
        "Final critic RMSE against Monte Carlo returns (mean over seeds; lower is better)",
        {name: MLPV.critic_rmse(arm) for name, arm in shown.items()},
        "{:.2f}",
    )
    print_cell_table(
        "Mean final return over seeds",
        {name: MLPV.cell_means(arm, final_return) for name, arm in shown.items()},
        "{:.1f}",
    )


def final_return(run: dict[str, Any]) -> float:
    return float(run["final_return"])


def print_cell_table(
    title: str, columns: dict[str, dict[tuple[str, str], float]], form: str
) -> None:
    """One row per cell of :data:`CELLS` that any column has, one column per arm."""
    print(f"## {title}\n")
    print("| env | algo | " + " | ".join(columns) + " |")
    print("|---|---|" + "---:|" * len(columns))
    for cell in CELLS:
        if any(cell in c for c in columns.values()):
            row = " | ".join(form.format(c[cell]) if cell in c else "" for c in columns.values())
            print(f"| `{cell[0]}` | {cell[1]} | {row} |")
    print()


if __name__ == "__main__":
    main()
