"""How large the optimistic bonus is against the advantages it shifts, per A2C rollout
(session 29, docs/results.md, "A broad kernel component and an optimistic value at Acrobot PPO").

A2C as in the comparison (zoo hyperparameters, 30,000 steps, seeds 0 and 1) with
``gp_kwargs=dict(trend="level", optimism=1)``. After each rollout the GP's posterior standard
deviation sigma is taken at the rollout's states; printed per quarter of training, mean over its
rollouts: the spread (standard deviation) of sigma over the rollout's states divided by that of
the rollout's advantages (both averaged over the quarter's rollouts, then divided: single A2C
rollouts without an episode's end have tiny advantages, which the mean of the per-rollout
ratios, printed next, weighs as much as the rest), the mean advantage, and the median and 90th
percentile of sigma over the rollout's states as a fraction of the prior standard deviation.

    python results/a2c_level/bonus_spread.py Pendulum-v1 CartPole-v1 Acrobot-v1 \\
        | tee results/a2c_level/bonus_spread.log
"""
import sys

import numpy as np
import torch
from stable_baselines3 import A2C
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams


class Spread(BaseCallback):
    def __init__(self) -> None:
        super().__init__()
        self.rows: list[tuple[float, ...]] = []

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        buffer, gp = self.model.rollout_buffer, self.model.policy.gp
        if gp.n_basis == 0:
            return
        states = torch.as_tensor(buffer.observations.reshape(len(buffer.advantages.ravel()), -1))
        _, var = gp.predict(states)
        sigma = var.clamp_min(0).sqrt()
        prior = sigma / (gp.kernel.variance.sqrt() * gp.y_scale)
        self.rows.append(
            (
                float(sigma.std()),
                float(buffer.advantages.std()),
                float(buffer.advantages.mean()),
                float(prior.quantile(0.5)),
                float(prior.quantile(0.9)),
            )
        )


for env_id in sys.argv[1:]:
    for seed in (0, 1):
        n_envs, kwargs, policy_kwargs = algo_kwargs("a2c", hyperparams("a2c", env_id).values)
        env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
        gp_kwargs = {"trend": "level", "optimism": 1.0}
        model = A2C(GPActorCriticPolicy, env, seed=seed,
                    policy_kwargs={**policy_kwargs, "gp_kwargs": gp_kwargs}, **kwargs)
        spread = Spread()
        model.learn(30000, callback=[GPValueCallback(), spread])
        rows = np.array(spread.rows)
        quarters = np.array_split(rows, 4)
        print(env_id, "seed", seed,
              "| sd(sigma) / sd(advantage) per quarter:",
              [round(float(q[:, 0].mean() / q[:, 1].mean()), 2) for q in quarters],
              "| mean of the per-rollout ratios:", [round(float((q[:, 0] / q[:, 1]).mean()), 2) for q in quarters],
              "| mean advantage:", [round(float(q[:, 2].mean()), 2) for q in quarters],
              "| sigma / prior sd, median:", [round(float(q[:, 3].mean()), 2) for q in quarters],
              "90th percentile:", [round(float(q[:, 4].mean()), 2) for q in quarters], flush=True)
