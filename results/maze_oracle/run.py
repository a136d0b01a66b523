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

The confirmation on fresh seeds (``PLAN.md``'s addendum)::

    python results/maze_oracle/run.py --under confirm --envs sb3_geogp/WallMaze-v0 \
        --seeds 590 591 592 593 594 595 596 597 598 599 --arms oracle blind
    python results/maze_oracle/read.py --under confirm --arms oracle blind \
        --plot results/maze_oracle/confirm/screen.png > results/maze_oracle/confirm/read.md
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
from sb3_geogp.kernels import Kernel
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


def specs(
    critic: str, envs: tuple[str, ...] = ENVS, seeds: tuple[int, ...] = SEEDS
) -> list[RunSpec]:
    return SweepConfig(algos=("ppo",), critics=(critic,), envs=envs, seeds=seeds).specs()


def arm_kernel(arm: str) -> Kernel | None:
    """The kernel ``run_one`` gives an arm's critic: the oracle's, or ``None`` (the named one)."""
    return WallAwareGeodesicKernel(None, MazeLayout()) if ARMS[arm][1] else None


def one(arm: str, spec: RunSpec, out: Path) -> str:
    run_one(spec, out, kernel=arm_kernel(arm))
    return f"{arm} {spec.run_id}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--under", default="", help="subfolder of the arms' folders")
    parser.add_argument("--envs", nargs="+", default=list(ENVS))
    parser.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS))
    parser.add_argument("--arms", nargs="+", choices=list(ARMS), default=list(ARMS))
    args = parser.parse_args()
    folder = {arm: HERE / args.under / arm for arm in args.arms}
    config = (tuple(args.envs), tuple(args.seeds))
    jobs = [
        (arm, s)
        for arm in args.arms
        for s in pending_runs(specs(ARMS[arm][0], *config), folder[arm])
    ]
    context = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(args.workers, mp_context=context) as pool:
        futures = [pool.submit(one, arm, spec, folder[arm]) for arm, spec in jobs]
        for future in tqdm(cf.as_completed(futures), total=len(futures), desc="runs", unit="run"):
            future.result()


if __name__ == "__main__":
    main()
