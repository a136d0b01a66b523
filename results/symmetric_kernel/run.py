"""``PLAN.md``: exact GPs with kernels summed over Acrobot's mirror image on the batches the
drop-in PPO default's GP critic is fed on Acrobot-v1 (one call per core; STREAMS is where the
batches are kept, recorded there where missing as ``results/actor_features`` records them)::

    python results/symmetric_kernel/run.py --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/symmetric_kernel/a
    python results/symmetric_kernel/run.py --seeds 1 3 5 7 9 --streams STREAMS \\
        --out results/symmetric_kernel/b
    python results/symmetric_kernel/read.py > results/symmetric_kernel/read.md

The predictors are ``results/additive_kernel/run.py``'s exact GP with its full term alone,
summed over the mirror image ``M x'`` by a weight of 0 (``full``), 1 (``mirror``) or learned
(``mirror_learned``).
"""

from __future__ import annotations

import functools
from pathlib import Path

import torch as th

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "run.py", "additive_kernel")
#: Acrobot's mirror ``theta -> -theta`` on (cos t1, sin t1, cos t2, sin t2, dt1, dt2).
MIRROR = th.tensor([1.0, -1.0, 1.0, -1.0, -1.0, -1.0], dtype=th.float64)
MODELS = {
    "full": ("full",),
    "mirror": ("full", "mirror"),
    "mirror_learned": ("full", "mirror", "weight"),
}


def main() -> None:
    replays = {
        name: functools.partial(ADDITIVE.replay, terms=terms, mirror=MIRROR)
        for name, terms in MODELS.items()
    }
    settings = {
        "recorded": ADDITIVE.RECORDING.RECORDED,
        "fit_points": ADDITIVE.FIT_POINTS,
        "mirror": MIRROR.tolist(),
    }
    ADDITIVE.RECORDING.run_replays(__doc__, replays, settings)


if __name__ == "__main__":
    main()
