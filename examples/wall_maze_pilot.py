"""Pilot WallMaze layouts with SB3's MLP critic: does it reach the threshold, and where not?

The comparison's issue asks for a WallMaze setting in which the MLP critic reaches the
threshold in at least half of the seeds. This script tries one layout (speed, walls, goal,
starts, sliding moves) with the comparison's own runs (:func:`~sb3_geogp.comparison.run.run_one`:
the sweep's WallMaze hyperparameters, deterministic evaluations, the same result files), on
seeds the sweep does not use, and prints each run's evaluation curve. With ``--map`` it also
trains one model (first algorithm, first seed) and runs its deterministic policy from a grid
of starts: which starts reach the goal within the time limit (printed, and drawn into
``OUT/failure_map.png``).

    python examples/wall_maze_pilot.py --slide --goal 0.1 0.9 --goal-radius 0.12 --map \\
        --out runs/pilot_corner        # the layout of sb3_geogp/WallMazeCorner-v0
    python examples/wall_maze_pilot.py --max-step 0.1 --start-clearance 0.1 --threshold -10

Finished runs in ``OUT/runs`` are kept and skipped when the same command runs again; a folder
holding another layout's runs (``OUT/setting.json``) is refused.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import gymnasium as gym
import matplotlib.pyplot as plt
import numpy as np
import torch as th
from gymnasium.envs.registration import register, registry
from tqdm.auto import tqdm

from sb3_geogp.comparison.command import parse_gp_option
from sb3_geogp.comparison.hyperparams import HyperparamsFile
from sb3_geogp.comparison.run import build_model, load_result, result_path, run_one
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.comparison.sweep import pending_runs
from sb3_geogp.envs.wall_maze import (
    DOOR_LAYOUT,
    MAX_EPISODE_STEPS,
    MazeLayout,
    WallMaze,
    distance_to_walls,
)
from sb3_geogp.toolbox.pools import worker_pool
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg

ENV_ID = "sb3_geogp_pilot/WallMaze-v0"
#: The walls a pilot can use: the published zig-zag, its upper wall alone, or
#: ``WallMazeDoor-v0``'s wall across the middle with a door (a 0.2 gap in its centre).
WALLS = {
    "zigzag": MazeLayout().walls,
    "upper": MazeLayout().walls[:1],
    "door": DOOR_LAYOUT.walls,
}
#: The sweep's WallMaze hyperparameters (sb3_geogp.comparison.hyperparams.OWN_HYPERPARAMS).
HYPERPARAMS = {"ppo": dict(n_envs=4, n_steps=256), "a2c": dict(n_envs=4)}


def register_pilot(layout: MazeLayout, discrete: bool) -> None:
    """Register :data:`ENV_ID` on ``layout`` (in this process; the workers call it too)."""
    if ENV_ID in registry:
        del registry[ENV_ID]
    entry = "WallMazeDiscrete" if discrete else "WallMaze"
    register(
        id=ENV_ID,
        entry_point=f"sb3_geogp.envs.wall_maze:{entry}",
        max_episode_steps=MAX_EPISODE_STEPS,
        kwargs={"layout": layout},
    )


def pilot_specs(args: argparse.Namespace) -> list[RunSpec]:
    """The MLP runs of the pilot (the sweep's measurement settings, 10 checkpoints)."""
    entries = {a: {**HYPERPARAMS[a], **dict(args.hyperparam)} for a in args.algos}
    files = tuple((a, HyperparamsFile("pilot", {ENV_ID: entries[a]})) for a in args.algos)
    config = SweepConfig(
        algos=tuple(args.algos),
        critics=("mlp",),
        envs=(ENV_ID,),
        seeds=tuple(args.seeds),
        timesteps=args.timesteps,
        thresholds=((ENV_ID, args.threshold),),
        hyperparams_files=files,
        n_checkpoints=10,
        critic_every=10,
        n_probe_states=8,
        n_mc_rollouts=2,
    )
    return config.specs()


def run_pilot(
    specs: list[RunSpec], layout: MazeLayout, discrete: bool, out: Path, workers: int
) -> list[dict[str, Any]]:
    """Every run of ``specs`` not yet in ``out``; the results of all of them.

    Raises
    ------
    ValueError
        If a finished run was made with another budget, threshold or hyperparameters
        (:func:`~sb3_geogp.comparison.sweep.pending_runs`, as the sweep refuses them).
    """
    todo = pending_runs(specs, out)
    bar = tqdm(total=len(specs), initial=len(specs) - len(todo), unit="run", desc="pilot runs")

    def finished(result: dict[str, Any]) -> None:
        bar.set_postfix_str(f"final {result['final_return']:.1f}")
        bar.update()

    if workers <= 1:
        for spec in todo:
            finished(run_one(spec, out))
    else:
        # Spawned workers, as the sweep's; each registers the layout before its first run.
        with worker_pool(workers, register_pilot, (layout, discrete)) as pool:
            for future in cf.as_completed([pool.submit(run_one, s, str(out)) for s in todo]):
                finished(future.result())
    bar.close()
    return [r for s in specs if (r := load_result(result_path(out, s))) is not None]


def curves_table(results: list[dict[str, Any]], threshold: float) -> str:
    """One line per run: the evaluation curve, final return and steps to the threshold."""
    lines = [
        f"| run | evaluation returns (every 10% of the budget) | final | steps to {threshold} |",
        "|---|---|---:|---:|",
    ]
    for r in results:
        spec = r["spec"]
        curve = ", ".join(f"{x:.0f}" for x in r["eval"]["mean_return"])
        reached = r["steps_to_threshold"]
        lines.append(
            f"| {spec['algo']} seed {spec['seed']} | {curve} | {r['final_return']:.1f} | "
            f"{'–' if reached is None else reached} |"
        )
    return "\n".join(lines) + "\n"


def _is_start(layout: MazeLayout, p: np.ndarray) -> bool:
    """A grid point the map starts from: off the walls by half a step, outside the goal."""
    return distance_to_walls(p, layout.segments()) >= 0.5 * layout.max_step and not bool(
        layout.in_goal(p)
    )


def failure_map(spec: RunSpec, n: int, out: Path) -> str:
    """Train ``spec``'s model; which of ``n x n`` grid starts its deterministic policy brings
    to the goal within the time limit.

    Returns the map as text (``.`` reached, ``X`` not, top row the top of the arena) and
    draws it into ``out/failure_map.png``.
    """
    maze = gym.make(spec.env_id).unwrapped
    assert isinstance(maze, WallMaze)
    u = (np.arange(n) + 0.5) / n * maze.layout.size
    grid = [[np.array([x, y]) for x in u] for y in u[::-1]]  # top row first
    valid = [[_is_start(maze.layout, p) for p in row] for row in grid]
    if not any(map(any, valid)):  # checked before the training it would waste
        raise SystemExit(
            f"error: no start of the {n} x {n} grid is off the walls: use a larger --grid"
        )
    th.set_num_threads(1)
    model = build_model(spec)
    model.learn(spec.total_timesteps, progress_bar=True)
    rows, starts, reached = [], [], []
    for points, valid_row in zip(grid, valid, strict=True):
        row = ""
        for p, ok in zip(points, valid_row, strict=True):
            if not ok:
                row += " "
                continue
            starts.append(p)
            reached.append(_reaches_goal(model, maze, p))
            row += "." if reached[-1] else "X"
        rows.append(row)
    _draw_map(maze.layout, np.array(starts), np.array(reached), spec, out / "failure_map.png")
    return (
        "\n".join(rows) + f"\n{np.mean(reached):.0%} of {len(starts)} grid starts reach the goal\n"
    )


def _reaches_goal(model: Any, maze: WallMaze, start: np.ndarray) -> bool:
    obs, _ = maze.reset(options={"start": start})
    for _ in range(MAX_EPISODE_STEPS):
        action, _ = model.predict(obs, deterministic=True)
        obs, _, terminated, _, _ = maze.step(action)
        if terminated:
            return True
    return False


def _draw_map(
    layout: MazeLayout, starts: np.ndarray, reached: np.ndarray, spec: RunSpec, path: Path
) -> None:
    fig, ax = plt.subplots(figsize=(5, 5))
    for ok, colour, label in ((True, "tab:green", "reaches the goal"), (False, "tab:red", "not")):
        pts = starts[reached == ok]
        ax.scatter(pts[:, 0], pts[:, 1], s=14, c=colour, label=label)
    for x0, y0, x1, y1 in layout.segments():
        ax.plot([x0, x1], [y0, y1], "k-", lw=3)
    ax.add_patch(plt.Circle(layout.goal, layout.goal_radius, color="gold", alpha=0.6))
    ax.set_aspect("equal")
    ax.set_xlim(0, layout.size)
    ax.set_ylim(0, layout.size)
    ax.set_title(
        f"{spec.algo.upper()} + MLP critic, seed {spec.seed}, {spec.total_timesteps} steps:\n"
        "deterministic policy from each start",
        fontsize=10,
    )
    # Outside the arena: inside, it hid some of the starts.
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _claim_folder(out: Path, setting: dict[str, Any]) -> None:
    """Record the pilot's setting in ``out/setting.json``; refuse a folder that holds another
    setting's runs (their file names do not say the layout)."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / "setting.json"
    text = json.dumps(setting, indent=1)
    if path.exists() and json.loads(path.read_text()) != json.loads(text):
        raise SystemExit(f"{out} holds the runs of another setting ({path}): pass another --out")
    path.write_text(text)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    p.add_argument("--max-step", type=float, default=MazeLayout.max_step)
    p.add_argument("--start-clearance", type=float, default=None, help="default: 2 max_step")
    p.add_argument("--walls", choices=sorted(WALLS), default="zigzag")
    p.add_argument("--slide", action="store_true", help="moves slide along walls")
    p.add_argument("--goal", type=float, nargs=2, default=MazeLayout.goal, metavar=("X", "Y"))
    p.add_argument("--goal-radius", type=float, default=MazeLayout.goal_radius)
    p.add_argument("--discrete", action="store_true", help="8 directions instead of a velocity")
    p.add_argument("--algos", nargs="+", choices=sorted(HYPERPARAMS), default=["ppo", "a2c"])
    p.add_argument("--seeds", type=int, nargs="+", default=[100, 101, 102])
    p.add_argument("--timesteps", type=count_arg, default=30_000)
    p.add_argument(
        "--hyperparam",
        action="append",
        default=[],
        type=parse_gp_option,
        metavar="KEY=VALUE",
        help="on top of the sweep's WallMaze hyperparameters, e.g. ent_coef=0.01 (repeatable)",
    )
    p.add_argument("--threshold", type=float, default=-20.0)
    p.add_argument("--map", action="store_true", help="also the failure map of one model")
    p.add_argument("--grid", type=count_arg, default=19, help="grid starts per side of the map")
    p.add_argument("--workers", type=count_arg, default=2)
    p.add_argument("--out", type=Path, default=Path("runs/wall_maze_pilot"))
    return p.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    layout = MazeLayout(
        walls=WALLS[args.walls],
        goal=tuple(args.goal),
        goal_radius=args.goal_radius,
        max_step=args.max_step,
        start_clearance=args.start_clearance,
        slide=args.slide,
    )
    register_pilot(layout, args.discrete)
    setting = {"layout": dataclasses.asdict(layout), "discrete": args.discrete}
    _claim_folder(args.out, {**setting, "hyperparams": dict(args.hyperparam)})
    env = WallMaze(layout)
    env.reset(seed=0)
    starts = np.array([env.reset()[1]["position"] for _ in range(2000)])
    optimal = -float(np.mean(layout.optimal_steps(starts)))
    specs = pilot_specs(args)
    try:
        results = run_pilot(specs, layout, args.discrete, args.out, args.workers)
    except ValueError as error:  # runs of another budget or threshold in --out
        raise SystemExit(f"error: {error}") from None
    text = (
        f"Layout: {dataclasses.asdict(layout)}, discrete actions: {args.discrete}; "
        f"hyperparameters: the sweep's + {dict(args.hyperparam)}; mean optimal return over 2000 "
        f"starts {optimal:.2f}, threshold {args.threshold}\n\n"
        + curves_table(results, args.threshold)
    )
    if args.map:
        text += "\nFailure map (top row: the top of the arena):\n\n```\n"
        text += failure_map(specs[0], args.grid, args.out) + "```\n"
    (args.out / "pilot.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
