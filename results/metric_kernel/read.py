"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``), with the check that
its ``full`` predictor equals ``results/additive_kernel``'s::

    python results/metric_kernel/read.py --plot results/metric_kernel/read.png \\
        > results/metric_kernel/read.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "read.py", "additive_kernel_read")
SYMMETRIC = load_script(HERE.parent / "symmetric_kernel" / "read.py", "symmetric_kernel_read")
MODELS = ("full", "metric")
PRIMARY = ("metric", "full")


def main() -> None:
    title = "Acrobot-v1: exact GPs on the newest batch, by metric"
    preface = SYMMETRIC.same_control
    ADDITIVE.report(__doc__, HERE, MODELS, (PRIMARY,), preface=preface, title=title)


if __name__ == "__main__":
    main()
