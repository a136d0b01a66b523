"""Tables of ``results/heldout_advantage/run.py``'s runs: per arm and critic, each score's mean
over seeds (each seed's mean over its scored rollouts in a stretch of training) and the paired
difference from the shadow MLP critic [95 % t interval over seeds].

    python results/heldout_advantage/read.py > results/heldout_advantage/read.md
    python results/heldout_advantage/read.py --runs results/heldout_advantage/runs_start \
        --figure results/heldout_advantage/correlation.png
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.report import pyplot
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
#: Stretches of training (environment steps at the rollout's end).
STRETCHES = ((0, 50_000), (0, 10_000), (10_000, 25_000), (25_000, 50_000))
#: Scores of :func:`~sb3_geogp.studies.advantage_error.advantage_scores` (values in return
#: units, the shadow's scaled back by its reward normalisation; its advantages are in
#: normalised units, so slopes would not compare).
SCORES = ("correlation", "value_rmse", "value_bias", "value_spread")
SHADOW = "mlp_shadow"


def load(runs: Path) -> dict[str, list[dict[str, Any]]]:
    """Runs by arm, in seed order."""
    by_arm: dict[str, list[dict[str, Any]]] = {}
    for path in sorted(runs.glob("*.json")):
        run = json.loads(path.read_text())
        by_arm.setdefault(run["arm"], []).append(run)
    return {arm: sorted(rs, key=lambda r: r["seed"]) for arm, rs in by_arm.items()}


#: Scores of the shadow MLP critic in return units, not a critic of its own.
RETURN_UNITS = "mlp_shadow_return_units"


def critics(run: dict[str, Any]) -> list[str]:
    return [k for k, v in run["rows"][0].items() if isinstance(v, dict) and k != RETURN_UNITS]


def per_seed(
    runs: list[dict[str, Any]],
    critic: str,
    score: str,
    lo: float,
    hi: float,
    stat: Callable[[list[float]], float] = np.nanmean,
) -> np.ndarray:
    """Each run's ``stat`` (mean) of ``score`` over its rollouts scored in ``[lo, hi)`` (NaN if
    none)."""
    out = []
    for run in runs:
        rows = [r for r in run["rows"] if lo <= r["step"] < hi]
        vals = [r[critic][score] for r in rows if r[critic][score] is not None]
        out.append(stat(vals) if vals else np.nan)
    return np.array(out, dtype=float)


def ceiling(runs: list[dict[str, Any]], lo: int, hi: int) -> float:
    """The correlation's ceiling by the reference's Monte Carlo noise, ``sqrt`` of its
    split-half reliability, averaged over the stretch's rollouts and the seeds."""
    rel = [r["reliability"] for run in runs for r in run["rows"] if lo <= r["step"] < hi]
    return float(np.nanmean(np.sqrt(np.clip(rel, 0.0, None))))


def cell(x: np.ndarray) -> str:
    mean, half = (float(v) for v in mean_ci(x, nan_policy="omit"))
    return f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]"


def table(by_arm: dict[str, list[dict[str, Any]]]) -> str:
    lines = []
    for arm, runs in by_arm.items():
        seeds = [r["seed"] for r in runs]
        lines += [
            f"## `{arm}`: {len(runs)} seeds ({min(seeds)}-{max(seeds)})",
            "",
            "| steps | critic | scored rollouts | "
            + " | ".join(f"{s} | − shadow MLP" for s in SCORES)
            + " |",
            "|---|---|---:|" + "---:|---|" * len(SCORES),
        ]
        for lo, hi in STRETCHES:
            n = sum(lo <= r["step"] < hi for run in runs for r in run["rows"])
            if not n:
                continue
            shadow = {s: per_seed(runs, SHADOW, s, lo, hi) for s in SCORES}
            for critic in critics(runs[0]):
                cells = []
                for s in SCORES:
                    x = per_seed(runs, critic, s, lo, hi)
                    diff = "–" if critic == SHADOW else cell(x - shadow[s])
                    cells.append(f"{np.nanmean(x):.3f} | {diff}")
                lines.append(f"| {lo:,}-{hi:,} | {critic} | {n} | " + " | ".join(cells) + " |")
            lines.append(
                f"| {lo:,}-{hi:,} | ceiling (Monte Carlo noise) | | {ceiling(runs, lo, hi):.3f} |"
                + " |" * (2 * len(SCORES) - 1)
            )
        returns = [np.mean(r["last_episodes"]) for r in runs]
        lines += [
            "",
            f"Last five training episodes' return, mean over seeds: {np.mean(returns):.0f}",
            "",
        ]
    return "\n".join(lines)


#: Steps per bin of the figure's curves.
BIN = 5_000


def figure(by_arm: dict[str, list[dict[str, Any]]], path: Path) -> None:
    """Per arm, each critic's advantage correlation along training (per seed the mean of its
    rollouts in each bin of 5,000 steps, then the mean over seeds), and the Monte Carlo
    ceiling."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(by_arm), figsize=(8 * len(by_arm), 4.8), squeeze=False)
    for ax, (arm, runs) in zip(axes[0], by_arm.items(), strict=True):
        edges = range(0, max(row["step"] for r in runs for row in r["rows"]) + 1, BIN)
        mids = [lo + BIN / 2 for lo in edges]
        for k, critic in enumerate(critics(runs[0])):
            mean = [np.nanmean(per_seed(runs, critic, "correlation", lo, lo + BIN)) for lo in edges]
            style = dict(lw=4, alpha=0.4) if critic == "own" else dict(lw=1.5, marker="o", ms=3)
            ax.plot(mids, mean, color=f"C{k}", label=critic, **style)
        ceiling_curve = [ceiling(runs, lo, lo + BIN) for lo in edges]
        ax.plot(mids, ceiling_curve, "k:", label="ceiling (Monte Carlo noise)")
        ax.axhline(0, color="grey", lw=0.8)
        ax.set(
            xlabel="environment steps",
            ylabel="correlation with V^pi's GAE advantages",
            title=f"PPO with `{arm}`'s critic: {len(runs)} seeds, the same rollouts",
        )
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("InvertedPendulum-v5: each critic's advantages against those of V^pi")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def provenance_lines(by_arm: dict[str, list[dict[str, Any]]]) -> str:
    """Which commits made the runs."""
    counts: dict[str, int] = {}
    for runs in by_arm.values():
        for run in runs:
            p = run["provenance"]
            key = f"commit {p['git_commit'][:8]} (uncommitted changes: {p['git_dirty']})"
            counts[key] = counts.get(key, 0) + 1
    return "\n".join(f"- {n} runs at {k}" for k, n in counts.items())


def slopes(by_arm: dict[str, list[dict[str, Any]]], lo: int = 10_000) -> str:
    """Where the runs score the shadow MLP critic in return units: per critic, how much of the
    reference its advantages hold (``advantage_slope``) and what they add beside it
    (``advantage_residual``, in units of the reference's spread), each seed's median over its
    rollouts from ``lo`` steps on, then the mean over seeds [95 % t]."""
    lines = []
    for arm, runs in by_arm.items():
        if RETURN_UNITS not in runs[0]["rows"][0]:
            continue
        lines += [
            f"## `{arm}`: the parts of the advantages, from {lo:,} steps on",
            "",
            "| critic | slope on the reference | residual |",
            "|---|---|---|",
        ]
        for critic in [RETURN_UNITS, *(c for c in critics(runs[0]) if c != SHADOW)]:
            cells = []
            for part in ("advantage_slope", "advantage_residual"):
                x = per_seed(runs, critic, part, lo, math.inf, np.nanmedian)
                mean, half = (float(v) for v in mean_ci(x, nan_policy="omit"))
                cells.append(f"{mean:.3f} [{mean - half:.3f}, {mean + half:.3f}]")
            lines.append(f"| {critic} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=HERE / "runs")
    parser.add_argument("--figure", type=Path, help="draw the correlations here instead")
    args = parser.parse_args()
    by_arm = load(args.runs)
    if args.figure is not None:
        figure(by_arm, args.figure)
        return
    print("# PPO InvertedPendulum-v5: each critic's advantages against those of V^pi\n")
    print(table(by_arm))
    if parts := slopes(by_arm):  # runs scored before the return units have none
        print(parts)
    print("## What the runs executed\n")
    print(provenance_lines(by_arm))


if __name__ == "__main__":
    main()
