"""``PLAN.md``'s reading: Acrobot-v1's critic fit at 100,000 steps, 0.35's default against
0.34's, paired by seed (the table of ``results/whole_batch/read.py``'s ``fit_table``)::

python results/whole_batch_100k/read.py > results/whole_batch_100k/read.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
FIRST = load_script(HERE.parent / "whole_batch" / "read.py", "whole_batch")


def main() -> None:
    print("0.35's default (whole) against 0.34's (default), 100,000 steps.\n")
    reading = "The registered rule reads nothing: exploratory (PLAN.md)"
    FIRST.fit_table(HERE, range(10), ("Acrobot-v1",), reading, ("default034", "default035"))


if __name__ == "__main__":
    main()
