"""The maze oracle swapped half-way through training (``PLAN.md``'s addendum 8, session 53).

The oracle critic's agents fall behind the blind critic's on WallMaze-v0 only in the second
half of training (addenda 1-2). Each run here trains PPO with the geodesic critic as the
screen did, but whether its kernel knows the walls is switched at the rollout that starts at
``--at`` steps (15,360: rollout 16 of 30): a 2 x 2 design, the first half's critic by the
second half's, paired by seed::

    python results/maze_oracle/swap.py                   # resumes: finished runs are kept
    python results/maze_oracle/swap.py --read --plot results/maze_oracle/swap/swap.png \\
        > results/maze_oracle/swap/read.md

Re-run with 0.31.3's oracle (``PLAN.md``'s addendum 10), next to the screen and confirmation
re-run in ``rerun_0_31_3``::

    python results/maze_oracle/swap.py --root rerun_0_31_3
    python results/maze_oracle/swap.py --root rerun_0_31_3 --read \\
        --plot results/maze_oracle/rerun_0_31_3/swap/swap.png \\
        > results/maze_oracle/rerun_0_31_3/swap/read.md

Every arm's kernel is one :class:`SwitchedKernel`; the arms differ only in when it knows the
walls. A switch changes the attachments made from then on (of new basis vectors and of every
point the critic is asked about); edges already in the graph stay.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import multiprocessing
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from torch import Tensor
from tqdm import tqdm

from sb3_geogp.comparison.run import run_one
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.comparison.sweep import pending_runs
from sb3_geogp.envs.wall_maze import WALL_MAZE_ID, MazeLayout
from sb3_geogp.policies import GPActorCriticPolicy
from sb3_geogp.studies.wall.oracle import WallAwareGeodesicKernel
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
READ = load_script(HERE / "read.py", "maze_oracle_read")
AREA = "area under the curve (mean return over checkpoints)"
SEEDS = tuple(range(618, 638))
AT = 15_360
#: Arm -> whether the kernel knows the walls (first half, second half).
ARMS = {
    "oracle": (True, True),
    "blind": (False, False),
    "early": (True, False),
    "late": (False, True),
}


class SwitchedKernel(WallAwareGeodesicKernel):
    """The oracle's kernel whose knowledge of the walls can be switched off (``knows``)."""

    def __init__(self, rooms: MazeLayout, knows: bool) -> None:
        super().__init__(None, rooms)
        self.knows = knows

    def blocked(self, x: Tensor, z: Tensor) -> Tensor | None:
        return super().blocked(x, z) if self.knows else None


class Switch(BaseCallback):
    """Sets the critic's ``knows`` at the start of every rollout: ``first`` before ``at``
    steps, ``second`` from then on; records the step of each rollout that knew the walls."""

    def __init__(self, at: int, first: bool, second: bool) -> None:
        super().__init__()
        self.at, self.first, self.second = at, first, second
        self.knowing: list[int] = []

    def _on_rollout_start(self) -> None:
        policy = self.model.policy
        assert isinstance(policy, GPActorCriticPolicy)
        kernel = policy.gp.kernel
        assert isinstance(kernel, SwitchedKernel)
        kernel.knows = self.first if self.model.num_timesteps < self.at else self.second
        if kernel.knows:
            self.knowing.append(self.model.num_timesteps)

    def _on_step(self) -> bool:
        return True


def one(arm: str, spec: RunSpec, out: Path, at: int) -> str:
    first, second = ARMS[arm]
    kernel = SwitchedKernel(MazeLayout(), knows=first)
    switch = Switch(at, first, second)
    run_one(spec, out, recorders=[switch], kernel=kernel)
    knew = switch.knowing
    span = f"{len(knew)} rollouts, from step {knew[0]} to {knew[-1]}" if knew else "no rollout"
    return f"{arm} {spec.run_id}: the critic knew the walls in {span}"


def specs(seeds: tuple[int, ...]) -> list[RunSpec]:
    return SweepConfig(
        algos=("ppo",), critics=("geodesic",), envs=(WALL_MAZE_ID,), seeds=seeds
    ).specs()


def train(root: str, seeds: tuple[int, ...], arms: list[str], at: int, workers: int) -> None:
    """Runs every arm's pending seeds into ``<root>/swap/<arm>``."""
    folder = {arm: HERE / root / "swap" / arm for arm in arms}
    jobs = [(arm, s) for arm in arms for s in pending_runs(specs(seeds), folder[arm])]
    context = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(workers, mp_context=context) as pool:
        futures = [pool.submit(one, arm, spec, folder[arm], at) for arm, spec in jobs]
        for future in tqdm(cf.as_completed(futures), total=len(futures), desc="runs", unit="run"):
            tqdm.write(future.result())


# -- the reading -------------------------------------------------------------------------------
def half_mean(result: dict[str, Any], at: int, second: bool) -> float:
    """Mean evaluation return over the checkpoints after ``at`` steps (``second``), or over
    those up to it."""
    steps = np.asarray(result["eval"]["timesteps"])
    returns = np.asarray(result["eval"]["mean_return"])
    return float(returns[steps > at].mean() if second else returns[steps <= at].mean())


def read(root: str, at: int, plot: Path | None) -> None:
    found = READ.runs(str(Path(root, "swap")), tuple(ARMS))
    data = {arm: runs[WALL_MAZE_ID] for arm, runs in found.items()}
    seeds = sorted(set.intersection(*(set(d) for d in data.values())))
    if not seeds:
        raise SystemExit(f"no seed has all four arms under {HERE / root / 'swap'}: train first")
    print(f"Seeds read: {len(seeds)} ({seeds[0]}-{seeds[-1]}); switch at {at:,} steps.\n")
    metric = {name: fn for name, (fn, _) in READ.METRICS.items()}
    readings = {
        "area under the curve, second half (primary)": lambda r: half_mean(r, at, True),
        "area under the curve, whole run": metric[AREA],
        "area under the curve, first half": lambda r: half_mean(r, at, False),
        "final return": metric["final return"],
        "critic RMSE, final": metric["critic RMSE, final"],
    }
    print("| reading | " + " | ".join(ARMS) + " | second half's oracle (late effect) "
          "| first half's oracle (early effect) | oracle − blind |")  # fmt: skip
    print("|---|" + "---:|" * len(ARMS) + "---|---|---|")
    for name, fn in readings.items():
        v = {arm: np.array([fn(data[arm][s]) for s in seeds]) for arm in ARMS}
        late = READ.paired((v["oracle"] + v["late"]) / 2, (v["early"] + v["blind"]) / 2)
        early = READ.paired((v["oracle"] + v["early"]) / 2, (v["late"] + v["blind"]) / 2)
        means = " | ".join(f"{v[arm].mean():.2f}" for arm in ARMS)
        pure = READ.paired(v["oracle"], v["blind"])
        print(f"| {name} | {means} | {late} | {early} | {pure} |")
    print("\nEffects: the mean over the other half's two settings of (oracle − blind) in the")
    print("named half, paired by seed, 95 % Student-t.")
    sets(root, "area under the curve", metric[AREA])
    # Added in session 58, after reading the re-run's table above.
    sets(root, "final critic RMSE", metric["critic RMSE, final"])
    if plot is not None:
        draw(data, seeds, at, plot)


def sets(root: str, name: str, reading: Callable[[dict[str, Any]], float]) -> None:
    """``oracle − blind`` in a whole-run ``reading`` (called ``name``) in every set of
    WallMaze-v0 seeds under ``root``, and pooled (readings chosen after seeing this design's,
    so printed apart)."""
    folders = {
        "580-589 (the screen, where the slowdown was noticed)": "",
        "590-599 (the confirmation)": "confirm",
        "618-637 (this design)": "swap",
    }
    pairs = {}
    for label, under in folders.items():
        found = READ.runs(str(Path(root, under)), ("oracle", "blind"))
        oracle, blind = (found[arm][WALL_MAZE_ID] for arm in ("oracle", "blind"))
        seeds = sorted(set(oracle) & set(blind))
        pairs[label] = tuple(np.array([reading(arm[s]) for s in seeds]) for arm in (oracle, blind))

    def pool(names: list[str]) -> tuple[np.ndarray, ...]:
        return tuple(np.concatenate([pairs[n][i] for n in names]) for i in (0, 1))

    names = list(pairs)
    pairs["590-599 and 618-637 (the seeds not used to notice it)"] = pool(names[1:])
    pairs["all"] = pool(names)
    print(f"\n| WallMaze-v0, oracle − blind, whole run | seeds | {name} [95 % t] |")
    print("|---|---:|---|")
    for label, (a, b) in pairs.items():
        print(f"| {label} | {len(a)} | {READ.paired(a, b)} |")


def draw(data: dict[str, dict[int, dict[str, Any]]], seeds: list[int], at: int, path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    steps = np.asarray(data["blind"][seeds[0]]["eval"]["timesteps"])
    styles = {"oracle": "C3-", "blind": "C0-", "early": "C3--", "late": "C0--"}
    labels = {
        "oracle": "oracle throughout",
        "blind": "blind throughout",
        "early": "oracle, then blind",
        "late": "blind, then oracle",
    }
    blind = np.array([data["blind"][s]["eval"]["mean_return"] for s in seeds])
    for arm, style in styles.items():
        returns = np.array([data[arm][s]["eval"]["mean_return"] for s in seeds])
        axes[0].plot(steps, returns.mean(0), style, label=labels[arm])
        if arm != "blind":
            mean, half = mean_ci((returns - blind).T, nan_policy="propagate")
            axes[1].plot(steps, mean, style, label=labels[arm])
            axes[1].fill_between(steps, mean - half, mean + half, color=style[:2], alpha=0.1)
    for ax in axes:
        ax.axvline(at, color="grey", lw=0.8, ls=":")
        ax.set_xlabel("environment steps")
    axes[1].axhline(0, color="grey", lw=0.8)
    axes[0].set_ylabel(f"evaluation return, mean of {len(seeds)} seeds")
    axes[1].set_ylabel("minus blind throughout, paired [95 % t]")
    axes[0].set_title("WallMaze-v0: the oracle switched at the dotted line")
    axes[1].set_title("difference from the blind critic")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--root", default="", help="the set of runs (a folder of the screen's; '' the published)"
    )
    parser.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS))
    parser.add_argument("--arms", nargs="+", choices=list(ARMS), default=list(ARMS))
    parser.add_argument("--at", type=int, default=AT, help="step at which the critic switches")
    parser.add_argument("--read", action="store_true", help="print the reading, train nothing")
    parser.add_argument("--plot", type=Path, default=None, help="with --read: the figure")
    args = parser.parse_args()
    if args.read:
        read(args.root, args.at, args.plot)
    else:
        train(args.root, tuple(args.seeds), args.arms, args.at, args.workers)


if __name__ == "__main__":
    main()
