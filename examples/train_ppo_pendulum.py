"""Train PPO on Pendulum-v1 with the default GP critic, save, reload, evaluate.

Run: ``python examples/train_ppo_pendulum.py [timesteps]`` (default 20 000: about a minute on
one CPU core). The only changes from plain SB3 are the policy class, ``gp_kwargs`` and the
callback. The default critic under PPO is the Laplacian-kernel GP (0.6); add
``kernel="geodesic"`` to ``gp_kwargs`` for the paper's geodesic kernel.
"""

from __future__ import annotations

import sys

import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.evaluation import evaluate_policy

from sb3_geogp import GPActorCriticPolicy, GPValueCallback


def main(timesteps: int = 20_000) -> None:
    th.set_num_threads(1)  # small networks and a small GP: one thread is fastest
    env = make_vec_env("Pendulum-v1", n_envs=4, seed=0)
    model = PPO(
        GPActorCriticPolicy,
        env,
        # rl-baselines3-zoo's PPO hyperparameters for Pendulum-v1
        n_steps=1024,
        gae_lambda=0.95,
        gamma=0.9,
        n_epochs=10,
        ent_coef=0.0,
        learning_rate=1e-3,
        clip_range=0.2,
        use_sde=True,
        sde_sample_freq=4,
        policy_kwargs=dict(gp_kwargs=dict(max_basis=256)),
        seed=0,
        verbose=1,
    )
    model.learn(timesteps, callback=GPValueCallback())
    model.save("ppo_geogp_pendulum")

    model = PPO.load("ppo_geogp_pendulum")
    mean, std = evaluate_policy(model, make_vec_env("Pendulum-v1", seed=1), n_eval_episodes=10)
    print(f"mean return over 10 episodes: {mean:.1f} +/- {std:.1f}")
    print(f"GP critic: {model.policy.gp.n_basis} basis vectors")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20_000)
