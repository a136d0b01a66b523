"""Does knowing the walls help the geodesic critic inside PPO training? A screen (session 50).

The wall study (docs/wall_experiment.md, "Attachments that know the wall") found the geodesic
GP's near-wall error on fixed data to be its attachment: with an oracle that forbids
attachments through the wall it falls 7-20x. This screen gives the same oracle to the geodesic
critic inside PPO training on the WallMaze tasks (``WallAwareGeodesicKernel`` on the task's
``MazeLayout``; everything else the geodesic critic's defaults) and compares it, seed by seed,
with the same critic attached blindly and with PPO's default critic (Laplacian). Plan fixed
before the runs: ``PLAN.md``.

    python results/maze_oracle/run.py            # resumes: finished runs are kept
    python results/maze_oracle/read.py > results/maze_oracle/read.md
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import multiprocessing
from pathlib import Path

from tqdm import tqdm

from sb3_geogp.comparison.run import run_one
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.comparison.sweep import pending_runs
from sb3_geogp.envs.wall_maze import WALL_MAZE_DISCRETE_ID, WALL_MAZE_ID, MazeLayout
from sb3_geogp.studies.wall.oracle import WallAwareGeodesicKernel

HERE = Path(__file__).resolve().parent
ENVS = (WALL_MAZE_ID, WALL_MAZE_DISCRETE_ID)
SEEDS = tuple(range(580, 590))
#: Arm -> (critic, whether its kernel knows the walls). Both WallMaze tasks use the default
#: layout (``MazeLayout()``).
ARMS = {
    "oracle": ("geodesic", True),
    "blind": ("geodesic", False),
    "laplacian": ("laplacian", False),
}


def specs(critic: str) -> list[RunSpec]:
    return SweepConfig(algos=("ppo",), critics=(critic,), envs=ENVS, seeds=SEEDS).specs()


def one(arm: str, spec: RunSpec) -> str:
    oracle = ARMS[arm][1]
    kernel = WallAwareGeodesicKernel(None, MazeLayout()) if oracle else None
    run_one(spec, HERE / arm, kernel=kernel)
    return f"{arm} {spec.run_id}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    jobs = [
        (arm, s)
        for arm, (critic, _) in ARMS.items()
        for s in pending_runs(specs(critic), HERE / arm)
    ]
    context = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(args.workers, mp_context=context) as pool:
        futures = [pool.submit(one, arm, spec) for arm, spec in jobs]
        for future in tqdm(cf.as_completed(futures), total=len(futures), desc="runs", unit="run"):
            future.result()


if __name__ == "__main__":
    main()
