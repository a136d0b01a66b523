"""Wall clock of PPO on Pendulum-v1: MLP critic vs RBF GP critic vs geodesic GP critic.

Same seeds and rl-baselines3-zoo hyperparameters for all three critics; prints wall-clock
seconds, the ratio to the MLP critic, the share of time spent in GP updates and the final
mean return (last 100 training episodes). Run
``python examples/benchmark_training.py --timesteps 100000 --seeds 0 1 2``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.experiments.compare import algo_kwargs

# rl-baselines3-zoo's PPO hyperparameters for Pendulum-v1 (4 envs), as recorded for the
# critic comparison.
N_ENVS, ZOO, _ = algo_kwargs("ppo", "Pendulum-v1")


def run(critic: str, timesteps: int, seed: int, max_basis: int) -> tuple[float, float, float]:
    """Train once; return (wall seconds, seconds in GP updates, mean return of last episodes)."""
    env = make_vec_env("Pendulum-v1", n_envs=N_ENVS, seed=seed)
    callback = None
    if critic == "mlp":
        model = PPO("MlpPolicy", env, seed=seed, **ZOO)
    else:
        gp_kwargs = dict(kernel=critic, max_basis=max_basis)
        model = PPO(
            GPActorCriticPolicy, env, seed=seed, policy_kwargs=dict(gp_kwargs=gp_kwargs), **ZOO
        )
        callback = GPValueCallback()
    start = time.perf_counter()
    model.learn(timesteps, callback=callback)
    seconds = time.perf_counter() - start
    returns = [info["r"] for info in model.ep_info_buffer]
    gp_seconds = callback.update_seconds if callback is not None else 0.0
    return seconds, gp_seconds, float(np.mean(returns)) if returns else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--timesteps", type=int, default=100_000)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--max-basis", type=int, default=256)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    th.set_num_threads(args.threads)

    results: dict[str, list[tuple[float, float, float]]] = {}
    for seed in args.seeds:
        for critic in ("mlp", "rbf", "geodesic"):
            results.setdefault(critic, []).append(run(critic, args.timesteps, seed, args.max_basis))
            seconds, _, ret = results[critic][-1]
            print(f"seed {seed} {critic:9s} {seconds:7.1f} s  return {ret:8.1f}", flush=True)

    mlp_seconds = np.mean([r[0] for r in results["mlp"]])
    print(
        f"\nPPO Pendulum-v1, {args.timesteps} steps, seeds {args.seeds}, "
        f"max_basis={args.max_basis}, {args.threads} thread(s)"
    )
    print(f"{'critic':9s} {'wall s':>8s} {'x MLP':>6s} {'GP upd %':>9s} {'return':>8s}")
    for critic, rows in results.items():
        seconds = float(np.mean([r[0] for r in rows]))
        share = float(np.mean([r[1] / r[0] for r in rows]))
        ret = float(np.mean([r[2] for r in rows]))
        print(
            f"{critic:9s} {seconds:8.1f} {seconds / mlp_seconds:6.2f} {100 * share:8.1f}% "
            f"{ret:8.1f}"
        )


if __name__ == "__main__":
    main()
