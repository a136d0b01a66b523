"""``PLAN.md``'s reading: per env, the window arm against the default, paired by seed::

python results/window_fit/read.py > results/window_fit/read.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
ARMS = ("default", "window16384")
ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")
SEEDS = range(10)
READINGS = {"per rollout": "tail_mean", "pooled": "tail_pooled"}


def score(arm: str, env: str, key: str) -> np.ndarray:
    runs = (HERE / arm / "runs" / f"laplacian__{env}__s{s}.json" for s in SEEDS)
    return np.array([json.loads(p.read_text())[key] for p in runs], dtype=float)


def row(env: str, reading: str, key: str) -> str:
    base, window = (score(arm, env, key) for arm in ARMS)
    mean, half = (float(v) for v in mean_ci(window - base, nan_policy="propagate"))
    cells = [f"{a.mean():.3f} ({int((a >= 0.9).sum())}/10)" for a in (base, window)]
    diff = f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]"
    median = float(np.median(window - base))
    return f"| {env} | {reading} | {' | '.join(cells)} | {diff} | {median:+.3f} |"


def main() -> None:
    arms = "default (at 0.9) | window 16384 (at 0.9) | window − default [95 % t]"
    print(f"| env | reading | {arms} | paired median |")
    print("|---|---|---:|---:|---:|---:|")
    for env in ENVS:
        for reading, key in READINGS.items():
            print(row(env, reading, key))


if __name__ == "__main__":
    main()
