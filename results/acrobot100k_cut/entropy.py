"""Does the warning's advice rescue the frozen runs? (session 45, exploratory)

Re-runs the three 0.25 runs of ``trace.py`` that never swing up (Acrobot-v1, PPO, 100,000 steps,
seeds 265, 276 and 345) with the zoo's hyperparameters but an entropy bonus, ``ent_coef`` 0.01
instead of 0, the first fix the all-zero-advantage warning names (the other, uncut returns, is
``trace.py``'s 0.24 arm). The MLP critic was not re-run with it: this asks whether the frozen
runs move, not which critic is better with an entropy bonus.

    python results/acrobot100k_cut/entropy.py > results/acrobot100k_cut/entropy.md
"""

from __future__ import annotations

import dataclasses
import tempfile

from sb3_geogp.comparison.run import run_one
from sb3_geogp.comparison.specs import SweepConfig

SEEDS = (265, 276, 345)
ENT_COEF = 0.01


def main() -> None:
    config = SweepConfig(
        algos=("ppo",), critics=("laplacian",), envs=("Acrobot-v1",), seeds=SEEDS,
        timesteps=100_000,
    )  # fmt: skip
    print(f"| seed | final return, ent_coef {ENT_COEF} | steps to -100 | all-zero warning |")
    print("|---:|---:|---:|---|")
    for spec in config.specs():
        spec = dataclasses.replace(spec, hyperparams={**spec.hyperparams, "ent_coef": ENT_COEF})
        with tempfile.TemporaryDirectory() as out:
            result = run_one(spec, out)
        steps = result["steps_to_threshold"]
        warned = any("is exactly 0" in w for w in result["warnings"])
        print(f"| {spec.seed} | {result['final_return']:.1f} | "
              f"{'never' if steps is None else f'{steps:,.0f}'} | {'yes' if warned else 'no'} |")  # fmt: skip


if __name__ == "__main__":
    main()
