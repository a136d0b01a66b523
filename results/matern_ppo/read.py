"""``PLAN.md``'s reading: the two sweeps (the default's Laplacian critic, and the Matérn 5/2
critic at its basis spacing) read as one, Matérn − Laplacian per cell by the comparison's
verdict rule::

    python results/matern_ppo/read.py > results/matern_ppo/read.md
    python results/matern_ppo/read.py --confirm > results/matern_ppo/confirm.md   # registration
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sb3_geogp.comparison.report import comparisons_markdown, summary_markdown
from sb3_geogp.comparison.results import comparisons, load_sweeps, summary_rows

HERE = Path(__file__).resolve().parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--confirm", action="store_true", help="the registered confirmation")
    args = parser.parse_args()
    prefix, seeds = ("confirm_", "673-692") if args.confirm else ("", "663-672")
    results = load_sweeps([HERE / f"{prefix}laplacian", HERE / f"{prefix}matern"])
    print("# The Matérn 5/2 kernel as PPO's critic at the default's basis spacing (session 65)\n")
    print(f"Fresh PPO seeds {seeds}; `matern` is the sweep with `novelty_tol=0.004605`.\n")
    print(summary_markdown(summary_rows(results)))
    print(comparisons_markdown(comparisons(results)))


if __name__ == "__main__":
    main()
