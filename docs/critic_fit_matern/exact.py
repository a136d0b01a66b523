"""``PLAN.md``'s model-level reading: exact Matérn GPs on the drop-in default's Acrobot batches.

An exact GP with maximum-likelihood hyperparameters (Matérn 5/2 or 3/2 profile, one
lengthscale per dimension, fitted on 1,024 points of the newest batch) predicts each recorded
batch of the default's PPO critic before it is learnt, as the Laplacian row of
``results/model_ceiling`` does (``examples/adaptation_schedule.py``'s ``replay_exact``); the
streams are that study's (``results/model_ceiling/laplacian.py --streams STREAMS``, recorded
again from scratch where missing)::

    python docs/critic_fit_matern/exact.py --seeds 0 1 2 3 4 5 6 7 8 9 --streams STREAMS \\
        --out docs/critic_fit_matern/exact.json

An interrupted call resumes: every (kernel, seed) already in ``--out`` is kept.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tqdm.auto import tqdm

from sb3_geogp.comparison.run import write_json_atomic
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]
SCHEDULE = load_script(ROOT / "examples" / "adaptation_schedule.py", "schedule")
CEILING = load_script(ROOT / "results" / "model_ceiling" / "laplacian.py", "model_ceiling")
KERNELS = ("matern52", "matern32")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, required=True)
    parser.add_argument("--streams", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    done = json.loads(args.out.read_text())["results"] if args.out.exists() else {}
    bar = tqdm(total=len(args.seeds) * len(KERNELS), unit="fit")
    for seed in args.seeds:
        stream = SCHEDULE.stream_path(
            args.streams, CEILING.ENV, seed, CEILING.STEPS, CEILING.RECORDED
        )
        batches = SCHEDULE.record(CEILING.ENV, seed, CEILING.STEPS, stream, CEILING.RECORDED)
        for kernel in KERNELS:
            key = f"{kernel}/{seed}"
            if key not in done:
                done[key] = SCHEDULE.replay_exact(
                    CEILING.ENV, seed, batches, kernel=kernel, recorded=CEILING.RECORDED
                )
                write_json_atomic(args.out, {"results": done, "provenance": provenance()})
            bar.update()


if __name__ == "__main__":
    main()
