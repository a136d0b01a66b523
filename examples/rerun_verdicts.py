"""Verdicts of re-run comparison cells next to the published ones, under the published rule.

The re-run's critics replace their published runs in the re-run cells; the critics not re-run
(e.g. the MLP) keep their published runs; the family-wise level stays the published sweep's.
Several re-run folders are read as one sweep, a cell found in several taken from the last.

    python examples/rerun_verdicts.py --published results/compare \\
        --rerun results/compare_adaptive_losing/ppo results/compare_adaptive_losing/a2c \\
        --out results/compare_adaptive_losing/before_after.md
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

from sb3_geogp.comparison.report import rerun_markdown
from sb3_geogp.comparison.results import load_results, load_sweeps, rerun_comparisons


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--published", type=Path, required=True, help="the published sweep")
    parser.add_argument("--rerun", type=Path, nargs="+", required=True, help="re-run sweeps")
    parser.add_argument("--out", type=Path, required=True, help="markdown file to write")
    args = parser.parse_args(argv)
    rerun = load_sweeps(args.rerun)
    if not rerun:
        raise SystemExit(f"no results in {[str(d) for d in args.rerun]}")
    before, after = rerun_comparisons(load_results(args.published), rerun)
    text = rerun_markdown(before, after)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    args.out.with_suffix(".json").write_text(json.dumps(dict(before=before, after=after), indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
