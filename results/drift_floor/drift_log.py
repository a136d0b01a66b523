"""How much 0.37's default PPO critic forgets by drift, per batch and per 4,096 points, on
CartPole-v1 and MountainCarContinuous-v0 (session 76, descriptive; why a floor per point
cannot spare one cell without the other)::

    python results/drift_floor/drift_log.py > results/drift_floor/drift_log.md

Trains PPO with the zoo's hyperparameters and ``GPActorCriticPolicy`` + ``GPValueCallback()``
(0.37's defaults) at the critic comparison's budgets, outside its harness (no evaluations),
and records the ``drift_factor`` and the points of every batch the critic absorbed
(``update_critic``'s statistics).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams

RUNS = (("CartPole-v1", 933, 30_000), ("CartPole-v1", 934, 30_000))
RUNS += (("MountainCarContinuous-v0", 933, 20_000),)


def feed_stats(
    algo: str, env_id: str, seed: int, steps: int, gp_kwargs: dict[str, Any] | None = None
) -> list[dict[str, float]]:
    """``update_critic``'s statistics of every feed of a run of ``algo`` ("ppo" or "a2c") with
    the zoo's hyperparameters and the drop-in critic (``gp_kwargs`` added to its options)."""
    n_envs, kwargs, policy_kwargs = algo_kwargs(algo, hyperparams(algo, env_id).values)
    if gp_kwargs is not None:
        policy_kwargs = {**policy_kwargs, "gp_kwargs": gp_kwargs}
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
    algo_cls = {"ppo": PPO, "a2c": A2C}[algo]
    model = algo_cls(GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
    fed: list[dict[str, float]] = []
    update = model.policy.update_critic

    def recording(*args: Any, **kw: Any) -> dict[str, float]:
        stats = update(*args, **kw)
        fed.append(stats)
        return stats

    model.policy.update_critic = recording  # type: ignore[method-assign]
    model.learn(steps, callback=GPValueCallback())
    env.close()
    return fed


def batches(env_id: str, seed: int, steps: int) -> list[tuple[int, float]]:
    """``(points, drift factor)`` of every PPO batch absorbed with drift."""
    return [
        (int(s["n_fed"]), float(s["drift_factor"]))
        for s in feed_stats("ppo", env_id, seed, steps)
        if "drift_factor" in s and s["drift_factor"] < 1
    ]


def main() -> None:
    th.set_num_threads(1)
    print(
        "| env | seed | batches with drift | points per batch, median | factor per batch, "
        "median / least | log-weight lost per 4,096 points, median / 90th pct / most | "
        "log-weight lost, whole run |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    for env_id, seed, steps in RUNS:
        fed = batches(env_id, seed, steps)
        n = np.array([b[0] for b in fed])
        factor = np.array([b[1] for b in fed])
        per = -np.log(factor) / n * 4096
        print(
            f"| {env_id} | {seed} | {len(fed)} | {np.median(n):.0f} | "
            f"{np.median(factor):.3f} / {factor.min():.3f} | "
            f"{np.median(per):.2f} / {np.percentile(per, 90):.2f} / {per.max():.1f} | "
            f"{sum(-math.log(f) for f in factor):.1f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
