"""The reading of ``PLAN.md``'s screen (session 77, exploratory)::

    python results/fit_spacing/read.py > results/fit_spacing/read.md

Spaced − 0.37's default per cell, paired by seed and as the comparison reads it
(``results/drift_floor/read.py``'s table), then the bit-for-bit check of the cells whose blocks
are whole 4,096-point rollouts, then the GP critic's share of the training time.
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
FLOOR = load_script(RESULTS / "drift_floor" / "read.py", "drift_floor")
DRIFT = load_script(RESULTS / "drift_forgetting" / "read.py", "drift_forgetting")
CELLS = (
    "CartPole-v1",
    "MountainCarContinuous-v0",
    "sb3_geogp/WallMaze-v0",
    "sb3_geogp/WallMazeDiscrete-v0",
)


def check() -> None:
    """Whether each check run's evaluations and critic accuracy probes are the default's."""
    print("## Blocks of 4,096 points: the same runs (seed 983)\n")
    default, spaced = (load_results(HERE / f"check_{arm}") for arm in ("default", "spaced"))
    by_env = {r["spec"]["env_id"]: r for r in default}
    for run in spaced:
        env = run["spec"]["env_id"]
        same = all(run[k] == by_env[env][k] for k in ("eval", "critic_accuracy"))
        print(f"- {env}: {'identical' if same else 'DIFFERENT'}")
    print()


def main() -> None:
    print("## The screen (PLAN.md, exploratory): fit_spacing=4096 − 0.37's default\n")
    print("Paired by seed; in brackets below each, the comparison's interval (groups resampled")
    print("separately, `report/vs_baseline.json`; one cell per sweep, so its bold verdicts are")
    print("at 95 %).\n")
    FLOOR.screen_table(HERE, CELLS, "spaced")
    check()
    arms = {
        arm: [f"{arm}_{env.removeprefix('sb3_geogp/')}" for env in CELLS]
        for arm in ("default", "spaced")
    }
    DRIFT.critic_share(HERE, arms, "each arm's sweeps one after the other, same seeds")


if __name__ == "__main__":
    main()
