"""The default GP critic in the zoo's ``VecNormalize``: the reading of ``PLAN.md`` (session 61,
an exploratory screen on seeds 0-19)::

    python results/gp_vecnormalize/read.py > results/gp_vecnormalize/read.md
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sb3_geogp.comparison.results import comparisons, pool_sweeps
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
CONTROL = load_script(HERE.parent / "mlp_vecnormalize" / "read.py", "mlp_vecnormalize_read")
FROZEN = load_script(HERE / "frozen.py", "gp_vecnormalize_frozen")
SEEDS = set(range(20))
#: The screen's five cells (``frozen.py``'s), in the control's order: not the sixth cell the
#: control's addendum added in session 62, which the screen never ran.
_SCREENED = {(env, algo) for algo, (envs, _) in FROZEN.CELLS.items() for env in envs}
CELLS = tuple(cell for cell in CONTROL.CELLS if cell in _SCREENED)
FAMILY = len(CELLS)


#: The screen's arms: the GP critic in the zoo's ``VecNormalize``, with rewards only normalised
#: (the addendum), with the statistics frozen after 2,000 steps (the second addendum), and the
#: same with a starting lengthscale of 1 (the third).
ARMS = {
    "VecNormalize": (HERE / "ppo", HERE / "a2c"),
    "rewards only": (HERE / "reward_only" / "ppo", HERE / "reward_only" / "a2c"),
    "frozen after 2,000 steps": (HERE / "frozen",),
    "frozen, lengthscale 1": (HERE / "frozen_unit_lengthscale",),
}


def on_seeds(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [r for r in runs if r["spec"]["seed"] in SEEDS]


def arms() -> dict[str, list[dict[str, Any]]]:
    """The screen's arms that have runs, and on the same seeds the MLP critic in
    ``VecNormalize`` and the GP critic without it (the registered control's runs)."""
    gp, _, mlp_normalised = CONTROL.arms()
    out = {"GP": on_seeds(gp), "MLP in VecNormalize": on_seeds(mlp_normalised)}
    for name, folders in ARMS.items():
        present = [f for f in folders if (f / "runs").is_dir()]
        if present:
            runs = pool_sweeps(present)
            assert all(r["spec"].get("normalize") is True for r in runs)
            out[f"GP, {name}"] = runs
    return out


def main() -> None:
    runs = arms()
    mlp_normalised, gp = runs["MLP in VecNormalize"], runs["GP"]
    screened = [name for name in runs if name.startswith("GP, ")]
    print("# The default GP critic in the zoo's VecNormalize: exploratory screen, seeds 0-19\n")
    for name in screened:
        for metric in ("final_return", "mean_return"):
            label = CONTROL.LABELS[metric]
            against_mlp = {
                (c["env"], c["algo"]): c
                for c in comparisons(runs[name] + mlp_normalised, family_size=FAMILY)
                if c["metric"] == metric and c["b"] == "mlp"
            }
            print(f"## {name} − MLP in VecNormalize, {label}\n")
            CONTROL.POOL30.print_table(against_mlp, label)
            print(f"\n## {name} − GP without VecNormalize, {label}\n")
            against_gp = CONTROL.POOL30.against_baseline(runs[name], gp, metric, family=FAMILY)
            CONTROL.POOL30.print_table(against_gp, label, "with − without")
            print()
    print("## Final return and critic RMSE against Monte Carlo returns (means over seeds)\n")
    print("| env | algo | " + " | ".join(runs) + " |")
    print("|---|---|" + "---:|" * len(runs))
    returns = {n: CONTROL.cell_means(arm, lambda r: r["final_return"]) for n, arm in runs.items()}
    rmse = {name: CONTROL.critic_rmse(arm) for name, arm in runs.items()}
    for cell in CELLS:
        shown = [f"{returns[n].get(cell, float('nan')):.1f} / {rmse[n].get(cell, float('nan')):.1f}"
                 for n in runs]  # fmt: skip
        print(f"| `{cell[0]}` | {cell[1]} | " + " | ".join(shown) + " |")


if __name__ == "__main__":
    main()
