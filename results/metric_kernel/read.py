"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``), with the check that
its ``full`` predictor equals ``results/additive_kernel``'s::

    python results/metric_kernel/read.py --plot results/metric_kernel/read.png \\
        > results/metric_kernel/read.md
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "read.py", "additive_kernel_read")
SYMMETRIC = load_script(HERE.parent / "symmetric_kernel" / "read.py", "symmetric_kernel_read")
MODELS = ("full", "metric")
PRIMARY = ("metric", "full")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    runs = ADDITIVE.load(HERE)
    tail = ADDITIVE.tables(runs, MODELS, (PRIMARY,), SYMMETRIC.same_control(runs))
    verdict = ADDITIVE.verdict(tail[PRIMARY[0]] - tail[PRIMARY[1]])
    print(f"\nPrimary ({' − '.join(PRIMARY)}, last 20 %), by PLAN.md's rule: "
          f"**{verdict}** ({len(runs)} seeds).")  # fmt: skip
    if args.plot:
        title = "Acrobot-v1: exact GPs on the newest batch, by metric"
        ADDITIVE.plot(tail, list(runs), args.plot, MODELS, title)


if __name__ == "__main__":
    main()
