"""The registered reading of ``PLAN.md`` (session 80): the default GP critic against SB3's
MLP critic on four cells it was never tuned on::

    python results/heldout/read.py > results/heldout/read.md
    python results/heldout/read.py --curves results/heldout/curves.png

Per cell: final evaluation return, GP − MLP, 95 % percentile bootstrap and family-wise over
the plan's 7 comparisons (Bonferroni; the table's rule), then the area under the curve and
the steps to the threshold (secondary), the seeds that finished, and the commits the runs
executed. The PPO cells under the table's rule are the plan's addendum 2 (exploratory, after
the registered reading), read apart and drawn in ``curves_exploratory.png`` beside the
``--curves`` figure. ``--dir`` reads other folders of the same layout (a smoke run, or
``results/heldout_0_43``, whose plan's family is ``--family 2``, and ``results/heldout2``,
``--family 3``).
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import difference_title, plot_cell_curves
from sb3_geogp.comparison.results import comparisons, load_results, summary_rows

HERE = Path(__file__).resolve().parent
#: The plan's folders and what each protocol is.
PROTOCOLS = {
    "normalized": "each critic as it can best run (primary): "
    "`--mlp-normalize --gp-actor-normalize`",
    "table_rule": "the table's rule: no `VecNormalize` (LunarLander-v3's entry has none)",
}
FAMILY = 7  # PLAN.md: 3 MuJoCo cells x 2 protocols + LunarLander-v3, kept after the addendum
SEEDS = 10
LABELS = {"final_return": "final return", "mean_return": "area under the curve (mean return)"}


#: Runs, or comparison rows, by protocol
Rows = dict[str, list[dict[str, Any]]]
#: (protocol, algo) of the plan's addendum 2: exploratory cells
EXPLORATORY = {("table_rule", "ppo")}


def protocol_runs(root: Path, exploratory: bool = False) -> Rows:
    """The runs of each protocol's folder that exists under ``root``: the registered ones, or
    (``exploratory``) those of :data:`EXPLORATORY`."""
    runs = {p: load_results(root / p) for p in PROTOCOLS if (root / p / "runs").is_dir()}
    chosen = {
        p: [r for r in rs if ((p, r["spec"]["algo"]) in EXPLORATORY) == exploratory]
        for p, rs in runs.items()
    }
    return {p: rs for p, rs in chosen.items() if rs}


def differences(by_protocol: Rows, family: int = FAMILY) -> Rows:
    """Per protocol, GP − MLP per cell on every metric, family-wise over ``family``
    comparisons (the plan's)."""
    return {
        p: [c for c in comparisons(runs, family_size=family) if c["b"] == "mlp"]
        for p, runs in by_protocol.items()
    }


def print_differences(diffs: Rows, metric: str, family: int = FAMILY) -> None:
    """The rows of ``diffs`` (:func:`differences`, family-wise over ``family``) on ``metric``
    as a table."""
    print(f"## GP − MLP, {LABELS[metric]}\n")
    print("| algo | env | protocol | seeds GP / MLP | GP − MLP [95 %] | verdict | family-wise "
          f"interval (of {family}) | family-wise |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for protocol, rows in diffs.items():
        for c in _sorted_cells(rows, metric):
            partial = "" if min(c["n_a"], c["n_b"]) == SEEDS else " (partial)"
            print(
                f"| {c['algo']} | {c['env']} | {protocol} | {c['n_a']} / {c['n_b']}{partial} | "
                f"{c['diff']:+.2f} [{c['low']:+.2f}, {c['high']:+.2f}] | {c['verdict']} | "
                f"[{c['fw_low']:+.2f}, {c['fw_high']:+.2f}] | {c['fw_verdict']} |"
            )
    print()


def print_summary(by_protocol: Rows) -> None:
    print("## Each critic's final return and steps to the threshold\n")
    print("| algo | env | protocol | critic | seeds | final return [95 %] | threshold | "
          "reached | median steps to it |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for protocol, runs in by_protocol.items():
        for r in sorted(summary_rows(runs), key=lambda r: (r["algo"], r["env"], r["critic"])):
            steps = r["steps_to_threshold_median"]
            median = "never" if steps is None else f"{steps:,.0f}"
            print(
                f"| {r['algo']} | {r['env']} | {protocol} | {r['critic']} | {r['n_seeds']} | "
                f"{r['final_mean']:.2f} [{r['final_low']:.2f}, {r['final_high']:.2f}] | "
                f"{r['threshold']:g} | {r['reached']}/{r['n_seeds']} | {median} |"
            )
    print()


def print_provenance(by_protocol: Rows) -> None:
    print("## What the runs executed\n")
    for protocol, runs in by_protocol.items():
        cells = Counter(
            (r["spec"]["algo"], r["spec"]["env_id"], r["provenance"]["git_commit"][:8],
             r["provenance"]["git_dirty"])
            for r in runs
        )  # fmt: skip
        for (algo, env, commit, dirty), n in sorted(cells.items()):
            print(f"- {protocol}, {algo} {env}: {n} runs at commit {commit} "
                  f"(uncommitted changes: {dirty})")  # fmt: skip
    print()


def _sorted_cells(rows: list[dict[str, Any]], metric: str) -> list[dict[str, Any]]:
    return sorted((c for c in rows if c["metric"] == metric), key=lambda c: (c["algo"], c["env"]))


def curves(by_protocol: Rows, path: str) -> None:
    """Both protocols' learning curves, a panel per cell, titled with its final-return row."""
    runs = [r for rs in by_protocol.values() for r in rs]
    titles, cells = {}, []
    for protocol, rows in differences(by_protocol).items():
        for c in _sorted_cells(rows, "final_return"):
            cells.append((c["env"], c["algo"]))
            titles[cells[-1]] = f"{protocol}\n{difference_title(c)}"
    plot_cell_curves(runs, path, cells, titles, n_cols=min(4, len(cells)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--curves", metavar="PNG", help="draw the learning curves")
    parser.add_argument("--dir", type=Path, default=HERE, help="folder holding the protocols")
    parser.add_argument("--family", type=int, default=FAMILY, help="comparisons family-wise")
    args = parser.parse_args()
    by_protocol = protocol_runs(args.dir)
    explored = protocol_runs(args.dir, exploratory=True)
    if args.curves:
        curves(by_protocol, args.curves)
        if explored:
            curves(explored, str(Path(args.curves).with_name("curves_exploratory.png")))
        return
    print("# Held-out cells: the registered reading (PLAN.md)\n")
    for name, text in PROTOCOLS.items():
        print(f"- `{name}`: {text}")
    print()
    diffs = differences(by_protocol, args.family)
    for metric in LABELS:
        print_differences(diffs, metric, args.family)
    print_summary(by_protocol)
    print_provenance(by_protocol)
    if explored:
        print("# Addendum 2 (exploratory, decided after the reading above): the table's rule\n")
        print_differences(differences(explored, args.family), "final_return", args.family)
        print_summary(explored)
        print_provenance(explored)


if __name__ == "__main__":
    main()
