"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``), as
``results/data_ceiling``'s (the off-line predictors' "all scored batches" are NaN: they were
fitted for the tail alone)::

    python results/data_ceiling_100k/read.py --plot results/data_ceiling_100k/read.png \\
        > results/data_ceiling_100k/read.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
CEILING = load_script(HERE.parent / "data_ceiling" / "read.py", "data_ceiling_read")

if __name__ == "__main__":
    CEILING.main(__doc__, HERE, "100,000")
