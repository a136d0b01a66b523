"""The reading of ``PLAN.md`` and ``ADDENDUM.md``: exact GPs against the on-line GP critic on
Acrobot's batches, for two recorded critics.

Part 1, the comparison's geodesic critic fed SB3's returns (the script's default recording):
two calls of ``examples/adaptation_schedule.py`` (one per core), then the added row::

    python examples/adaptation_schedule.py --envs Acrobot-v1 --seeds 0 2 4 6 8 \\
        --timesteps 30000 --settings '{"default": {}}' --mlp --batch --exact \\
        --streams STREAMS --out results/model_ceiling/a
    python examples/adaptation_schedule.py --envs Acrobot-v1 --seeds 1 3 5 7 9 \\
        --timesteps 30000 --settings '{"default": {}}' --mlp --batch --exact \\
        --streams STREAMS --out results/model_ceiling/b
    python results/model_ceiling/extra.py STREAMS results/model_ceiling/c

Part 2, the drop-in PPO default (``laplacian.py``, folders ``laplacian_a`` to ``laplacian_d``;
its docstring has the commands). Then::

    python results/model_ceiling/read.py --plot results/model_ceiling/read.png \\
        > results/model_ceiling/read.md
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
SCHEDULE = load_script(HERE.parents[1] / "examples" / "adaptation_schedule.py", "schedule")
ENV = "Acrobot-v1"
DEFAULT = "default"
LAPLACE, RBF, TWO, ONLINE, ONLINE_TWO = SCHEDULE.EXACT
#: The decomposition, one change at a time (first minus second), read in both parts.
STEPS = (
    (LAPLACE, DEFAULT),
    (SCHEDULE.BATCH_ONLINE, DEFAULT),
    (ONLINE, SCHEDULE.BATCH_ONLINE),
    (LAPLACE, ONLINE),
    (SCHEDULE.MLP, DEFAULT),
)
#: Part 1's other readings: ``PLAN.md``'s fixed ones, then those reported beside them.
MORE = (
    (RBF, LAPLACE),
    (TWO, LAPLACE),
    (ONLINE_TWO, ONLINE),
    (SCHEDULE.BATCH, SCHEDULE.BATCH_ONLINE),
    (SCHEDULE.BATCH_EUCLIDEAN, SCHEDULE.BATCH),
)
BySeed = dict[str, dict[str, Any]]


def load(*folders: str) -> BySeed:
    """Per seed, every predictor's result, merged over ``folders`` (seeds or rows)."""
    out: BySeed = {}
    for folder in folders:
        rows = json.loads((HERE / folder / "results.json").read_text())["results"][ENV]
        for seed, row in rows.items():
            out.setdefault(seed, {}).update(row)
    return out


def paired(by_seed: BySeed, first: str, second: str) -> tuple[float, float, float]:
    """Mean paired difference of the tail scores and its 95 % t interval (mean, low, high)."""
    diff = np.array([r[first]["tail"] - r[second]["tail"] for r in by_seed.values()])
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    return mean, mean - half, mean + half


def shown(interval: tuple[float, float, float]) -> str:
    mean, low, high = interval
    return f"{mean:+.3f} [{low:+.3f}, {high:+.3f}]"


def verdict(interval: tuple[float, float, float]) -> str:
    """``PLAN.md``'s rule for its first reading."""
    _, low, high = interval
    if low > 0.05:
        return "the on-line approximation loses fit the model allows"
    if low >= -0.05 and high <= 0.05:
        return "the model with these data is the limit"
    return "inconclusive"


def report(by_seed: BySeed, title: str, readings: tuple[tuple[str, str], ...]) -> str:
    names = list(next(iter(by_seed.values())))
    lines = [
        f"## {title}",
        "",
        f"{ENV}, seeds {sorted(map(int, by_seed))}. Explained variance of the fed targets by",
        "each predictor before it learns the batch, mean over the last 20 % of scored",
        "batches, then over seeds (lowest, highest).",
        "",
        "| predictor | score | lowest | highest |",
        "|---|---:|---:|---:|",
    ]
    for name in names:
        tails = [r[name]["tail"] for r in by_seed.values()]
        lines.append(f"| {name} | {np.mean(tails):.3f} | {min(tails):.3f} | {max(tails):.3f} |")
    lines += ["", "| reading | paired by seed [95 % t] |", "|---|---|"]
    for first, second in readings:
        lines.append(f"| {first} − {second} | {shown(paired(by_seed, first, second))} |")
    rule = verdict(paired(by_seed, LAPLACE, DEFAULT))
    lines += ["", f"`PLAN.md`'s rule on exact (maximum likelihood) − default: {rule}.", ""]
    return "\n".join(lines) + "\n"


def plot(parts: dict[str, BySeed], path: Path) -> None:
    """Mean score per batch for every predictor (clipped at -1), one panel per part."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(parts), figsize=(7.5 * len(parts), 6.0), squeeze=False)
    names = dict.fromkeys(n for by_seed in parts.values() for n in next(iter(by_seed.values())))
    colours = {name: f"C{k}" for k, name in enumerate(names)}
    for ax, (title, by_seed) in zip(axes[0], parts.items(), strict=True):
        for name in next(iter(by_seed.values())):
            scores = [r[name]["explained_variance"] for r in by_seed.values()]
            # Monte Carlo feeds end episodes, not rollouts: runs differ in their batch counts
            curves = np.full((len(scores), max(map(len, scores))), np.nan)
            for row, score in zip(curves, scores, strict=True):
                row[: len(score)] = score
            batches = np.arange(1, curves.shape[1] + 1)
            mean = np.clip(np.nanmean(curves, axis=0), -1, 1)
            ax.plot(batches, mean, "o-", color=colours[name], label=name, ms=4)
        ax.set(xlabel="batch predicted (in feeding order)", title=title)
        ax.set_ylim(-1.05, 1.0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5, loc="lower right")
    axes[0][0].set_ylabel("explained variance of the fed targets (mean over seeds)")
    fig.suptitle(f"{ENV}, PPO 30,000 steps: each predictor on the batch it has not yet seen")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    parts = {
        "the drop-in PPO default (Laplacian, Monte Carlo targets)": (
            load("laplacian_a", "laplacian_b", "laplacian_c", "laplacian_d"),
            (*STEPS, (ONLINE_TWO, ONLINE), (ONLINE_TWO, DEFAULT)),
        ),
        "the comparison's geodesic critic fed SB3's returns": (
            load("a", "b", "c"),
            STEPS + MORE,
        ),
    }
    print("# Exact GPs against the on-line GP critic on Acrobot's batches\n")
    for title, (by_seed, readings) in parts.items():
        print(report(by_seed, title, readings))
    if args.plot is not None:
        plot({title: by_seed for title, (by_seed, _) in parts.items()}, args.plot)


if __name__ == "__main__":
    main()
