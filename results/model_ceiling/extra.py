"""The row added after ``PLAN.md`` (see ``ADDENDUM.md``): the default GP's basis at the on-line
GP's own hyperparameters, in batch on the newest batch, on the same recorded streams::

    python results/model_ceiling/extra.py STREAMS results/model_ceiling/c
"""

from __future__ import annotations

import sys
from pathlib import Path

import torch as th
from tqdm.auto import tqdm

from sb3_geogp.comparison.run import write_json_atomic
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
SCHEDULE = load_script(HERE.parents[1] / "examples" / "adaptation_schedule.py", "schedule")
ENV = "Acrobot-v1"
SEEDS = range(10)
STEPS = 30_000


def main() -> None:
    streams, out = Path(sys.argv[1]), Path(sys.argv[2])
    results = {}
    for seed in tqdm(SEEDS, desc=SCHEDULE.BATCH_ONLINE):
        path = SCHEDULE.stream_path(streams, ENV, seed, STEPS, {})
        batches = th.load(path, weights_only=False)
        row = SCHEDULE.replay_batch(ENV, seed, batches, refit=False)
        results[seed] = {SCHEDULE.BATCH_ONLINE: row}
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "results.json", {"results": {ENV: results}, "provenance": provenance()})


if __name__ == "__main__":
    main()
