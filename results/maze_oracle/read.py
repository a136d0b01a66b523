"""The maze oracle screen's reading (``PLAN.md``): paired by seed, oracle − blind and
oracle − laplacian, critic RMSE (primary), final return and area under the curve.

    python results/maze_oracle/read.py --plot results/maze_oracle/screen.png \\
        > results/maze_oracle/read.md

``--under confirm --arms oracle blind`` reads the confirmation (``run.py``'s docstring).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
ARMS = ("oracle", "blind", "laplacian")
ENVS = ("sb3_geogp/WallMaze-v0", "sb3_geogp/WallMazeDiscrete-v0")

Metric = Callable[[dict[str, Any]], float]
METRICS: dict[str, tuple[Metric, str]] = {
    "critic RMSE, mean over checkpoints": (
        lambda r: float(np.mean(r["critic_accuracy"]["rmse"][1:])),
        "lower is better",
    ),
    "critic RMSE, final": (lambda r: float(r["critic_accuracy"]["rmse"][-1]), "lower is better"),
    "final return": (lambda r: float(r["final_return"]), "higher is better"),
    "area under the curve (mean return over checkpoints)": (
        lambda r: float(np.mean(r["eval"]["mean_return"])),
        "higher is better",
    ),
}


Runs = dict[str, dict[str, dict[int, dict[str, Any]]]]


def runs(under: str = "", arms: tuple[str, ...] = ARMS) -> Runs:
    """``runs[arm][env][seed]``."""
    out: Runs = {}
    for arm in arms:
        folder = HERE / under / arm
        found = load_results(folder) if folder.is_dir() else []
        out[arm] = {
            env: {r["spec"]["seed"]: r for r in found if r["spec"]["env_id"] == env} for env in ENVS
        }
    return out


def paired(a: np.ndarray, b: np.ndarray, digits: int = 2) -> str:
    """Mean of ``a - b`` (paired by seed) with its 95 % Student-t interval."""
    mean, half = (float(v) for v in mean_ci(a - b, nan_policy="propagate"))
    return f"{mean:+.{digits}f} [{mean - half:+.{digits}f}, {mean + half:+.{digits}f}]"


def table(data: Runs) -> None:
    """Per metric and task: each arm's mean and the oracle's paired difference from the others."""
    arms, others = list(data), [a for a in data if a != "oracle"]
    for name, (metric, sense) in METRICS.items():
        print(f"\n### {name} ({sense})\n")
        diffs = "".join(f" oracle − {a} [95 % t] |" for a in others)
        print(f"| task | seeds |{''.join(f' {a} |' for a in arms)}{diffs}")
        print("|---|---:|" + "---:|" * len(arms) + "---|" * len(others))
        for env in ENVS:
            seeds = sorted(set.intersection(*(set(data[arm][env]) for arm in arms)))
            if not seeds:
                continue
            v = {arm: np.array([metric(data[arm][env][s]) for s in seeds]) for arm in arms}
            means = "".join(f" {v[arm].mean():.2f} |" for arm in arms)
            pairs = "".join(f" {paired(v['oracle'], v[a])} |" for a in others)
            print(f"| `{env.split('/')[-1]}` | {len(seeds)} |{means}{pairs}")


def plot(data: Runs, path: str) -> None:
    envs = [env for env in ENVS if any(data[arm][env] for arm in data)]
    fig, axes = plt.subplots(
        2, len(envs), figsize=(5.5 * len(envs), 7), layout="constrained", squeeze=False
    )
    for col, env in enumerate(envs):
        for arm in data:
            found = list(data[arm][env].values())
            if not found:
                continue
            for row, (key, steps) in enumerate(
                ((("critic_accuracy", "rmse"), ("critic_accuracy", "timesteps")),
                 (("eval", "mean_return"), ("eval", "timesteps")))
            ):  # fmt: skip
                y = np.array([r[key[0]][key[1]] for r in found], dtype=float)
                x = np.array(found[0][steps[0]][steps[1]], dtype=float)
                mean, half = mean_ci(y.T, nan_policy="propagate")  # over seeds
                ax = axes[row, col]
                (line,) = ax.plot(x, mean, marker="o", ms=3, label=f"{arm} ({len(found)} seeds)")
                ax.fill_between(x, mean - half, mean + half, color=line.get_color(), alpha=0.15)
        axes[0, col].set_title(f"{env.split('/')[-1]}: critic RMSE vs Monte Carlo", fontsize=10)
        axes[1, col].set_title(f"{env.split('/')[-1]}: evaluation return", fontsize=10)
        axes[1, col].set_xlabel("timesteps")
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
    fig.suptitle(
        "PPO, geodesic critic with and without the wall oracle\n(mean over seeds, 95 % t band)"
    )
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG")
    parser.add_argument("--under", default="", help="subfolder of the arms' folders")
    parser.add_argument("--arms", nargs="+", choices=ARMS, default=list(ARMS))
    args = parser.parse_args()
    data = runs(args.under, tuple(args.arms))
    seeds = sorted({s for arm in data.values() for env in arm.values() for s in env})
    print(f"## Maze oracle {args.under or 'screen'} (session 50, exploratory): PPO, 30,000 "
          f"steps, seeds {seeds[0]}-{seeds[-1]}")  # fmt: skip
    table(data)
    if args.plot:
        plot(data, args.plot)


if __name__ == "__main__":
    main()
