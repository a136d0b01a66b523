"""The reading of ``PLAN.md``: exact GPs against the on-line GP critic on Acrobot's batches.

The two halves of the seeds ran as two calls of ``examples/adaptation_schedule.py`` (one per
core), each writing its own folder::

    python examples/adaptation_schedule.py --envs Acrobot-v1 --seeds 0 2 4 6 8 \\
        --timesteps 30000 --settings '{"default": {}}' --mlp --batch --exact \\
        --streams STREAMS --out results/model_ceiling/a
    python examples/adaptation_schedule.py --envs Acrobot-v1 --seeds 1 3 5 7 9 \\
        --timesteps 30000 --settings '{"default": {}}' --mlp --batch --exact \\
        --streams STREAMS --out results/model_ceiling/b
    python results/model_ceiling/extra.py STREAMS results/model_ceiling/c
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
#: The readings ``PLAN.md`` fixed (first minus second), then those reported beside them.
PLANNED = ((LAPLACE, DEFAULT), (RBF, LAPLACE), (TWO, LAPLACE))
BESIDE = (
    (ONLINE, DEFAULT),
    (SCHEDULE.BATCH_ONLINE, DEFAULT),
    (ONLINE, SCHEDULE.BATCH_ONLINE),
    (LAPLACE, ONLINE),
    (ONLINE_TWO, ONLINE),
    (SCHEDULE.BATCH, SCHEDULE.BATCH_ONLINE),
    (SCHEDULE.BATCH_EUCLIDEAN, SCHEDULE.BATCH),
    (SCHEDULE.MLP, DEFAULT),
)


def merged() -> dict[str, dict[str, Any]]:
    """Per seed, every predictor's result: both halves of the seeds, then the added row."""
    out: dict[str, dict[str, Any]] = {}
    for half in ("a", "b"):
        out.update(json.loads((HERE / half / "results.json").read_text())["results"][ENV])
    extra = json.loads((HERE / "c" / "results.json").read_text())["results"][ENV]
    for seed, rows in extra.items():
        out[seed].update(rows)
    return out


def paired(by_seed: dict[str, dict[str, Any]], first: str, second: str) -> str:
    """Mean paired difference of the tail scores with its 95 % t interval."""
    diff = np.array([r[first]["tail"] - r[second]["tail"] for r in by_seed.values()])
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    return f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]"


def verdict(interval: str) -> str:
    """``PLAN.md``'s rule for the first reading."""
    low, high = (float(v) for v in interval.split("[")[1].rstrip("]").split(","))
    if low > 0.05:
        return "the on-line approximation loses fit the model allows"
    if low >= -0.05 and high <= 0.05:
        return "the model with these data is the limit"
    return "inconclusive"


def report(by_seed: dict[str, dict[str, Any]]) -> str:
    names = list(next(iter(by_seed.values())))
    lines = [
        f"# Exact GPs against the on-line GP critic, {ENV}, seeds {sorted(map(int, by_seed))}",
        "",
        "Explained variance of the fed targets by each predictor before it learns the batch,",
        "mean over the last 20 % of scored batches, then over seeds (lowest, highest).",
        "",
        "| predictor | score | lowest | highest |",
        "|---|---:|---:|---:|",
    ]
    for name in names:
        tails = [r[name]["tail"] for r in by_seed.values()]
        lines.append(f"| {name} | {np.mean(tails):.3f} | {min(tails):.3f} | {max(tails):.3f} |")
    lines += ["", "| reading | paired by seed [95 % t] |", "|---|---|"]
    for first, second in PLANNED + BESIDE:
        lines.append(f"| {first} − {second} | {paired(by_seed, first, second)} |")
    lines += [
        "",
        f"Planned rule on the first reading: {verdict(paired(by_seed, LAPLACE, DEFAULT))}.",
    ]
    return "\n".join(lines) + "\n"


def plot(by_seed: dict[str, dict[str, Any]], path: Path) -> None:
    """Mean score per batch for every predictor (clipped at -1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9.5, 4.6))
    for k, name in enumerate(next(iter(by_seed.values()))):
        curves = np.array([r[name]["explained_variance"] for r in by_seed.values()])
        batches = np.arange(1, curves.shape[1] + 1)
        ax.plot(batches, np.clip(curves.mean(0), -1, 1), "o-", color=f"C{k}", label=name)
    ax.set(xlabel="batch (rollout of 4,096 states) predicted", ylabel="explained variance")
    ax.set_title(f"{ENV}, PPO 30,000 steps: each predictor on the batch it has not seen (10 seeds)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    by_seed = merged()
    print(report(by_seed), end="")
    if args.plot is not None:
        plot(by_seed, args.plot)


if __name__ == "__main__":
    main()
