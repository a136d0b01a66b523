#!/usr/bin/env python3
"""Paired readings of results/dtc_absorb (the switch against the default, same seeds):
``python results/dtc_absorb/read.py results/dtc_absorb > results/dtc_absorb/read.md``."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")


def tail(root: Path, folder: str, env: str, seeds: range, key: str = "tail_mean") -> np.ndarray:
    """Each seed's critic-fit score ``key`` of the runs in ``root / folder``."""
    runs = root / folder / "runs"
    return np.array(
        [json.loads((runs / f"laplacian__{env}__s{s}.json").read_text())[key] for s in seeds]
    )


def interval(d: np.ndarray) -> tuple[float, float]:
    """95 % percentile bootstrap interval of the mean of ``d``."""
    boot = np.random.default_rng(0).choice(d, size=(10000, len(d))).mean(1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return float(lo), float(hi)


def critic_fit(root: Path, seeds: range = range(643, 653)) -> None:
    """The planned reading: seeds 643-652, three envs, both readings of the score (also read
    by results/fitc_rebuild on other seeds)."""
    print("| env | reading | default | switch | switch - default [95 % CI] | switch higher |")
    print("|---|---|---:|---:|---:|---:|")
    for env in ENVS:
        for key, label in (("tail_mean", "mean over rollouts"), ("tail_pooled", "pooled")):
            a, b = (tail(root, arm, env, seeds, key) for arm in ("default", "switch"))
            lo, hi = interval(b - a)
            print(
                f"| {env} | {label} | {a.mean():.3f} | {b.mean():.3f} | "
                f"{(b - a).mean():+.3f} [{lo:+.3f}, {hi:+.3f}] | {(b > a).sum()}/{len(a)} |"
            )


def fixed_policy(root: Path) -> None:
    """The fixed-policy pendulum: the adaptive on-line GP's MSE against the Monte Carlo truth,
    switch / default per seed (the same stream and truth), geometric mean with a 95 %
    percentile bootstrap CI over seeds; and each arm's ratio to its own batch sparse GP (whose
    inducing points are that arm's basis vectors)."""
    runs = {
        arm: json.loads((root / f"fixed_policy_{arm}" / "results.json").read_text())["rows"]
        for arm in ("default", "switch")
    }
    print()
    print(
        "| max BV | MSE default | MSE switch | switch / default [95 % CI] | switch lower | "
        "default / its batch GP | switch / its batch GP |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for m in (20, 50, 100, 200):
        a, b = ({r["seed"]: r for r in runs[arm] if r["max_basis"] == m} for arm in runs)
        seeds = sorted(a)
        log_ratio = np.log([b[s]["mse_adaptive"] / a[s]["mse_adaptive"] for s in seeds])
        lo, hi = np.exp(interval(log_ratio))
        mse = [np.mean([arm[s]["mse_adaptive"] for s in seeds]) for arm in (a, b)]
        own = [np.exp(np.mean(np.log([arm[s]["ratio_adaptive"] for s in seeds]))) for arm in (a, b)]
        print(
            f"| {m} | {mse[0]:.2f} | {mse[1]:.2f} | {np.exp(log_ratio.mean()):.3f} "
            f"[{lo:.3f}, {hi:.3f}] | {(log_ratio < 0).sum()}/{len(seeds)} | {own[0]:.2f} | "
            f"{own[1]:.2f} |"
        )


def acrobot_extension(root: Path) -> None:
    """Acrobot-v1 on seeds 653-662 too, added after reading seeds 643-652's +0.054 (not
    planned: a closer look at the one env whose interval nearly excluded 0), and all 20."""
    blocks = {"643-652": ("", range(643, 653)), "653-662 (added)": ("extension_", range(653, 663))}
    scores = {
        label: tuple(tail(root, prefix + arm, "Acrobot-v1", seeds) for arm in ("default", "switch"))
        for label, (prefix, seeds) in blocks.items()
    }
    scores["643-662"] = tuple(np.concatenate(arms) for arms in zip(*scores.values(), strict=True))
    print()
    print(
        "| Acrobot-v1, mean over rollouts | default | switch | switch - default [95 % CI] | "
        "switch higher |"
    )
    print("|---|---:|---:|---:|---:|")
    for label, (a, b) in scores.items():
        lo, hi = interval(b - a)
        print(
            f"| seeds {label} | {a.mean():.3f} | {b.mean():.3f} | {(b - a).mean():+.3f} "
            f"[{lo:+.3f}, {hi:+.3f}] | {(b > a).sum()}/{len(a)} |"
        )


if __name__ == "__main__":
    root = Path(sys.argv[1])
    critic_fit(root)
    fixed_policy(root)
    acrobot_extension(root)
