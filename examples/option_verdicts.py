"""A GP critic option against the default GP critic and against the MLP critic, per cell.

A sweep of one GP critic with an option (``--variant``, e.g. ``sb3-geogp compare ...
--gp-option prior_mean=linear``) next to a sweep of the same critic without it and of SB3's MLP
critic on the same seeds (``--reference``). Per cell (environment, algorithm) and metric, with
the published rule (:func:`~sb3_geogp.comparison.results.comparisons`: difference of means,
95 % percentile-bootstrap interval, family-wise level of the published sweep's 42
comparisons): variant − reference GP critic, variant − MLP, reference − MLP; and the final
returns of every run, sorted, so that stalls (e.g. Acrobot's -500 cap) are seen one by one.

    python examples/option_verdicts.py --critic laplacian --label prior_mean=linear \\
        --variant results/linear_mean/acrobot_s30_linear \\
        --reference results/linear_mean/acrobot_s30 --out results/linear_mean/acrobot_s30.md

``--variant-critic`` names the variant's critic where the option is another kernel (e.g. the
variant ``rbf`` against the reference ``geodesic``): its runs are then compared as if they were
runs of ``--critic``.

``--seeds`` reads only the runs of some seeds, e.g. a sweep of seeds 0-19 against references
of seeds 0-9 (``--seeds 0 1 2 3 4 5 6 7 8 9``) and, in a second call, of seeds 10-19.
``--pool`` reads folders of different seeds of the same cells as one sweep of all their seeds
(:func:`~sb3_geogp.comparison.results.pool_sweeps`; without it a cell is taken whole from the
last folder that has it, as a re-run replaces a sweep's cell) and compares each cell on the
seeds the variant has.

Writes the markdown, the rows as JSON beside it and a figure of the final-return intervals
(``.png``).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import (
    comparison_cell,
    count_verdicts,
    family_level,
    plot_difference_panels,
)
from sb3_geogp.comparison.results import (
    METRICS,
    PUBLISHED_FAMILY,
    comparisons,
    group_runs,
    load_sweeps,
    pool_sweeps,
)
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter
from sb3_geogp.toolbox.tables import markdown_table

#: The columns: which runs are compared with which.
COLUMNS = ("variant − reference", "variant − MLP", "reference − MLP")


def verdict_rows(
    variant: list[dict[str, Any]],
    reference: list[dict[str, Any]],
    critic: str,
    family_size: int = PUBLISHED_FAMILY,
) -> list[dict[str, Any]]:
    """Per cell and metric, the three comparisons of :data:`COLUMNS` (``None`` where a side
    has no runs).

    Raises
    ------
    ValueError
        If ``variant`` holds runs of another critic than ``critic`` (the option's sweep is of
        one GP critic), or has none.
    """
    others = {r["spec"]["critic"] for r in variant} - {critic}
    if others or not variant:
        raise ValueError(f"--variant must hold runs of {critic} only, found {sorted(others)}")
    gp = [r for r in reference if r["spec"]["critic"] == critic]
    mlp = [r for r in reference if r["spec"]["critic"] == "mlp"]
    found = {
        COLUMNS[0]: comparisons(variant, baseline=gp, family_size=family_size),
        COLUMNS[1]: comparisons(variant + mlp, family_size=family_size),
        COLUMNS[2]: comparisons(gp + mlp, family_size=family_size),
    }
    keyed = {
        column: {(r["env"], r["algo"], r["metric"]): r for r in rows if r["b"] in (critic, "mlp")}
        for column, rows in found.items()
    }
    return [
        dict(
            env=env,
            algo=algo,
            metric=metric,
            **{c: keyed[c].get((env, algo, metric)) for c in COLUMNS},
        )
        for env, algo in _cells(variant)
        for metric in METRICS
    ]


def as_critic(runs: list[dict[str, Any]], found: str, critic: str) -> list[dict[str, Any]]:
    """``runs`` of the critic ``found`` relabelled as runs of ``critic`` (copies; other critics'
    runs are left out), so that a kernel can be read as an option of another."""
    return [
        {**r, "spec": {**r["spec"], "critic": critic}} for r in runs if r["spec"]["critic"] == found
    ]


def of_variant_seeds(
    reference: list[dict[str, Any]], variant: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """The runs of ``reference`` whose cell (environment, algorithm) and seed the variant has
    a run of: pooled folders hold more seeds of some cells on one side than on the other."""
    seeds = {(s["env_id"], s["algo"], s["seed"]) for s in (r["spec"] for r in variant)}
    return [
        r for r in reference if (r["spec"]["env_id"], r["spec"]["algo"], r["spec"]["seed"]) in seeds
    ]


def _cells(runs: list[dict[str, Any]]) -> list[tuple[str, str]]:
    """The ``(environment, algorithm)`` cells of ``runs``, sorted."""
    return sorted({(r["spec"]["env_id"], r["spec"]["algo"]) for r in runs})


def finals(
    variant: list[dict[str, Any]], reference: list[dict[str, Any]], critic: str
) -> list[list[str]]:
    """Rows ``[cell, side, n, sorted final returns]`` for the variant, the reference GP critic
    and the MLP of each cell."""
    sides = {"variant": group_runs(variant), "reference": group_runs(reference)}
    rows = []
    for env, algo in _cells(variant):
        for label, groups, name in (
            ("variant", sides["variant"], critic),
            ("reference", sides["reference"], critic),
            ("MLP", sides["reference"], "mlp"),
        ):
            runs = groups.get((env, algo, name), [])
            values = sorted(r["final_return"] for r in runs)
            rows.append(
                [f"`{env}` {algo}", label, str(len(runs)), ", ".join(f"{v:.0f}" for v in values)]
            )
    return rows


def markdown(rows: list[dict[str, Any]], finals_rows: list[list[str]], label: str) -> str:
    """One table per metric (the last row counts better (family-wise) / no difference / worse
    (family-wise) per column), then the final returns of every run."""
    lines = [f"Variant: `{label}`.", ""]
    for name, metric in METRICS.items():
        mine = [r for r in rows if r["metric"] == name]
        body = [
            [f"`{r['env']}`", r["algo"], *(comparison_cell(r[c]) for c in COLUMNS)] for r in mine
        ]
        total = ["**counts**", "better (fw) / n.d. / worse (fw)"]
        total += [count_verdicts([r[c] for r in mine if r[c] is not None]) for c in COLUMNS]
        family = next(r[c]["family_size"] for r in mine for c in COLUMNS if r[c] is not None)
        lines += [
            f"### {metric.label}",
            "",
            "Difference of means [95 % bootstrap CI] and verdict; **bold**: also at the "
            f"{family_level(family)} ({family} comparisons).",
            "",
            markdown_table(["env", "algo", *COLUMNS], [*body, total]),
            "",
        ]
    lines += [
        "### final returns of every run, sorted",
        "",
        markdown_table(["cell", "critic", "runs", "final returns"], finals_rows),
        "",
    ]
    return "\n".join(lines)


def plot(rows: list[dict[str, Any]], path: Path, label: str) -> None:
    """Final return differences with 95 % intervals: one panel per cell, one bar per column."""
    mine = [r for r in rows if r["metric"] == "final_return"]
    plot_difference_panels(
        mine,
        COLUMNS,
        path,
        f"Final return differences, 95 % bootstrap intervals (variant: {label})",
        n_cols=min(len(mine), 4),
        panel_size=(3.2, 3.0),
        tick_labels=[c.replace(" − ", "\n− ") for c in COLUMNS],
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument(
        "--variant", type=Path, nargs="+", required=True, help="the option's sweeps"
    )
    parser.add_argument(
        "--reference", type=Path, nargs="+", required=True, help="the default GP and MLP runs"
    )
    parser.add_argument("--critic", required=True, help="the GP critic (kernel) of both sweeps")
    parser.add_argument(
        "--variant-critic",
        default=None,
        help="the variant's GP critic where it differs from --critic (a kernel read as an option)",
    )
    parser.add_argument("--label", required=True, help="the option, as shown in the tables")
    parser.add_argument("--family-size", type=int, default=PUBLISHED_FAMILY)
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=None,
        help="only the runs of these seeds, on both sides (a sweep of more seeds than the "
        "references hold)",
    )
    parser.add_argument(
        "--pool",
        action="store_true",
        help="folders hold different seeds of the same cells: pool them (a run of a seed in "
        "several folders taken from the last) instead of taking each cell from the last "
        "folder, and compare each cell on the seeds the variant has",
    )
    parser.add_argument("--out", type=Path, required=True, help="markdown file to write")
    args = parser.parse_args(argv)
    load = pool_sweeps if args.pool else load_sweeps
    variant, reference = load(args.variant), load(args.reference)
    if args.variant_critic is not None:
        variant = as_critic(variant, args.variant_critic, args.critic)
    if args.pool:
        reference = of_variant_seeds(reference, variant)
    if args.seeds is not None:
        variant, reference = (
            [r for r in runs if r["spec"]["seed"] in args.seeds] for runs in (variant, reference)
        )
    rows = verdict_rows(variant, reference, args.critic, args.family_size)
    text = markdown(rows, finals(variant, reference, args.critic), args.label)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    args.out.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    plot(rows, args.out.with_suffix(".png"), args.label)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
