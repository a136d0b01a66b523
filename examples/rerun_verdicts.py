"""Verdicts of re-run comparison cells next to the published ones, under the published rule.

The re-run's critics replace their published runs in the re-run cells; the critics not re-run
(e.g. the MLP) keep their published runs; the family-wise level stays the published sweep's.
Several folders on either side are read as one sweep, a cell found in several taken from the
last.

    python examples/rerun_verdicts.py --published results/compare \\
        --rerun results/compare_adaptive_losing/ppo results/compare_adaptive_losing/a2c \\
        --out results/compare_adaptive_losing/before_after.md

A new default critic under another name is compared with the critic it replaces by
``--replaces NEW=OLD``, and ``--algos`` keeps the re-run's cells of some algorithms only (0.6:
the Laplacian kernel replaced the geodesic one under PPO):

    python examples/rerun_verdicts.py \\
        --published results/compare results/compare_adaptive results/compare_ard \\
        --rerun results/pilot_laplacian/A results/pilot_laplacian/A_rest \\
        --replaces laplacian=geodesic --algos ppo --out results/default_0_6/before_after.md
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

from sb3_geogp.comparison.hyperparams import ALGOS, ALL_CRITICS
from sb3_geogp.comparison.report import rerun_markdown
from sb3_geogp.comparison.results import load_sweeps, rerun_comparisons
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter


def critic_pair(text: str) -> tuple[str, str]:
    """``NEW=OLD`` as ``(new, old)``, both names of :data:`ALL_CRITICS`."""
    new, sep, old = text.partition("=")
    if not sep or new not in ALL_CRITICS or old not in ALL_CRITICS:
        raise argparse.ArgumentTypeError(
            f"expected NEW=OLD with critics of {ALL_CRITICS}, got {text!r}"
        )
    return new, old


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument(
        "--published", type=Path, nargs="+", required=True, help="the published sweep(s)"
    )
    parser.add_argument("--rerun", type=Path, nargs="+", required=True, help="re-run sweeps")
    parser.add_argument(
        "--replaces",
        type=critic_pair,
        action="append",
        default=[],
        metavar="NEW=OLD",
        help="a re-run critic and the published critic it takes the place of (repeatable)",
    )
    parser.add_argument(
        "--algos", nargs="+", choices=sorted(ALGOS), default=None, help="default: every one"
    )
    parser.add_argument("--out", type=Path, required=True, help="markdown file to write")
    args = parser.parse_args(argv)
    rerun = [r for r in load_sweeps(args.rerun) if r["spec"]["algo"] in (args.algos or ALGOS)]
    if not rerun:
        raise SystemExit(f"no results in {[str(d) for d in args.rerun]}")
    replaces = dict(args.replaces)
    before, after = rerun_comparisons(load_sweeps(args.published), rerun, replaces=replaces)
    text = rerun_markdown(before, after, replaces)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    payload = dict(before=before, after=after, replaces=replaces)
    args.out.with_suffix(".json").write_text(json.dumps(payload, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
