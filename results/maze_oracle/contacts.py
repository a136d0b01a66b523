"""Where the oracle's agents lose time on WallMaze-v0: moves stopped by walls (PLAN.md's
second addendum) and exploration (its third).

Re-runs the screen's WallMaze-v0 runs of ``oracle`` and ``blind`` (seeds 580-589) with a
recorder that reads each rollout from SB3's buffer without changing the run (each re-run must
reproduce its stored final return exactly), and reads, per run, the mean over the rollouts
after ``LATE`` steps of the share of moves a wall stopped, of states next to an interior wall,
and of the policy's log standard deviation; ``oracle − blind`` paired by seed.

    python results/maze_oracle/contacts.py > results/maze_oracle/contacts.md
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import multiprocessing
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.measurement import RolloutRecorder
from sb3_geogp.comparison.run import result_path, run_one
from sb3_geogp.envs.wall_maze import WALL_MAZE_ID, MazeLayout, distance_to_walls
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RUN = load_script(HERE / "run.py", "maze_oracle_run")
READ = load_script(HERE / "read.py", "maze_oracle_read")
ARMS = ("oracle", "blind")
LATE = 15_000
#: States this close to an interior wall count as next to it (one step is 0.05 at most).
NEAR = 0.05
#: What each run is read for: recorder key -> row label.
SHARES = {
    "stopped": "share of moves stopped by a wall",
    "near_wall": f"share of states within {NEAR} of an interior wall",
    "log_std": "policy's log standard deviation (mean over action dimensions)",
}


class Contacts(RolloutRecorder):
    """Per rollout: the share of moves a wall stopped and of states next to an interior wall,
    and the policy's mean log standard deviation (its exploration; PLAN.md's third addendum)."""

    def __init__(self, layout: MazeLayout) -> None:
        super().__init__()
        self.layout = layout

    def row(self) -> dict[str, Any]:
        buffer = self.model.rollout_buffer
        obs = np.asarray(buffer.observations, dtype=np.float64)  # (steps, envs, 2)
        action = np.clip(np.asarray(buffer.actions, dtype=np.float64), -1.0, 1.0)
        norm = np.maximum(1.0, np.linalg.norm(action, axis=-1, keepdims=True))
        commanded = np.linalg.norm(self.layout.max_step * action / norm, axis=-1)[:-1]
        moved = np.linalg.norm(obs[1:] - obs[:-1], axis=-1)
        same_episode = ~np.asarray(buffer.episode_starts[1:], dtype=bool)
        stopped = (moved < 0.5 * commanded) & same_episode
        walls = np.asarray(self.layout.walls, dtype=np.float64)
        near = np.array([[distance_to_walls(p, walls) < NEAR for p in row] for row in obs])
        return {
            "timesteps": int(self.num_timesteps),
            "stopped": float(stopped.sum() / max(same_episode.sum(), 1)),
            "near_wall": float(near.mean()),
            "log_std": float(self.model.policy.log_std.mean()),
        }


def one(arm: str, seed: int) -> dict[str, Any]:
    spec = next(s for s in RUN.specs(RUN.ARMS[arm][0], (WALL_MAZE_ID,), (seed,)))
    recorder = Contacts(MazeLayout())
    with tempfile.TemporaryDirectory() as tmp:
        result = run_one(spec, tmp, recorders=[recorder], kernel=RUN.arm_kernel(arm))
    stored = json.loads(result_path(HERE / arm, spec).read_text())
    if result["final_return"] != stored["final_return"] or result["eval"] != stored["eval"]:
        raise RuntimeError(f"{arm} seed {seed} did not reproduce its stored run")
    late = [r for r in recorder.rows if r["timesteps"] > LATE]
    return {
        "arm": arm,
        "seed": seed,
        **{k: float(np.mean([r[k] for r in late])) for k in SHARES},
    }


def main() -> None:
    jobs = [(arm, seed) for arm in ARMS for seed in RUN.SEEDS]
    with cf.ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        rows = list(pool.map(one, *zip(*jobs, strict=True)))
    by = {(r["arm"], r["seed"]): r for r in rows}
    print(f"## Where the oracle's agents lose time: WallMaze-v0, seeds 580-589, rollouts after "
          f"{LATE:,} steps (re-runs reproduce the stored runs)\n")  # fmt: skip
    print("| per rollout | oracle | blind | oracle − blind [95 % t] |")
    print("|---|---:|---:|---|")
    for key, name in SHARES.items():
        v = {arm: np.array([by[(arm, s)][key] for s in RUN.SEEDS]) for arm in ARMS}
        print(f"| {name} | {v['oracle'].mean():.3f} | {v['blind'].mean():.3f} | "
              f"{READ.paired(v['oracle'], v['blind'], 3)} |")  # fmt: skip
    (HERE / "contacts.json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
