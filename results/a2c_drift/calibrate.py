"""A2C's drift per 4,096 fed points with its default GP critic (RBF) logging its drift
(``drift_forgetting=1e-300``: every weight exactly 1), for PLAN.md's rate (session 76)::

    python results/a2c_drift/calibrate.py Pendulum-v1 184
    python results/a2c_drift/calibrate.py Pendulum-v1 185
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import A2C
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams

WINDOW = 4096


def feeds(env_id: str, seed: int, steps: int = 30_000) -> list[tuple[int, float]]:
    """``(points, drift)`` of every feed that absorbed points."""
    n_envs, kwargs, policy_kwargs = algo_kwargs("a2c", hyperparams("a2c", env_id).values)
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
    gp_kwargs = {"kernel": "rbf", "drift_forgetting": 1e-300}
    policy_kwargs = {**policy_kwargs, "gp_kwargs": gp_kwargs}
    model = A2C(GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
    fed: list[tuple[int, float]] = []
    update = model.policy.update_critic

    def recording(*args: Any, **kw: Any) -> dict[str, float]:
        stats = update(*args, **kw)
        if stats.get("n_fed", 0) > 0:
            fed.append((int(stats["n_fed"]), float(stats.get("policy_kl", 0.0))))
        return stats

    model.policy.update_critic = recording  # type: ignore[method-assign]
    model.learn(steps, callback=GPValueCallback())
    env.close()
    return fed


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
