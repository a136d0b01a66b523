"""A2C's drift per 4,096 fed points with its default GP critic (RBF) logging its drift
(``drift_forgetting=1e-300``: every weight exactly 1), for PLAN.md's rate (session 76)::

    python results/a2c_drift/calibrate.py Pendulum-v1 184
    python results/a2c_drift/calibrate.py Pendulum-v1 185
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch as th

from sb3_geogp.toolbox.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]
DRIFT_LOG = load_script(ROOT / "results" / "drift_floor" / "drift_log.py", "drift_log")
WINDOW = 4096


def feeds(env_id: str, seed: int, steps: int = 30_000) -> list[tuple[int, float]]:
    """``(points, drift)`` of every feed that absorbed points."""
    gp_kwargs = {"kernel": "rbf", "drift_forgetting": 1e-300}
    return [
        (int(s["n_fed"]), float(s.get("policy_kl", 0.0)))
        for s in DRIFT_LOG.feed_stats("a2c", env_id, seed, steps, gp_kwargs)
        if s.get("n_fed", 0) > 0
    ]


def window_sums(fed: list[tuple[int, float]]) -> list[float]:
    """The drift summed over consecutive windows of at least :data:`WINDOW` fed points, per
    :data:`WINDOW` points."""
    sums, drift, points = [], 0.0, 0
    for n, kl in fed:
        drift, points = drift + kl, points + n
        if points >= WINDOW:
            sums.append(drift * WINDOW / points)
            drift, points = 0.0, 0
    return sums


def main() -> None:
    th.set_num_threads(1)
    env_id, seed = sys.argv[1], int(sys.argv[2])
    fed = feeds(env_id, seed)
    sums = window_sums(fed)
    print(
        f"{env_id} {seed} feeds {len(fed)} points per feed median "
        f"{np.median([n for n, _ in fed])} drift per {WINDOW} pts: median {np.median(sums):.4f} "
        f"mean {np.mean(sums):.4f} windows {len(sums)}"
    )


if __name__ == "__main__":
    main()
