"""Issue 13's 40-seed table at every checkpoint (session 35; secondary, read after the primary).

The primary reading of ``PREREGISTRATION.md`` is the final return. This script reads the same
runs (``pool30.py --a2c 0.17 --add fresh40``) along the whole learning curve: for each cell the
default GP critic − SB3's MLP critic, difference of mean evaluation returns at every checkpoint
with its 95 % percentile-bootstrap band, and the area under the curve (the sweep's
``mean_return`` metric) with the published rule (95 %, Bonferroni at 42 comparisons).

    python results/table40/checkpoints.py --plot results/table40/checkpoints.png \
        > results/table40/checkpoints.md
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "replication_0_15"))
from pool30 import mlp_rows, pooled_runs

from sb3_geogp.comparison.report import pyplot
from sb3_geogp.comparison.results import group_runs, stack_curves
from sb3_geogp.toolbox.stats import difference_ci

DEFAULT_CRITIC = {"ppo": "laplacian", "a2c": "geodesic"}


Curves = tuple[np.ndarray, np.ndarray, np.ndarray]


def cell_curves(runs: list[dict]) -> dict[tuple[str, str], Curves]:
    """``(env, algo)`` -> (timesteps, GP curves, MLP curves), curves of shape (n_seeds, T)."""
    groups = group_runs(runs)
    out = {}
    for env, algo, critic in sorted(groups, key=lambda k: (k[1], k[0])):
        if critic != "mlp":
            continue
        t, mlp = stack_curves(groups[(env, algo, "mlp")])
        gp_runs = groups[(env, algo, DEFAULT_CRITIC[algo])]
        # the GP runs on the MLP runs' checkpoints (they differ by a rollout at most)
        rows = [np.interp(t, r["eval"]["timesteps"], r["eval"]["mean_return"]) for r in gp_runs]
        out[(env, algo)] = (t, np.stack(rows), mlp)
    return out


def stretches(t: np.ndarray, low: np.ndarray, high: np.ndarray) -> str:
    """The checkpoints at which the 95 % band excludes zero, as ``better 1.5k-4.5k; worse 9.0k``."""
    sign = np.where(low > 0, 1, np.where(high < 0, -1, 0))
    parts, start, said = [], 0, 0
    for i in range(1, len(t) + 1):
        if i == len(t) or sign[i] != sign[start]:
            if sign[start] != 0:
                first, last = f"{t[start] / 1e3:.1f}k", f"{t[i - 1] / 1e3:.1f}k"
                word = "" if sign[start] == said else ("better " if sign[start] > 0 else "worse ")
                parts.append(word + first + ("" if first == last else f"-{last}"))
                said = sign[start]
            start = i
    return "; ".join(parts) or "no checkpoint"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG", help="draw the differences per checkpoint")
    args = parser.parse_args()
    runs = pooled_runs("0.17", ("fresh40",))
    auc = mlp_rows(runs, "mean_return")
    curves = cell_curves(runs)
    print(
        "| algo | env | GP − MLP, area under the curve [95 % CI] | verdict (95 % / family-wise) "
        "| checkpoints where the 95 % band excludes 0 |"
    )
    print("|---|---|---|---|---|")
    counts = {"better": 0, "no difference": 0, "worse": 0}
    fw_counts = dict(counts)
    bands = {}
    for (env, algo), (t, gp, mlp) in curves.items():
        diff, low, high = difference_ci(gp, mlp, level=0.95)
        bands[(env, algo)] = (t, diff, low, high)
        c = auc[(env, algo)]
        counts[c["verdict"]] += 1
        fw_counts[c["fw_verdict"]] += 1
        print(
            f"| {algo.upper()} | {env.split('/')[-1]} | {c['diff']:+.1f} [{c['low']:+.1f}, "
            f"{c['high']:+.1f}] | {c['verdict']} / {c['fw_verdict']} | "
            f"{stretches(t, low, high)} |"
        )
    print(f"\ncounts at 95 %: {counts}; family-wise: {fw_counts}")
    if args.plot:
        plot(bands, args.plot)


def plot(bands: dict, path: str) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(2, 7, figsize=(17, 5.2), squeeze=False)
    for ax, ((env, algo), (t, diff, low, high)) in zip(axes.flat, bands.items(), strict=True):
        ax.fill_between(t / 1e3, low, high, color="C0", alpha=0.25, lw=0)
        ax.plot(t / 1e3, diff, color="C0", lw=1.5)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_title(f"{env.split('/')[-1]}, {algo.upper()}", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("timesteps (thousands)", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("GP − MLP, evaluation return", fontsize=8)
    fig.suptitle(
        "default GP critic − SB3's MLP critic at every checkpoint, 40 seeds per cell "
        "(line: difference of means; band: 95 % percentile bootstrap)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
