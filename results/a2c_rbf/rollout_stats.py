"""What each A2C critic gives the actor, rollout by rollout (session 35, diagnostic).

A2C on one environment as in the comparison (zoo hyperparameters, 30,000 steps), the critic
being SB3's MLP critic (``mlp``), the A2C default GP critic (``default``: the geodesic
kernel), the default with ``gp_kwargs=dict(kernel="rbf")`` (``rbf``) or with the geodesic
kernel's Gaussian profile (``gaussian``, the paper's). After each rollout it records the mean and
standard deviation of the advantages A2C will use (A2C does not normalise them), the mean
value target and value, the policy's mean entropy on the rollout's states and the mean return
of the last 20 training episodes. Writes ``<out>.json`` and a figure ``<out>.png``.

    python results/a2c_rbf/rollout_stats.py --env CartPole-v1 --seeds 0 1 2 3 4 \
        --out results/a2c_rbf/rollout_stats_cartpole
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import A2C
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams
from sb3_geogp.comparison.measurement import RolloutRecorder
from sb3_geogp.comparison.report import pyplot

#: ``gp_kwargs`` of each critic (``None``: SB3's MLP critic). ``gaussian`` changes only the
#: default's profile (the graph distance kept), ``rbf`` the distance too.
CRITICS = {
    "mlp": None,
    "default": {},
    "rbf": {"kernel": "rbf"},
    "gaussian": {"kernel_kwargs": {"profile": "gaussian"}},
}


class RolloutStats(RolloutRecorder):
    """Per rollout: advantages, targets, values, entropy, recent episode returns."""

    def row(self) -> dict[str, Any]:
        buffer = self.model.rollout_buffer
        obs = th.as_tensor(buffer.observations.reshape(buffer.buffer_size * buffer.n_envs, -1))
        with th.no_grad():
            entropy = self.model.policy.get_distribution(obs.to(self.model.device)).entropy()
        episodes = [e["r"] for e in self.model.ep_info_buffer][-20:]
        return dict(
            t=self.num_timesteps,
            advantage=float(buffer.advantages.mean()),
            advantage_sd=float(buffer.advantages.std()),
            target=float(buffer.returns.mean()),
            value=float(buffer.values.mean()),
            entropy=float(entropy.mean()),
            episode_return=float(np.mean(episodes)) if episodes else None,
        )


def run(env_id: str, critic: str, seed: int, timesteps: int) -> list[dict[str, Any]]:
    """One A2C run; the rows of :class:`RolloutStats`."""
    th.set_num_threads(1)
    n_envs, kwargs, policy_kwargs = algo_kwargs("a2c", hyperparams("a2c", env_id).values)
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
    stats = RolloutStats()
    gp_kwargs = CRITICS[critic]
    if gp_kwargs is None:
        model = A2C("MlpPolicy", env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
        callbacks: list[BaseCallback] = [stats]
    else:
        policy_kwargs = {**policy_kwargs, "gp_kwargs": gp_kwargs}
        model = A2C(GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
        callbacks = [GPValueCallback(), stats]  # the callback fills the values first
    model.learn(timesteps, callback=callbacks)
    return stats.rows


def plot(found: dict[str, dict[str, list[dict[str, Any]]]], env_id: str, path: str) -> None:
    """Mean over seeds of each statistic against timesteps, one line per critic."""
    keys = ("episode_return", "entropy", "advantage", "advantage_sd", "value")
    plt = pyplot()
    fig, axes = plt.subplots(1, len(keys), figsize=(3.4 * len(keys), 3.0))
    for k, critic in enumerate(found):
        runs = list(found[critic].values())
        t = np.array([r["t"] for r in runs[0]]) / 1e3
        for ax, key in zip(axes, keys, strict=True):
            y = np.array([[np.nan if r[key] is None else r[key] for r in rows] for rows in runs])
            ax.plot(t, np.nanmean(y, axis=0), color=f"C{k}", lw=1.2, label=critic)
            ax.set_title(key.replace("_", " "), fontsize=9)
            ax.set_xlabel("timesteps (thousands)", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    n = len(next(iter(found.values())))
    fig.suptitle(f"A2C {env_id}, per rollout, mean over {n} seeds", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="CartPole-v1")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument(
        "--critics", nargs="+", choices=list(CRITICS), default=["mlp", "default", "rbf"]
    )
    parser.add_argument("--timesteps", type=int, default=30_000)
    parser.add_argument("--out", required=True, help="path without suffix")
    args = parser.parse_args()
    found: dict[str, dict[str, list[dict[str, Any]]]] = {}
    for critic in args.critics:
        found[critic] = {}
        for seed in args.seeds:
            rows = run(args.env, critic, seed, args.timesteps)
            found[critic][str(seed)] = rows
            late = rows[len(rows) // 2 :]
            print(
                f"{critic} seed {seed}: second half mean advantage "
                f"{np.mean([r['advantage'] for r in late]):+.2f}, its spread "
                f"{np.mean([r['advantage_sd'] for r in late]):.2f}, entropy "
                f"{np.mean([r['entropy'] for r in late]):.3f}, last value {rows[-1]['value']:.1f}",
                flush=True,
            )
    with open(f"{args.out}.json", "w") as f:
        json.dump(found, f)
    plot(found, args.env, f"{args.out}.png")


if __name__ == "__main__":
    main()
