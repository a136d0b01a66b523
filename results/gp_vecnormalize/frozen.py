"""The screen's third arm (``PLAN.md``, second addendum): the default GP critic's policy in the
zoo's ``VecNormalize`` with its statistics frozen after a warm-up, as ``GPValueCallback``'s
warning suggests (``vec_env.training = False``), seeds 0-19, the five cells::

    python results/gp_vecnormalize/frozen.py --out results/gp_vecnormalize/frozen
    python results/gp_vecnormalize/frozen.py --lengthscale 1.0 \
        --out results/gp_vecnormalize/frozen_unit_lengthscale

``--lengthscale`` (the third addendum) gives the GP critics that starting lengthscale, as
docs/usage.md advises for normalised observations (unit variance), instead of one from the
observation space's raw bounds. Each run is ``sb3-geogp compare --gp-normalize``'s run of the
same spec with one more callback, which freezes the statistics once ``--warmup`` steps have
been taken; the result file records it as ``normalize_frozen_after``. Runs already in
``--out`` are skipped.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
from pathlib import Path

from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import unwrap_vec_normalize
from tqdm import tqdm

from sb3_geogp.comparison.run import load_result, result_path, run_one, write_json_atomic
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.toolbox.scripts import count_arg

#: The cells whose zoo entry normalises, by algorithm, and each algorithm's default critic.
CELLS = {
    "a2c": (("Pendulum-v1", "MountainCarContinuous-v0", "Acrobot-v1"), "rbf"),
    "ppo": (("MountainCarContinuous-v0", "Acrobot-v1"), "laplacian"),
}


class FreezeNormalization(BaseCallback):
    """Stop ``VecNormalize`` updating its statistics once ``warmup`` steps have been taken."""

    def __init__(self, warmup: int) -> None:
        super().__init__()
        self.warmup = warmup

    def _on_step(self) -> bool:
        normalizer = unwrap_vec_normalize(self.training_env)
        if normalizer is not None and normalizer.training and self.num_timesteps >= self.warmup:
            normalizer.training = False
        return True


def specs(seeds: range, lengthscale: float | None = None) -> list[RunSpec]:
    """``sb3-geogp compare --gp-normalize``'s specs of the five cells' default GP critics (with
    ``--gp-option 'kernel_kwargs={"lengthscale": ...}'`` where ``lengthscale`` is given)."""
    options = () if lengthscale is None else (("kernel_kwargs", {"lengthscale": lengthscale}),)
    out = []
    for algo, (envs, critic) in CELLS.items():
        config = SweepConfig(
            algos=(algo,),
            critics=(critic,),
            envs=envs,
            seeds=tuple(seeds),
            gp_normalize=True,
            gp_options=options,
        )
        out += config.specs()
    return out


def run(job: tuple[RunSpec, Path, int]) -> str:
    spec, out, warmup = job
    result = run_one(spec, out, recorders=[FreezeNormalization(warmup)])
    write_json_atomic(result_path(out, spec), {**result, "normalize_frozen_after": warmup})
    return spec.run_id


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--warmup", type=count_arg, default=2_000, help="steps before freezing")
    parser.add_argument("--seeds", type=count_arg, default=20, help="seeds 0..N-1")
    parser.add_argument("--workers", type=count_arg, default=2)
    parser.add_argument("--lengthscale", type=float, default=None, help="the GP's starting one")
    args = parser.parse_args()
    todo = [
        (spec, args.out, args.warmup)
        for spec in specs(range(args.seeds), args.lengthscale)
        if load_result(result_path(args.out, spec)) is None
    ]
    with mp.get_context("spawn").Pool(args.workers) as pool:
        for _ in tqdm(pool.imap_unordered(run, todo), total=len(todo), desc="runs"):
            pass


if __name__ == "__main__":
    main()
