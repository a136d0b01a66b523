"""Monte Carlo targets under PPO on issue 13's 40 seeds, read as ``PREREGISTRATION.md`` fixes
(session 41: a screen, then the adoption test of its addendum 1).

C: PPO's default GP critic fed ``GPValueCallback(target="monte_carlo")`` (here: ``s0``,
``s10``, ``s150``, ``s160``, Acrobot and CartPole, the screen; ``rest_s*``, the five other PPO
cells, the adoption test of addendum 1). A: the default's runs of the 40-seed table, and SB3's
MLP critic's (``results/table40_prior/table.py``'s arms). Final return (or ``--metric
mean_return``, the area under the curve), difference of means, 95 % percentile bootstrap;
C − MLP family-wise at the published 42 comparisons, C − A over the cells run. Only seeds that
C, A and the MLP all have are compared, so a partial sweep reads on its finished seeds.

    python results/ppo_mc_targets/table.py --plot results/ppo_mc_targets/table.png \
        > results/ppo_mc_targets/table.md
    python results/ppo_mc_targets/table.py --metric mean_return > results/ppo_mc_targets/auc.md

``--verdict`` (session 42, after adoption as 0.24's PPO default target) prints issue 13's
verdict table with today's defaults: the PPO rows C's runs, the A2C rows 0.22's default's
(as ``results/table40_prior/table.py --verdict``), each cell against SB3's MLP critic:

    python results/ppo_mc_targets/table.py --verdict > results/ppo_mc_targets/verdict.md
    python results/ppo_mc_targets/table.py --verdict --metric mean_return \
        > results/ppo_mc_targets/verdict_auc.md

``table.md``, ``auc.md`` and ``table.png`` were written by these commands before any
``rest_s*`` folder existed (the screen's two cells); ``table_partial.md``, ``auc_partial.md``
and ``table_partial.png`` by the same commands with ``_partial`` names once ``rest_s0``,
``rest_s10`` and ``rest_s150`` had finished (session 41). With all four blocks the adoption
test is read into ``adoption.md`` / ``adoption_auc.md`` / ``adoption.png``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "replication_0_15"))
from pool30 import against_baseline, mlp_rows, print_table  # noqa: E402

from sb3_geogp.comparison.report import plot_difference_panels  # noqa: E402
from sb3_geogp.comparison.results import pool_sweeps  # noqa: E402
from sb3_geogp.toolbox.scripts import load_script  # noqa: E402

FIRST_SEEDS = (0, 10, 150, 160)
LABELS = {"final_return": "final return", "mean_return": "area under the curve"}
#: Acrobot-v1's evaluation return of a policy that never reaches the goal (500 steps at -1).
CAP = -500.0


#: ``results/table40_prior/table.py``: the default's and the MLP critic's runs, and the reading.
TABLE40 = load_script(HERE.parent / "table40_prior" / "table.py", "table40_prior")


def arms() -> tuple[list[dict[str, Any]], ...]:
    """C, A and the MLP critic's runs of the cells C has, each on the seeds all three have."""
    folders = [HERE / f"{p}s{f}" for p in ("", "rest_") for f in FIRST_SEEDS]
    mc = pool_sweeps([folder for folder in folders if folder.is_dir()])
    # table40_prior's B arm (prior_sd=0.1) is 0.23's default; its A arm is 0.22's.
    default, _, mlp = TABLE40.arms()
    return TABLE40.on_common_seeds(mc, default, mlp)


def stalls(runs: list[dict[str, Any]]) -> str:
    """Acrobot runs whose final evaluation return is at the cap, as "k of n"."""
    acrobot = [r for r in runs if r["spec"]["env_id"] == "Acrobot-v1"]
    return f"{sum(r['final_return'] <= CAP for r in acrobot)} of {len(acrobot)}"


def report(
    mc: list[dict[str, Any]],
    default: list[dict[str, Any]],
    mlp: list[dict[str, Any]],
    metric: str,
    c_a_family: int,
    plot: str | None,
    a_name: str = "the default",
) -> None:
    """Print C − MLP (family-wise at the published 42), A − MLP and C − A (family-wise over
    ``c_a_family`` cells) per cell of ``mc``, and the Acrobot runs at the cap; draw the three
    differences per cell to ``plot``."""
    label = LABELS[metric]
    cells = {(r["spec"]["env_id"], "ppo") for r in mc}
    sets = {
        "C − MLP": mlp_rows(mc + mlp, metric),
        "A − MLP": {k: v for k, v in mlp_rows(default + mlp, metric).items() if k in cells},
        "C − A": against_baseline(mc, default, metric, c_a_family),
    }
    for name, rows in sets.items():
        print(f"\n### {name} (C: Monte Carlo targets; A: {a_name})\n")
        print_table(rows, label, name)
    print(f"\nAcrobot runs at the -500 cap: C {stalls(mc)}, A {stalls(default)}, MLP {stalls(mlp)}")
    if plot:
        panels = [{"env": e, "algo": a, **{k: t.get((e, a)) for k, t in sets.items()}}
                  for e, a in sorted(cells)]  # fmt: skip
        counts = [c["n_a"] for c in sets["C − MLP"].values()]
        low, high = min(counts), max(counts)
        seeds = f"{low}" if low == high else f"{low}-{high}"
        title = f"PPO ({seeds} seeds a cell): Monte Carlo targets (C), {a_name} (A), {label}"
        plot_difference_panels(panels, list(sets), plot, title, n_cols=len(cells),
                               panel_size=(2.6, 2.4))  # fmt: skip


def main() -> None:
    args = TABLE40.reading_parser(__doc__, "C").parse_args()
    mc, default, mlp = arms()
    if args.verdict:
        print_table(
            mlp_rows(mc + mlp + TABLE40.a2c_runs(), args.metric),
            LABELS[args.metric],
        )
        return
    n_cells = len({r["spec"]["env_id"] for r in mc})
    report(mc, default, mlp, args.metric, n_cells, args.plot)


if __name__ == "__main__":
    main()
