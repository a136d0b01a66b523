"""The reading fixed in PREREGISTRATION.md: does ``Adaptation(prior_sd=0.1)`` lower the PPO
CartPole-v1 late fall rate of the default GP critic at 100,000 steps? (session 38)

Arms: B, the default GP critic with the hyperprior (``gp_prior``, seeds 180-219); A, the
default GP critic (``../falls_s180`` and ``s200``); SB3's MLP critic (the same directories).
A fall is ``../falls.py``'s: reach 475 at a checkpoint, end below 300.

    python results/budget100k/prior/read.py --plot results/budget100k/prior/curves.png \
        > results/budget100k/prior/read.md
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.comparison.report import pyplot
from sb3_geogp.comparison.results import METRICS, pool_sweeps
from sb3_geogp.toolbox.stats import mean_ci, steps_to_threshold

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent))
from falls import FALLEN, THRESHOLD, counts  # noqa: E402

SEEDS = tuple(range(180, 220))
RERUN = "A′: GP default, 180-199 re-run here"


def arms() -> dict[str, dict[int, dict[str, Any]]]:
    """Each arm's runs by seed (only the pre-registered seeds)."""
    default = pool_sweeps([HERE.parent / "falls_s180", HERE / "s200"])
    prior = pool_sweeps([HERE / "gp_prior"]) if (HERE / "gp_prior").is_dir() else []
    # Seeds 180-199 of A re-run on the machine that ran B (a control added after the reading).
    here = pool_sweeps([d for d in (HERE / "default_today_s180", HERE / "s200") if d.is_dir()])

    def by_seed(runs: list[dict[str, Any]], critic: str) -> dict[int, dict[str, Any]]:
        mine = (r for r in runs if r["spec"]["critic"] == critic)
        return {r["spec"]["seed"]: r for r in mine if r["spec"]["seed"] in SEEDS}

    return {
        "B: GP, prior_sd=0.1": by_seed(prior, "laplacian"),
        "A: GP default": by_seed(default, "laplacian"),
        "MLP": by_seed(default, "mlp"),
        RERUN: by_seed(here, "laplacian"),
    }


def fall_counts(runs: dict[int, dict[str, Any]]) -> tuple[int, list[int]]:
    """Runs that reached the threshold, and the seeds of those that then fell."""
    critic = next(iter(runs.values()))["spec"]["critic"]
    _, reached, fell = counts(list(runs.values()), critic)
    return reached, fell


def fall_row(name: str, runs: dict[int, dict[str, Any]]) -> tuple[str, int, int]:
    reached, fell = fall_counts(runs)
    curves = [(np.array(r["eval"]["timesteps"]), np.array(r["eval"]["mean_return"]))
              for r in runs.values()]  # fmt: skip
    finals = [c[-1] for _, c in curves]
    steps = [float(steps_to_threshold(t, c, THRESHOLD)) for t, c in curves]
    seeds = ", ".join(map(str, fell)) or "–"
    print(f"| {name} | {len(runs)} | {reached} | {len(fell)} | {seeds} | {np.mean(finals):.1f} | "
          f"{sum(f >= 500 for f in finals)} | {np.median(steps):,.0f} |")  # fmt: skip
    return name, reached, len(fell)


def paired(name: str, a: dict[int, dict[str, Any]], b: dict[int, dict[str, Any]]) -> None:
    """``a - b`` per seed both have: final return and area under the curve (the mean over
    checkpoints), 95 % t intervals."""
    seeds = sorted(set(a) & set(b))
    cells = []
    for metric in (METRICS["final_return"].of_run, METRICS["mean_return"].of_run):
        d = np.array([metric(a[s]) - metric(b[s]) for s in seeds])
        mean, half = mean_ci(d, nan_policy="propagate")
        cells.append(f"{mean:+.1f} [{mean - half:+.1f}, {mean + half:+.1f}]")
    print(f"| {name} | {len(seeds)} | {cells[0]} | {cells[1]} |")


def fisher(first: tuple[str, int, int], second: tuple[str, int, int], alternative: str) -> None:
    (n1, k1, f1), (n2, k2, f2) = first, second
    p = sps.fisher_exact([[f1, k1 - f1], [f2, k2 - f2]], alternative=alternative).pvalue
    print(f"- falls, {n1} ({f1}/{k1}) against {n2} ({f2}/{k2}): one-sided Fisher's exact p "
          f"({alternative}) = {p:.3f}")  # fmt: skip


def plot(runs: dict[str, dict[int, dict[str, Any]]], path: str) -> None:
    """Every run's evaluation curve per arm (a fall shows as a line leaving 500), the mean bold."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(runs), figsize=(4.4 * len(runs), 3.6), sharey=True)
    for ax, (name, by_seed) in zip(axes, runs.items(), strict=True):
        curves = np.array([r["eval"]["mean_return"] for r in by_seed.values()])
        t = next(iter(by_seed.values()))["eval"]["timesteps"]
        _, fell = fall_counts(by_seed)
        for seed, curve in zip(by_seed, curves, strict=True):
            ax.plot(t, curve, color="tab:red" if seed in fell else "0.6", lw=0.7, alpha=0.8)
        ax.plot(t, curves.mean(axis=0), color="k", lw=2, label="mean")
        ax.set(title=f"{name} ({len(by_seed)} seeds)", xlabel="timesteps")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("evaluation return (10 episodes)")
    axes[0].plot([], [], color="tab:red", lw=0.7, label="a run that fell")
    axes[0].legend(fontsize=8, loc="lower right")
    fig.suptitle("PPO CartPole-v1, 100,000 steps, seeds 180-219", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", metavar="PNG", help="also draw every run's curve per arm")
    args = parser.parse_args(argv)
    runs = arms()
    print(f"PPO CartPole-v1, 100,000 steps, seeds {SEEDS[0]}-{SEEDS[-1]}; a fall: reach "
          f"{THRESHOLD:g} at a checkpoint, end below {FALLEN:g}.\n")  # fmt: skip
    print("| arm | runs | reached 475 | fell | seeds that fell | mean final return | ended at 500 "
          "| median steps to 475 |")  # fmt: skip
    print("|---|---:|---:|---:|---|---:|---:|---:|")
    rows = {name: fall_row(name, r) for name, r in runs.items() if r}
    b, a, mlp, rerun = runs.values()
    print("\nPrimary (pre-registered, seeds 180-219 pooled):")
    fisher(rows["B: GP, prior_sd=0.1"], rows["A: GP default"], "less")
    fresh = {k: {s: r for s, r in v.items() if s >= 200} for k, v in runs.items()}
    if fresh["A: GP default"] and fresh["MLP"]:
        print("\nSecondary, fresh seeds 200-219 alone (a second replication of the fall count):")
        a200, mlp200 = (fall_counts(fresh[k]) for k in ("A: GP default", "MLP"))
        fisher(("A", a200[0], len(a200[1])), ("MLP", mlp200[0], len(mlp200[1])), "greater")
    print("\n| difference, paired by seed | seeds | final return [95 % CI] | area under the curve "
          "[95 % CI] |")  # fmt: skip
    print("|---|---:|---|---|")
    paired("B − A", b, a)
    paired("B − MLP", b, mlp)
    paired("A − MLP", a, mlp)
    if len(rerun) == len(SEEDS):
        print("\nControl added after the reading (not pre-registered): A's seeds 180-199 ran on "
              "another machine than B (the same training code, versions and recorded CPU "
              "kernels, runs about 3x as slow); none of them reproduces here bit for bit. A′ "
              "re-runs them on B's machine:\n")  # fmt: skip
        fisher(rows["B: GP, prior_sd=0.1"], rows[RERUN], "less")
        print("\n| difference, paired by seed | seeds | final return [95 % CI] | area under the "
              "curve [95 % CI] |")  # fmt: skip
        print("|---|---:|---|---|")
        paired("B − A′", b, rerun)
        paired("A′ − MLP", rerun, mlp)
    if args.plot:
        plot(runs, args.plot)


if __name__ == "__main__":
    main()
