"""``PLAN.md``'s reading: the two sweeps (the default's Laplacian critic, and the Matérn 5/2
critic at its basis spacing) read as one, Matérn − Laplacian per cell by the comparison's
verdict rule::

    python results/matern_ppo/read.py > results/matern_ppo/read.md
    python results/matern_ppo/read.py --confirm > results/matern_ppo/confirm.md   # registration
    python results/matern_ppo/read.py --screen32 > results/matern_ppo/screen32.md  # session 72
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sb3_geogp.comparison.report import comparisons_markdown, summary_markdown
from sb3_geogp.comparison.results import comparisons, load_sweeps, summary_rows

HERE = Path(__file__).resolve().parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    reading = parser.add_mutually_exclusive_group()
    reading.add_argument("--confirm", action="store_true", help="the registered confirmation")
    reading.add_argument("--screen32", action="store_true", help="session 72's Matérn 3/2 screen")
    args = parser.parse_args()
    if args.screen32:
        sweeps, seeds, nu, tol, session = (
            ("s72_laplacian", "s72_matern32"),
            "883-892",
            "3/2",
            0.007821,
            72,
        )
    else:
        prefix = "confirm_" if args.confirm else ""
        sweeps = (f"{prefix}laplacian", f"{prefix}matern")
        seeds = "673-692" if args.confirm else "663-672"
        nu, tol, session = "5/2", 0.004605, 65
    results = load_sweeps([HERE / name for name in sweeps])
    title = f"The Matérn {nu} kernel as PPO's critic at the default's basis spacing"
    print(f"# {title} (session {session})\n")
    print(f"Fresh PPO seeds {seeds}; `matern` is the sweep with `novelty_tol={tol}`.\n")
    print(summary_markdown(summary_rows(results)))
    print(comparisons_markdown(comparisons(results)))


if __name__ == "__main__":
    main()
