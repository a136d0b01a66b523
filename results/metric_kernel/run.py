"""``PLAN.md``: exact GPs with a diagonal and a full metric on the batches the drop-in PPO
default's GP critic is fed on Acrobot-v1 (one call per core; STREAMS as
``results/symmetric_kernel``'s)::

    python results/metric_kernel/run.py --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/metric_kernel/a
    python results/metric_kernel/run.py --seeds 1 3 5 7 9 --streams STREAMS \\
        --out results/metric_kernel/b
    python results/metric_kernel/read.py > results/metric_kernel/read.md

The predictors are ``results/additive_kernel/run.py``'s exact GP with its full term alone, its
metric diagonal (``full``) or learned whole (``metric``).
"""

from __future__ import annotations

import functools
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "run.py", "additive_kernel")
MODELS = {"full": ("full",), "metric": ("full", "shear")}


def main() -> None:
    replays = {
        name: functools.partial(ADDITIVE.replay, terms=terms) for name, terms in MODELS.items()
    }
    settings = {"recorded": ADDITIVE.RECORDING.RECORDED, "fit_points": ADDITIVE.FIT_POINTS}
    ADDITIVE.RECORDING.run_replays(__doc__, replays, settings)


if __name__ == "__main__":
    main()
