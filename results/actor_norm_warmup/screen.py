"""The screen of ``PLAN.md`` (session 63): A2C's default GP critic without the actor's
normalisation, with it (0.32's ``normalize_actor_obs=True``), and with it frozen after a
warm-up, in three A2C cells on fresh seeds 154-173::

    python results/actor_norm_warmup/screen.py --out results/actor_norm_warmup

Each run is ``sb3-geogp compare``'s run of its spec (``--gp-actor-normalize`` in the last two
arms); the frozen arm adds one callback, which stops the statistics taking in observations once
``--warmup`` steps have been taken (those published then stay), and its result file records it
as ``actor_normalize_frozen_after``. The arms go to ``OUT/default``, ``OUT/actor`` and
``OUT/frozen``; runs already there are skipped.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from tqdm import tqdm

from sb3_geogp.comparison.run import load_result, result_path, run_one, write_json_atomic
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.toolbox.scripts import count_arg

#: The A2C cells: the two the option cost family-wise in session 62, and the one it gained most.
ENVS = ("Acrobot-v1", "sb3_geogp/PaperPendulum-v0", "MountainCarContinuous-v0")
SEEDS = range(154, 174)
ARMS = ("default", "actor", "frozen")


class FreezeActorStatistics(BaseCallback):
    """Stop the actor's normaliser taking in observations once ``warmup`` steps have been taken:
    its statistics, and the ones it publishes at each rollout's start, stay as they are."""

    def __init__(self, warmup: int) -> None:
        super().__init__()
        self.warmup = warmup

    def _on_step(self) -> bool:
        normalizer = self.model.policy.actor_normalizer
        if self.num_timesteps >= self.warmup and "observe" not in vars(normalizer):
            normalizer.observe = _ignore
        return True


def _ignore(x: np.ndarray) -> None:
    """The frozen normaliser's ``observe``."""


def specs(arm: str) -> list[RunSpec]:
    config = SweepConfig(
        algos=("a2c",),
        critics=("rbf",),
        envs=ENVS,
        seeds=tuple(SEEDS),
        gp_actor_normalize=arm != "default",
    )
    return config.specs()


def run(job: tuple[str, RunSpec, Path, int]) -> str:
    arm, spec, out, warmup = job
    if arm != "frozen":
        run_one(spec, out / arm)
        return spec.run_id
    result = run_one(spec, out / arm, recorders=[FreezeActorStatistics(warmup)])
    write_json_atomic(
        result_path(out / arm, spec), {**result, "actor_normalize_frozen_after": warmup}
    )
    return spec.run_id


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--warmup", type=count_arg, default=2_000, help="steps before freezing")
    parser.add_argument("--workers", type=count_arg, default=2)
    args = parser.parse_args()
    # seed by seed, the three arms together: an interrupted screen leaves whole seeds
    jobs = [
        (arm, spec, args.out, args.warmup)
        for spec_index in range(len(ENVS) * len(SEEDS))
        for arm in ARMS
        for spec in [sorted(specs(arm), key=lambda s: (s.seed, s.env_id))[spec_index]]
        if load_result(result_path(args.out / arm, spec)) is None
    ]
    with mp.get_context("spawn").Pool(args.workers) as pool:
        for _ in tqdm(pool.imap_unordered(run, jobs), total=len(jobs), desc="runs"):
            pass


if __name__ == "__main__":
    main()
