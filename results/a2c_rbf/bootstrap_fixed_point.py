"""Where A2C's bootstrapped targets take each GP critic on fixed data (session 35, a control).

A2C's value targets bootstrap from the critic itself: with ``n_steps=5`` and
``gae_lambda=1`` the target of a step is the rewards to the end of its 5-step segment plus
``gamma^k V(s_end)``. A critic that shrinks its predictions towards its prior mean between
its data contracts each bootstrap, and the values settle where ``V = r + gamma S(V)`` holds
for the shrunk ``S(V)``, below the returns of a task with positive rewards and above them
with negative ones. This script takes the policy out: CartPole-v1 driven by one fixed noisy
controller (push towards the pole's lean with probability 0.5, else at random: episodes of
about 150 steps), 8 environments and 5-step segments as the comparison's A2C, and feeds each
GP critic, as the A2C policy builds it, its own bootstrapped targets segment by segment. It
reports, over the last steps (``--tail``), the critic's mean value minus the mean discounted
Monte Carlo return of the same states (their episodes' true returns under the fixed
controller), per kernel and seed.

    python results/a2c_rbf/bootstrap_fixed_point.py --seeds 0 1 2 \
        --out results/a2c_rbf/bootstrap_fixed_point.json
"""

from __future__ import annotations

import argparse
import json

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3 import A2C

from sb3_geogp import SparseOnlineGP
from sb3_geogp.policies import (
    build_gp_critic,
    check_gp_kwargs,
    default_adaptation,
    default_forgetting,
    default_kernel,
    default_trend,
    resolved_gp_kwargs,
)

GAMMA, N_ENVS, N_STEPS = 0.99, 8, 5
#: ``gp_kwargs`` of each critic, as for ``GPActorCriticPolicy`` under A2C.
CRITICS = {
    "default (geodesic)": {},
    "geodesic, gaussian profile": {"kernel_kwargs": {"profile": "gaussian"}},
    "rbf": {"kernel": "rbf"},
    "laplacian": {"kernel": "laplacian"},
}


def trajectories(seed: int, timesteps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``N_ENVS`` CartPole streams under the fixed controller, time-major.

    Returns
    -------
    obs : ndarray, shape (T, N_ENVS, 4)
    rewards, dones : ndarray, shape (T, N_ENVS)
        ``dones[t]``: the step from ``obs[t]`` ended its episode (termination or the 500-step
        cap; the cap is treated as an end, identically for every critic).
    """
    rng = np.random.default_rng(seed)
    envs = [gym.make("CartPole-v1") for _ in range(N_ENVS)]
    state = [env.reset(seed=seed * 100 + i)[0] for i, env in enumerate(envs)]
    steps = timesteps // N_ENVS
    obs, rewards = np.zeros((steps, N_ENVS, 4)), np.zeros((steps, N_ENVS))
    dones = np.zeros((steps, N_ENVS), dtype=bool)
    for t in range(steps):
        for i, env in enumerate(envs):
            obs[t, i] = state[i]
            lean = state[i][2] + 0.5 * state[i][3]
            action = int(lean > 0) if rng.random() < 0.5 else int(rng.integers(2))
            state[i], rewards[t, i], term, trunc, _ = env.step(action)
            dones[t, i] = term or trunc
            if dones[t, i]:
                state[i] = env.reset()[0]
    return obs, rewards, dones


def discounted_returns(rewards: np.ndarray, dones: np.ndarray) -> np.ndarray:
    """Monte Carlo returns to each episode's end (the last, unfinished one to the data's end)."""
    out = np.zeros_like(rewards)
    running = np.zeros(rewards.shape[1])
    for t in range(len(rewards) - 1, -1, -1):
        running = rewards[t] + GAMMA * running * ~dones[t]
        out[t] = running
    return out


def predict(gp: SparseOnlineGP, x: np.ndarray) -> np.ndarray:
    """The critic's values of ``x``, shape (n, 4); zeros before its first feed, as the
    policy's."""
    if int(gp.n_seen) == 0:
        return np.zeros(len(x))
    return gp.predict(x)[0].numpy()


def run(kwargs: dict, seed: int, timesteps: int, tail: int) -> dict[str, float]:
    """Feed one GP critic its own 5-step bootstrapped targets; its bias on the last steps."""
    obs, rewards, dones = trajectories(seed, timesteps)
    mc = discounted_returns(rewards, dones)
    options = resolved_gp_kwargs(
        check_gp_kwargs(kwargs),
        default_kernel(A2C),
        default_trend(A2C),
        default_adaptation(A2C),
        default_forgetting(A2C),
    )
    th.manual_seed(seed)
    gp = build_gp_critic(options, input_dim=4)
    values = np.zeros_like(rewards)
    for t0 in range(0, len(rewards) - N_STEPS, N_STEPS):
        seg = slice(t0, t0 + N_STEPS)
        values[seg] = predict(gp, obs[seg].reshape(-1, 4)).reshape(N_STEPS, N_ENVS)
        running = predict(gp, obs[t0 + N_STEPS])
        targets = np.zeros((N_STEPS, N_ENVS))
        for k in range(N_STEPS - 1, -1, -1):
            running = rewards[t0 + k] + GAMMA * running * ~dones[t0 + k]
            targets[k] = running
        # environment by environment, each in time order, a trajectory starting at each
        # environment's chunk and after each episode's end, as GPValueCallback feeds it
        episode_starts = np.zeros((N_ENVS, N_STEPS), dtype=bool)
        episode_starts[:, 0] = True
        episode_starts[:, 1:] = dones[t0 : t0 + N_STEPS - 1].T
        gp.update(
            obs[seg].transpose(1, 0, 2).reshape(-1, 4),
            targets.T.reshape(-1),
            episode_starts.reshape(-1),
        )
    last = slice(len(rewards) - tail // N_ENVS - N_STEPS, len(rewards) - N_STEPS)
    return dict(
        value=float(values[last].mean()),
        mc_return=float(mc[last].mean()),
        bias=float((values[last] - mc[last]).mean()),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--timesteps", type=int, default=30_000)
    parser.add_argument("--tail", type=int, default=5_000)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    found = {}
    for name, kwargs in CRITICS.items():
        found[name] = [run(kwargs, s, args.timesteps, args.tail) for s in args.seeds]
        rows = found[name]
        print(
            f"{name:28s} value {np.mean([r['value'] for r in rows]):6.1f}  Monte Carlo "
            f"{np.mean([r['mc_return'] for r in rows]):6.1f}  bias per seed "
            + ", ".join(f"{r['bias']:+.1f}" for r in rows),
            flush=True,
        )
    with open(args.out, "w") as f:
        json.dump(found, f, indent=1)


if __name__ == "__main__":
    main()
