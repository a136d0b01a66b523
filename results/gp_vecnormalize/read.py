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
SEEDS = set(range(20))
FAMILY = len(CONTROL.CELLS)


def arms() -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """The GP critic in ``VecNormalize`` (this folder), and on the same seeds the MLP critic in
    ``VecNormalize`` and the GP critic without it (the registered control's runs)."""
    gp_normalised = pool_sweeps([HERE / "ppo", HERE / "a2c"])
    assert all(r["spec"].get("normalize") is True for r in gp_normalised)
    gp, _, mlp_normalised = CONTROL.arms()

    def on_seeds(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [r for r in runs if r["spec"]["seed"] in SEEDS]

    return gp_normalised, on_seeds(mlp_normalised), on_seeds(gp)


def main() -> None:
    gp_normalised, mlp_normalised, gp = arms()
    print("# The default GP critic in the zoo's VecNormalize: exploratory screen, seeds 0-19\n")
    for metric in ("final_return", "mean_return"):
        label = CONTROL.LABELS[metric]
        against_mlp = {
            (c["env"], c["algo"]): c
            for c in comparisons(gp_normalised + mlp_normalised, family_size=FAMILY)
            if c["metric"] == metric and c["b"] == "mlp"
        }
        print(f"## GP in VecNormalize − MLP in VecNormalize, {label}\n")
        CONTROL.POOL30.print_table(against_mlp, label)
        print(f"\n## GP in VecNormalize − GP without it, {label}\n")
        against_gp = CONTROL.POOL30.against_baseline(gp_normalised, gp, metric, family=FAMILY)
        CONTROL.POOL30.print_table(against_gp, label, "with − without")
        print()
    print("## Final critic RMSE against Monte Carlo returns (mean over seeds)\n")
    print("| env | algo | GP | GP in VecNormalize | MLP in VecNormalize |")
    print("|---|---|---:|---:|---:|")
    columns = [CONTROL.critic_rmse(arm) for arm in (gp, gp_normalised, mlp_normalised)]
    for cell in CONTROL.CELLS:
        rmse = " | ".join(f"{c[cell]:.2f}" for c in columns)
        print(f"| `{cell[0]}` | {cell[1]} | {rmse} |")


if __name__ == "__main__":
    main()
