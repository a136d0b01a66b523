"""Issue 13's 30k table, PPO rows, with ``Adaptation(prior_sd=0.1)`` added to PPO's default
adaptation, read as ``PREREGISTRATION.md`` fixes (session 38).

B: the candidate's runs (``s0``, ``s10``, ``s150``, ``s160`` here). A: the default's runs of
the 40-seed table, and SB3's MLP critic's (``results/replication_0_15/pool30.py --add
ppo160``'s PPO sources). Final return (or ``--metric mean_return``, the area under the curve),
difference of means, 95 % percentile bootstrap, family-wise at the published 42 comparisons.
Only seeds that B, A and the MLP all have are compared, so a partial sweep reads on its
finished seeds (the pre-registration reads all 280 runs only).

    python results/table40_prior/table.py --plot results/table40_prior/table.png \
        > results/table40_prior/table.md
    python results/table40_prior/table.py --metric mean_return > results/table40_prior/auc.md

``--verdict`` (session 39, after adoption as 0.23's PPO default) prints issue 13's verdict
table of today's defaults: these PPO rows (B − MLP) beside the A2C rows of 0.22's default
(``results/table40_rbf/table.py``'s runs), each cell against SB3's MLP critic:

    python results/table40_prior/table.py --verdict > results/table40_prior/verdict.md
    python results/table40_prior/table.py --verdict --metric mean_return \
        > results/table40_prior/verdict_auc.md
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "replication_0_15"))
from pool30 import against_baseline, mlp_rows, pooled_runs, print_table  # noqa: E402

from sb3_geogp.comparison.report import plot_difference_panels  # noqa: E402
from sb3_geogp.comparison.results import pool_sweeps  # noqa: E402
from sb3_geogp.toolbox.scripts import load_script  # noqa: E402

FIRST_SEEDS = (0, 10, 150, 160)


def arms() -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """B, A and the MLP critic's PPO runs, each on the seeds all three have per cell."""
    table = [r for r in pooled_runs("0.22", ("ppo160",)) if r["spec"]["algo"] == "ppo"]
    prior = pool_sweeps([HERE / f"s{f}" for f in FIRST_SEEDS if (HERE / f"s{f}").is_dir()])
    default = [r for r in table if r["spec"]["critic"] == "laplacian"]
    mlp = [r for r in table if r["spec"]["critic"] == "mlp"]
    return on_common_seeds(prior, default, mlp)


def on_common_seeds(*arms: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], ...]:
    """Each arm's runs of the (env, seed) pairs that every arm has."""

    def cell_seeds(runs: list[dict[str, Any]]) -> set[tuple[str, int]]:
        return {(r["spec"]["env_id"], r["spec"]["seed"]) for r in runs}

    common = set.intersection(*(cell_seeds(runs) for runs in arms))
    return tuple(
        [r for r in runs if (r["spec"]["env_id"], r["spec"]["seed"]) in common] for runs in arms
    )


def a2c_runs() -> list[dict[str, Any]]:
    """The A2C runs of the table with 0.22's default, paired as ``table40_rbf/table.py`` pairs
    them."""
    rbf = load_script(HERE.parent / "table40_rbf" / "table.py", "table40_rbf")
    return [r for r in rbf.table_runs("0.22", False) if r["spec"]["algo"] == "a2c"]


def against_default(
    prior: list[dict[str, Any]], default: list[dict[str, Any]], metric: str
) -> dict[tuple[str, str], dict[str, Any]]:
    """B − A by (env, algo): the same critic, the default's runs as the baseline (the rule
    reads its 95 % verdict; the family-wise one is over these seven cells)."""
    return against_baseline(prior, default, metric, 7)


def reading_parser(doc: str, arm: str, verdict: bool = True) -> argparse.ArgumentParser:
    """The options of a reading of issue 13's PPO cells with a new arm ``arm`` (e.g. ``"B"``)
    against the default (A) and SB3's MLP critic: ``--metric``, ``--plot`` and, with
    ``verdict``, ``--verdict``; ``doc``'s first paragraph describes it."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--metric", choices=("final_return", "mean_return"), default="final_return")
    parser.add_argument(
        "--plot", metavar="PNG", help=f"draw each cell: A − MLP, {arm} − MLP, {arm} − A"
    )
    if verdict:
        parser.add_argument(
            "--verdict",
            action="store_true",
            help=f"today's defaults, PPO ({arm}) and A2C, against the MLP",
        )
    return parser


def main() -> None:
    args = reading_parser(__doc__, "B").parse_args()
    label = {"final_return": "final return", "mean_return": "area under the curve"}[args.metric]
    prior, default, mlp = arms()
    if args.verdict:
        print_table(mlp_rows(prior + mlp + a2c_runs(), args.metric), label)
        return
    sets = {
        "B − MLP": mlp_rows(prior + mlp, args.metric),
        "A − MLP": mlp_rows(default + mlp, args.metric),
        "B − A": against_default(prior, default, args.metric),
    }
    for name, rows in sets.items():
        print(f"\n### {name} (B: `prior_sd=0.1`; A: the default)\n")
        print_table(rows, label, name)
    if args.plot:
        cells = sorted(sets["B − MLP"])
        panels = [{"env": e, "algo": a, **{k: t.get((e, a)) for k, t in sets.items()}}
                  for e, a in cells]  # fmt: skip
        seeds = min(c["n_a"] for c in sets["B − MLP"].values())
        title = (
            f"PPO, issue 13's table ({seeds} seeds a cell): hyperprior (B), default (A), {label}"
        )
        plot_difference_panels(panels, list(sets), args.plot, title, n_cols=7,
                               panel_size=(2.2, 2.4))  # fmt: skip


if __name__ == "__main__":
    main()
