"""``ADDENDUM.md``'s second part: the decomposition on the drop-in PPO default's own streams.

The Laplacian GP critic as the drop-in policy has it under PPO, fed as the policy is trained
(Monte Carlo returns, :class:`~sb3_geogp.GPValueCallback`'s default feed), recorded on
Acrobot-v1 for 30,000 steps; then the predictors of the decomposition on its batches (the
others of ``PLAN.md`` left out for time)::

    python results/model_ceiling/laplacian.py --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/model_ceiling/laplacian_a
    python results/model_ceiling/laplacian.py --seeds 1 3 5 7 9 --streams STREAMS \\
        --out results/model_ceiling/laplacian_b
    python results/model_ceiling/laplacian.py --extra --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/model_ceiling/laplacian_c
    python results/model_ceiling/laplacian.py --extra --seeds 1 3 5 7 9 --streams STREAMS \\
        --out results/model_ceiling/laplacian_d
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from tqdm.auto import tqdm

from sb3_geogp.comparison.run import write_json_atomic
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
SCHEDULE = load_script(HERE.parents[1] / "examples" / "adaptation_schedule.py", "schedule")
ENV = "Acrobot-v1"
STEPS = 30_000
#: The drop-in PPO default: the Laplacian critic fed as the policy is trained.
RECORDED = {"kernel": "laplacian", "target": None}
LAPLACE, _, _, ONLINE, ONLINE_TWO = SCHEDULE.EXACT
PREDICTORS = {
    "default": functools.partial(SCHEDULE.replay, setting=RECORDED),
    SCHEDULE.MLP: SCHEDULE.replay_mlp,
    SCHEDULE.BATCH_ONLINE: functools.partial(SCHEDULE.replay_batch, refit=False, recorded=RECORDED),
    ONLINE: functools.partial(SCHEDULE.replay_exact, online=True, recorded=RECORDED),
    LAPLACE: functools.partial(SCHEDULE.replay_exact, recorded=RECORDED),
}
#: ``ADDENDUM.md``'s third part, run after the five above were read (``--extra``).
EXTRA = {
    ONLINE_TWO: functools.partial(SCHEDULE.replay_exact, online=True, history=2, recorded=RECORDED),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, required=True)
    parser.add_argument("--streams", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--extra", action="store_true", help="score the EXTRA rows only")
    args = parser.parse_args()
    predictors = EXTRA if args.extra else PREDICTORS
    results = {}
    bar = tqdm(total=len(args.seeds) * (1 + len(predictors)), unit="run")
    for seed in args.seeds:
        stream = SCHEDULE.stream_path(args.streams, ENV, seed, STEPS, RECORDED)
        batches = SCHEDULE.record(ENV, seed, STEPS, stream, RECORDED)
        bar.update()
        results[seed] = {}
        for name, predictor in predictors.items():
            results[seed][name] = predictor(ENV, seed, batches)
            bar.update()
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(
        args.out / "results.json",
        {"recorded": RECORDED, "results": {ENV: results}, "provenance": provenance()},
    )


if __name__ == "__main__":
    main()
