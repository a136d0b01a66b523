"""The mean advantage of every A2C rollout, by critic (session 28, docs/results.md, "A moving
level under A2C, and what the critic's bias does there").

A2C as in the comparison (zoo hyperparameters, 30,000 steps, seeds 0-4), the critic being the
0.17 GP default (``none``: no trend), ``gp_kwargs=dict(trend=...)`` for any other name, or
SB3's MLP critic (``mlp``). With ``trend="rising_level"`` it needs ``trends.patch`` applied.
``monte_carlo`` and ``horizonN`` (session 34) are the default critic fed
``GPValueCallback(target="monte_carlo")``, uncut or cut after N steps.

    python results/a2c_level/advantages.py results/a2c_level/advantages.json \
        Acrobot-v1,CartPole-v1 none,level
"""
import json
import sys

import numpy as np
from stable_baselines3 import A2C
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams

out = {}
envs = sys.argv[2].split(",") if len(sys.argv) > 2 else ["Acrobot-v1", "CartPole-v1"]
trends = sys.argv[3].split(",") if len(sys.argv) > 3 else ["none", "level"]
for env_id in envs:
    for trend in trends:
        for seed in (0, 1, 2, 3, 4):
            n_envs, kwargs, pk = algo_kwargs("a2c", hyperparams("a2c", env_id).values)
            env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
            targets = {}
            if trend == "monte_carlo" or trend.startswith("horizon"):
                horizon = int(trend[len("horizon"):]) if trend.startswith("horizon") else None
                targets = {"target": "monte_carlo", "horizon": horizon}
            gpk = {} if trend == "none" or targets else {"trend": trend}
            if trend == "mlp":  # SB3's own critic
                model = A2C("MlpPolicy", env, seed=seed, policy_kwargs=pk, **kwargs)
            else:
                model = A2C(GPActorCriticPolicy, env, seed=seed,
                            policy_kwargs={**pk, "gp_kwargs": gpk}, **kwargs)
            adv, ep = [], []
            class Log(BaseCallback):
                def _on_step(self): return True
                def _on_rollout_end(self):
                    adv.append(float(self.model.rollout_buffer.advantages.mean()))
            gp_callback = [] if trend == "mlp" else [GPValueCallback(**targets)]
            model.learn(30000, callback=[*gp_callback, Log()])
            out[f"{env_id} {trend} {seed}"] = adv
            q = len(adv) // 4
            print(env_id, trend, seed, "mean advantage per quarter:",
                  [round(float(np.mean(adv[i * q:(i + 1) * q])), 3) for i in range(4)], flush=True)
json.dump(out, open(sys.argv[1], "w"))
