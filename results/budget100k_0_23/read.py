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
from dataclasses import dataclass
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
from pool30 import mlp_rows, print_table  # noqa: E402

Runs = dict[str, dict[tuple[str, int], dict[str, Any]]]
ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")


@dataclass(frozen=True)
class Study:
    """A 100,000-step PPO study on ``envs``: its folder, seed blocks, and per arm the folder
    prefix (relative to ``here``) and critic of its runs (``{arm: (prefix, critic)}``) and its
    colour."""

    here: Path
    blocks: tuple[int, ...]
    sources: dict[str, tuple[str, str]]
    colours: dict[str, str]
    envs: tuple[str, ...] = ENVS

    @property
    def arms(self) -> tuple[str, ...]:
        return tuple(self.sources)


STUDY = Study(
    HERE,
    (220, 230),
    {"0.23": ("s", "laplacian"), "0.22": ("without_prior_s", "laplacian"), "MLP": ("s", "mlp")},
    {"0.23": "tab:blue", "0.22": "tab:orange", "MLP": "0.35"},
)


def arm_runs(study: Study, arm: str, block: int) -> dict[tuple[str, int], dict[str, Any]]:
    """One arm's runs of one block, by (env, seed)."""
    prefix, critic = study.sources[arm]
    folder = study.here / f"{prefix}{block}"
    runs = pool_sweeps([folder]) if folder.is_dir() else []
    return {(r["spec"]["env_id"], r["spec"]["seed"]): r for r in runs
            if r["spec"]["critic"] == critic and r["spec"]["env_id"] in study.envs}  # fmt: skip


def whole_blocks(study: Study) -> tuple[Runs, list[int]]:
    """Every arm's runs on the blocks that all arms finished, and those blocks."""
    runs: Runs = {arm: {} for arm in study.arms}
    done = []
    for block in study.blocks:
        by_arm = {arm: arm_runs(study, arm, block) for arm in study.arms}
        if all(len(r) == len(study.envs) * 10 for r in by_arm.values()):
            done.append(block)
            for arm in study.arms:
                runs[arm].update(by_arm[arm])
    return runs, done


def paired(runs: Runs, a: str, b: str, env: str, level: float = 0.95) -> str:
    """``a − b`` in ``env``, paired by seed: final return and area, ``level`` t intervals."""
    seeds = sorted(s for e, s in runs[a] if e == env)
    cells = [f"| {a} − {b} | `{env}` | {len(seeds)}"]
    for metric in (METRICS["final_return"].of_run, METRICS["mean_return"].of_run):
        d = np.array([metric(runs[a][env, s]) - metric(runs[b][env, s]) for s in seeds])
        mean, half = mean_ci(d, level, nan_policy="propagate")
        cells.append(f"{mean:+.1f} [{mean - half:+.1f}, {mean + half:+.1f}]")
    return " | ".join(cells) + " |"


def against_mlp(runs: Runs, arm: str, metric: str) -> dict[tuple[str, str], dict[str, Any]]:
    """``arm`` − MLP per cell, the comparison's statistics, family-wise over the 3 cells."""
    rows = comparisons(list(runs[arm].values()) + list(runs["MLP"].values()), family_size=3)
    return {(c["env"], c["algo"]): c for c in rows if c["metric"] == metric}


def print_against_mlp(runs: Runs, arms: Sequence[str]) -> None:
    """Each of ``arms`` − SB3's MLP critic (arm ``"MLP"``) on the final return and the area
    under the curve, family-wise at the published 42."""
    for arm in arms:
        for metric, label in (
            ("final_return", "final return"),
            ("mean_return", "area under the curve"),
        ):
            print(f"\nSecondary: {arm} − MLP, {label}, family-wise at the published 42:\n")
            rows = mlp_rows(list(runs[arm].values()) + list(runs["MLP"].values()), metric)
            print_table(rows, label, f"{arm} − MLP")


def arm_row(study: Study, runs: Runs, arm: str) -> str:
    """Per arm: CartPole falls, Acrobot runs ending at -500, median steps to each threshold
    over the runs that reached it, with how many did (unlike ``summary_rows``, whose median
    counts the others as never reaching it: quote the counts with these medians)."""
    cells = [f"| {arm}"]
    if "CartPole-v1" in study.envs:
        cartpole = [r for (e, _), r in runs[arm].items() if e == "CartPole-v1"]
        _, reached, fell = counts(cartpole, study.sources[arm][1])
        cells.append(f"{len(fell)} of {reached} ({', '.join(map(str, fell)) or '–'})")
    if "Acrobot-v1" in study.envs:
        acrobot = [r for (e, _), r in runs[arm].items() if e == "Acrobot-v1"]
        cells.append(f"{sum(r['final_return'] <= -500 for r in acrobot)}")
    for env in study.envs:
        steps = [r["steps_to_threshold"] for (e, _), r in runs[arm].items() if e == env]
        hit = [s for s in steps if s is not None]
        median = f"{np.median(hit):,.0f}" if hit else "–"
        cells.append(f"{median} ({len(hit)} of {len(steps)})")
    return " | ".join(cells) + " |"


def print_arm_rows(study: Study, runs: Runs) -> None:
    """:func:`arm_row` of every arm, under its header."""
    columns = {"CartPole-v1": ("CartPole falls (reach 475, end below 300)", "---|"),
               "Acrobot-v1": ("Acrobot runs ending at -500", "---:|")}  # fmt: skip
    counted = [columns[e] for e in columns if e in study.envs]
    print("\n| arm | " + "".join(f"{name} | " for name, _ in counted)
          + " | ".join(f"median steps to threshold, {e}" for e in study.envs) + " |")  # fmt: skip
    print("|---|" + "".join(rule for _, rule in counted) + "---|" * len(study.envs))
    for arm in study.arms:
        print(arm_row(study, runs, arm))


def start(study: Study, argv: Sequence[str] | None, doc: str) -> tuple[Runs, list[int], str | None]:
    """Parse ``--plot``, read the whole blocks (exit if none) and print the heading: the runs,
    the blocks read and the figure's path."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG", help="also draw every run's curve per arm")
    args = parser.parse_args(argv)
    runs, blocks = whole_blocks(study)
    if not blocks:
        sys.exit("no block of 10 seeds has finished in every arm yet")
    partial = "" if len(blocks) == len(study.blocks) else " (PARTIAL: not every block has finished)"
    print(f"PPO, 100,000 steps, seed blocks {', '.join(f'{b}-{b + 9}' for b in blocks)}"
          f"{partial}.\n")  # fmt: skip
    return runs, blocks, args.plot


def finish(study: Study, runs: Runs, figure: str | None, blocks: list[int], what: str) -> None:
    """End a reading: :func:`print_arm_rows`, then, where ``figure`` is a path, :func:`plot` of
    ``what`` there."""
    print_arm_rows(study, runs)
    if figure:
        plot(study, runs, figure, blocks, what)


def paired_header(level: str = "95 %") -> str:
    """Header of :func:`paired`'s rows, its intervals at ``level``."""
    return (
        f"| difference | cell | seeds | final return [{level} CI] | area under the curve "
        f"[{level} CI] |\n|---|---|---:|---|---|"
    )


def plot(study: Study, runs: Runs, path: str, blocks: list[int], what: str) -> None:
    """Each cell: every run's evaluation curve per arm (thin) and the arm's mean (bold)."""
    plt = pyplot()
    width = max(4.6 * len(study.envs), 9.2)  # one panel still fits the title
    fig, grid = plt.subplots(1, len(study.envs), figsize=(width, 3.8), squeeze=False)
    axes = grid[0]
    for ax, env in zip(axes, study.envs, strict=True):
        for arm in study.arms:
            mine = [r for (e, _), r in runs[arm].items() if e == env]
            t = np.array(mine[0]["eval"]["timesteps"])
            curves = np.array([r["eval"]["mean_return"] for r in mine])
            for curve in curves:
                ax.plot(t, curve, color=study.colours[arm], lw=0.4, alpha=0.35)
            ax.plot(t, curves.mean(axis=0), color=study.colours[arm], lw=2.2,
                    label=f"{arm} (mean of {len(mine)})")  # fmt: skip
        ax.set(title=env, xlabel="timesteps")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("evaluation return (10 episodes)")
    axes[0].legend(fontsize=8, loc="lower right")
    seeds = f"{blocks[0]}-{blocks[-1] + 9}"
    fig.suptitle(f"PPO, 100,000 steps, seeds {seeds}: {what}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> None:
    runs, blocks, figure = start(STUDY, argv, __doc__)
    print("**Primary** (paired by seed, 95 % t):\n")
    print(paired_header())
    print(paired(runs, "0.23", "0.22", "CartPole-v1"))
    print("\n**Co-primary**: 0.23 − MLP, final return, family-wise over these 3 cells:\n")
    print_table(against_mlp(runs, "0.23", "final_return"), "final return", "0.23 − MLP")
    print("\nSecondary: the same pairs elsewhere and on the area under the curve.\n")
    print(paired_header())
    for env in ("Pendulum-v1", "Acrobot-v1"):
        print(paired(runs, "0.23", "0.22", env))
    print()
    print_table(against_mlp(runs, "0.22", "final_return"), "final return", "0.22 − MLP")
    for arm in ("0.23", "0.22"):
        print()
        print_table(against_mlp(runs, arm, "mean_return"), "area under the curve", f"{arm} − MLP")
    finish(
        STUDY,
        runs,
        figure,
        blocks,
        "0.23's default GP critic (hyperprior), 0.22's, SB3's MLP critic",
    )


if __name__ == "__main__":
    main()
