"""The reading fixed in PREREGISTRATION.md: 0.23's PPO default (the lengthscale hyperprior)
at 100,000 steps on fresh seeds 220-239, against 0.22's default and SB3's MLP critic
(session 39).

Arms: 0.23, the default GP critic (``s<F>``, critic ``laplacian``); 0.22, the same without the
prior (``without_prior_s<F>``); SB3's MLP critic (``s<F>``). Only whole blocks of 10 seeds are
read (every arm, cell and seed of the block finished), so a partial sweep reads as such.

    python results/budget100k_0_23/read.py --plot results/budget100k_0_23/curves.png \
        > results/budget100k_0_23/read.md
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.report import pyplot
from sb3_geogp.comparison.results import METRICS, comparisons, pool_sweeps
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "budget100k"))
sys.path.insert(0, str(HERE.parent / "replication_0_15"))
from falls import counts  # noqa: E402
from pool30 import print_table  # noqa: E402

BLOCKS = (220, 230)
ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")
ARMS = ("0.23", "0.22", "MLP")
#: An arm's runs: its folder prefix and critic.
SOURCES = {"0.23": ("s", "laplacian"), "0.22": ("without_prior_s", "laplacian"),
           "MLP": ("s", "mlp")}  # fmt: skip
Runs = dict[str, dict[tuple[str, int], dict[str, Any]]]


def arm_runs(arm: str, block: int) -> dict[tuple[str, int], dict[str, Any]]:
    """One arm's runs of one block, by (env, seed)."""
    prefix, critic = SOURCES[arm]
    folder = HERE / f"{prefix}{block}"
    runs = pool_sweeps([folder]) if folder.is_dir() else []
    return {(r["spec"]["env_id"], r["spec"]["seed"]): r for r in runs
            if r["spec"]["critic"] == critic}  # fmt: skip


def whole_blocks() -> tuple[Runs, list[int]]:
    """Every arm's runs on the blocks that all arms finished, and those blocks."""
    runs: Runs = {arm: {} for arm in ARMS}
    done = []
    for block in BLOCKS:
        by_arm = {arm: arm_runs(arm, block) for arm in ARMS}
        if all(len(r) == len(ENVS) * 10 for r in by_arm.values()):
            done.append(block)
            for arm in ARMS:
                runs[arm].update(by_arm[arm])
    return runs, done


def paired(runs: Runs, a: str, b: str, env: str) -> str:
    """``a − b`` in ``env``, paired by seed: final return and area, 95 % t intervals."""
    seeds = sorted(s for e, s in runs[a] if e == env)
    cells = [f"| {a} − {b} | `{env}` | {len(seeds)}"]
    for metric in (METRICS["final_return"].of_run, METRICS["mean_return"].of_run):
        d = np.array([metric(runs[a][env, s]) - metric(runs[b][env, s]) for s in seeds])
        mean, half = mean_ci(d, nan_policy="propagate")
        cells.append(f"{mean:+.1f} [{mean - half:+.1f}, {mean + half:+.1f}]")
    return " | ".join(cells) + " |"


def against_mlp(runs: Runs, arm: str, metric: str) -> dict[tuple[str, str], dict[str, Any]]:
    """``arm`` − MLP per cell, the comparison's statistics, family-wise over the 3 cells."""
    rows = comparisons(list(runs[arm].values()) + list(runs["MLP"].values()), family_size=3)
    return {(c["env"], c["algo"]): c for c in rows if c["metric"] == metric}


def arm_row(runs: Runs, arm: str) -> str:
    """Per arm: CartPole falls, Acrobot runs ending at -500, median steps to each threshold."""
    cartpole = [r for (e, _), r in runs[arm].items() if e == "CartPole-v1"]
    _, reached, fell = counts(cartpole, SOURCES[arm][1])
    capped = sum(r["final_return"] <= -500 for (e, _), r in runs[arm].items() if e == "Acrobot-v1")
    cells = [f"| {arm} | {len(fell)} of {reached} ({', '.join(map(str, fell)) or '–'})",
             f"{capped}"]  # fmt: skip
    for env in ENVS:
        steps = [r["steps_to_threshold"] for (e, _), r in runs[arm].items() if e == env]
        hit = [s for s in steps if s is not None]
        median = f"{np.median(hit):,.0f}" if hit else "–"
        cells.append(f"{median} ({len(hit)} of {len(steps)})")
    return " | ".join(cells) + " |"


def plot(runs: Runs, path: str, blocks: list[int]) -> None:
    """Each cell: every run's evaluation curve per arm (thin) and the arm's mean (bold)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(ENVS), figsize=(4.6 * len(ENVS), 3.8))
    colours = {"0.23": "tab:blue", "0.22": "tab:orange", "MLP": "0.35"}
    for ax, env in zip(axes, ENVS, strict=True):
        for arm in ARMS:
            mine = [r for (e, _), r in runs[arm].items() if e == env]
            t = np.array(mine[0]["eval"]["timesteps"])
            curves = np.array([r["eval"]["mean_return"] for r in mine])
            for curve in curves:
                ax.plot(t, curve, color=colours[arm], lw=0.4, alpha=0.35)
            ax.plot(t, curves.mean(axis=0), color=colours[arm], lw=2.2,
                    label=f"{arm} (mean of {len(mine)})")  # fmt: skip
        ax.set(title=env, xlabel="timesteps")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("evaluation return (10 episodes)")
    axes[0].legend(fontsize=8, loc="lower right")
    seeds = f"{blocks[0]}-{blocks[-1] + 9}"
    fig.suptitle(f"PPO, 100,000 steps, seeds {seeds}: 0.23's default GP critic (hyperprior), "
                 "0.22's, SB3's MLP critic", fontsize=10)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG", help="also draw every run's curve per arm")
    args = parser.parse_args(argv)
    runs, blocks = whole_blocks()
    if not blocks:
        sys.exit("no block of 10 seeds has finished in every arm yet")
    partial = "" if len(blocks) == len(BLOCKS) else " (PARTIAL: not every block has finished)"
    print(f"PPO, 100,000 steps, seed blocks {', '.join(f'{b}-{b + 9}' for b in blocks)}"
          f"{partial}.\n")  # fmt: skip
    print("**Primary** (paired by seed, 95 % t):\n")
    header = (
        "| difference | cell | seeds | final return [95 % CI] | area under the curve [95 % CI] |"
    )
    print(header + "\n|---|---|---:|---|---|")
    print(paired(runs, "0.23", "0.22", "CartPole-v1"))
    print("\n**Co-primary**: 0.23 − MLP, final return, family-wise over these 3 cells:\n")
    print_table(against_mlp(runs, "0.23", "final_return"), "final return", "0.23 − MLP")
    print("\nSecondary: the same pairs elsewhere and on the area under the curve.\n")
    print(header + "\n|---|---|---:|---|---|")
    for env in ("Pendulum-v1", "Acrobot-v1"):
        print(paired(runs, "0.23", "0.22", env))
    print()
    print_table(against_mlp(runs, "0.22", "final_return"), "final return", "0.22 − MLP")
    for arm in ("0.23", "0.22"):
        print()
        print_table(against_mlp(runs, arm, "mean_return"), "area under the curve", f"{arm} − MLP")
    print("\n| arm | CartPole falls (reach 475, end below 300) | Acrobot runs ending at -500 | "
          + " | ".join(f"median steps to threshold, {e}" for e in ENVS) + " |")  # fmt: skip
    print("|---|---|---:|" + "---|" * len(ENVS))
    for arm in ARMS:
        print(arm_row(runs, arm))
    if args.plot:
        plot(runs, args.plot, blocks)


if __name__ == "__main__":
    main()
