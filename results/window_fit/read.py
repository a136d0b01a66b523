"""``PLAN.md``'s reading: per env, the window arm against the default, paired by seed::

python results/window_fit/read.py > results/window_fit/read.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
#: each arm's folder, name, and envs (the first arm is the default all are read against)
ARMS = {
    "default": ("default", ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")),
    "window16384": ("window 16384", ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")),
    "window4096": ("window 4096 (addendum)", ("Pendulum-v1", "Acrobot-v1")),
    "whole_batch": ("whole_batch (addendum 2)", ("Pendulum-v1", "Acrobot-v1")),
}
SEEDS = range(10)
READINGS = {"per rollout": "tail_mean", "pooled": "tail_pooled"}


def score(arm: str, env: str, key: str) -> np.ndarray:
    runs = (HERE / arm / "runs" / f"laplacian__{env}__s{s}.json" for s in SEEDS)
    return np.array([json.loads(p.read_text())[key] for p in runs], dtype=float)


def row(arm: str, env: str, reading: str, key: str) -> str:
    base, other = score("default", env, key), score(arm, env, key)
    mean, half = (float(v) for v in mean_ci(other - base, nan_policy="propagate"))
    cells = [f"{a.mean():.3f} ({int((a >= 0.9).sum())}/10)" for a in (base, other)]
    diff = f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]"
    median = float(np.median(other - base))
    name = ARMS[arm][0]
    return f"| {env} | {name} | {reading} | {' | '.join(cells)} | {diff} | {median:+.3f} |"


def main() -> None:
    columns = "default (at 0.9) | arm (at 0.9) | arm − default [95 % t] | paired median"
    print(f"| env | arm | reading | {columns} |")
    print("|---|---|---|---:|---:|---:|---:|")
    for env in ARMS["default"][1]:
        for arm, (_, envs) in list(ARMS.items())[1:]:
            if env in envs:
                for reading, key in READINGS.items():
                    print(row(arm, env, reading, key))


if __name__ == "__main__":
    main()
