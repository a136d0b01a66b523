"""The default critic against the MLP on fresh seeds, next to the seeds it was chosen on.

Every default of the GP critic was chosen on the comparison's seeds 0-9. This script puts the
verdicts of those seeds (``--before``) next to the verdicts of a replication on seeds that no
choice saw (``--fresh``), each critic of ``--critic`` (the default per algorithm) against SB3's
MLP critic, under the published rule (:func:`~sb3_geogp.comparison.results.comparisons`:
difference of means, 95 % percentile-bootstrap interval, family-wise level of the published
sweep's 42 comparisons), plus both sets of seeds pooled. The final return's verdicts are read
by the rule fixed before the replication (results/replication_s10/PREREGISTRATION.md):

* a verdict of better or worse *replicates* when the fresh difference has its sign and a 95 %
  interval that excludes 0, is *not confirmed* when the fresh interval includes 0, and is
  *contradicted* when it excludes 0 on the other side;
* "no difference" *stays* when the fresh interval includes 0, otherwise the fresh verdict is
  *new*.

    python examples/replication_verdicts.py \\
        --before results/compare results/pilot_laplacian/A results/pilot_laplacian/A_rest \\
            results/replication_s10/a2c_s0_9 \\
        --fresh results/replication_s10/ppo results/replication_s10/a2c \\
        --critic ppo=laplacian a2c=geodesic --out results/replication_s10/verdicts.md

Writes the markdown (one table per metric, the counts of each column), the rows as JSON beside
it, and a figure of the final-return intervals (``.png``).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.hyperparams import ALGOS, ALL_CRITICS
from sb3_geogp.comparison.report import (
    comparison_cell,
    count_verdicts,
    family_level,
    plot_difference_panels,
)
from sb3_geogp.comparison.results import METRICS, PUBLISHED_FAMILY, comparisons, load_sweeps
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter
from sb3_geogp.toolbox.tables import markdown_table

SIDES = ("before", "fresh", "pooled")


def critic_choice(text: str) -> tuple[str, str]:
    """``ALGO=CRITIC`` as ``(algo, critic)``."""
    algo, sep, critic = text.partition("=")
    if not sep or algo not in ALGOS or critic not in ALL_CRITICS or critic == "mlp":
        raise argparse.ArgumentTypeError(
            f"expected ALGO=CRITIC, ALGO one of {sorted(ALGOS)}, CRITIC a GP critic of "
            f"{ALL_CRITICS}, got {text!r}"
        )
    return algo, critic


def selected(results: list[dict[str, Any]], critics: dict[str, str]) -> list[dict[str, Any]]:
    """The runs of ``critics[algo]`` and of the MLP, of the algorithms of ``critics``."""
    wanted = {(algo, critic) for algo, gp in critics.items() for critic in ("mlp", gp)}
    return [r for r in results if (r["spec"]["algo"], r["spec"]["critic"]) in wanted]


def _run_key(r: dict[str, Any]) -> tuple[str, str, str, int]:
    spec = r["spec"]
    return spec["algo"], spec["critic"], spec["env_id"], int(spec["seed"])


def replication(before: dict[str, Any], fresh: dict[str, Any]) -> str:
    """The pre-registered reading of a cell (module docstring), from its 95 % verdicts."""
    old, new = before["verdict"], fresh["verdict"]
    if old == "no difference":
        return "stays no difference" if new == "no difference" else f"new: {new}"
    if new == old:
        return "replicates"
    return "not confirmed" if new == "no difference" else "contradicted"


def verdict_rows(
    before: list[dict[str, Any]],
    fresh: list[dict[str, Any]],
    family_size: int = PUBLISHED_FAMILY,
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Per cell and metric, the default − MLP comparison on each side and the reading.

    Raises
    ------
    ValueError
        If a run (algorithm, critic, environment, seed) is on both sides: the pooled column
        would count it twice.
    """
    shared = {_run_key(r) for r in before} & {_run_key(r) for r in fresh}
    if shared:
        raise ValueError(f"{len(shared)} runs are on both sides, e.g. {sorted(shared)[0]}")
    sides = {"before": before, "fresh": fresh, "pooled": before + fresh}
    found = {
        side: {
            (r["env"], r["algo"], r["metric"]): r
            for r in comparisons(runs, seed=seed, family_size=family_size)
            if r["b"] == "mlp"
        }
        for side, runs in sides.items()
    }
    rows = []
    for key in sorted(found["fresh"]):
        env_id, algo, metric = key
        row: dict[str, Any] = dict(env=env_id, algo=algo, metric=metric)
        row.update({side: found[side].get(key) for side in SIDES})
        row["critic"] = row["fresh"]["a"]
        if row["before"] is not None:
            row["reading"] = replication(row["before"], row["fresh"])
        rows.append(row)
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    """One table per metric; the last row of each counts better (family-wise) / no difference
    / worse (family-wise) per column."""
    lines: list[str] = []
    for name, metric in METRICS.items():
        mine = [r for r in rows if r["metric"] == name]
        if not mine:
            continue
        fw, family = mine[0]["fresh"]["fw_level"], mine[0]["fresh"]["family_size"]
        seeds = {side: _seeds(mine, side) for side in SIDES}
        header = ["env", "algo", "critic − MLP"]
        header += [f"{side}, seeds {seeds[side]}" for side in SIDES]
        header += ["reading (fixed before)"] if name == "final_return" else []
        body = []
        for r in mine:
            cells = [f"`{r['env']}`", r["algo"], r["critic"]]
            cells += [comparison_cell(r[side]) for side in SIDES]
            cells += [r.get("reading", "–")] if name == "final_return" else []
            body.append(cells)
        total = ["**counts**", "", "better (fw) / n.d. / worse (fw)"]
        total += [count_verdicts([r[side] for r in mine if r[side] is not None]) for side in SIDES]
        total += [""] if name == "final_return" else []
        lines += [
            f"### {metric.label}",
            "",
            f"Difference of means [95 % bootstrap CI] and verdict; **bold**: also at the "
            f"{family_level(family)} ({100 * fw:.3g} % intervals, {family} comparisons).",
            "",
            markdown_table(header, [*body, total]),
            "",
        ]
    return "\n".join(lines)


def _seeds(rows: list[dict[str, Any]], side: str) -> str:
    """The seed counts of a side, e.g. ``"10"`` or ``"9-10"``."""
    counts = sorted(
        {n for r in rows if r[side] is not None for n in (r[side]["n_a"], r[side]["n_b"])}
    )
    if not counts:
        return "–"
    return "n=" + (str(counts[0]) if counts[0] == counts[-1] else f"{counts[0]}-{counts[-1]}")


def plot(rows: list[dict[str, Any]], path: Path) -> None:
    """Final return, critic − MLP, with 95 % intervals: one panel per cell, one bar per side."""
    plot_difference_panels(
        [r for r in rows if r["metric"] == "final_return"],
        SIDES,
        path,
        "Final return, default GP critic − MLP critic, 95 % bootstrap intervals "
        "(before: seeds the defaults were chosen on; fresh: new seeds)",
        n_cols=7,
        panel_size=(2.3, 2.6),
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--before", type=Path, nargs="+", required=True, help="seeds 0-9's sweeps")
    parser.add_argument("--fresh", type=Path, nargs="+", required=True, help="the replication")
    parser.add_argument(
        "--critic",
        type=critic_choice,
        nargs="+",
        required=True,
        metavar="ALGO=CRITIC",
        help="the GP critic compared with the MLP under each algorithm",
    )
    parser.add_argument("--family-size", type=int, default=PUBLISHED_FAMILY)
    parser.add_argument("--out", type=Path, required=True, help="markdown file to write")
    args = parser.parse_args(argv)
    critics = dict(args.critic)
    fresh = selected(load_sweeps(args.fresh), critics)
    if not fresh:
        raise SystemExit(f"no runs of {critics} or the MLP in {[str(d) for d in args.fresh]}")
    before = selected(load_sweeps(args.before), critics)
    rows = verdict_rows(before, fresh, args.family_size)
    text = markdown(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    args.out.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    plot(rows, args.out.with_suffix(".png"))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
