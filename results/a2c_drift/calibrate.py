"""Scratch: A2C's drift per 4,096 points with its default GP critic (rbf) logging drift."""
import sys, json, math
import numpy as np, torch as th
from stable_baselines3 import A2C
from stable_baselines3.common.env_util import make_vec_env
from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams
th.set_num_threads(1)
env_id, seed = sys.argv[1], int(sys.argv[2])
n_envs, kwargs, policy_kwargs = algo_kwargs("a2c", hyperparams("a2c", env_id).values)
env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
policy_kwargs = {**policy_kwargs, "gp_kwargs": {"kernel": "rbf", "drift_forgetting": 1e-300}}
model = A2C(GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
fed = []
upd = model.policy.update_critic
def rec(*a, **k):
    s = upd(*a, **k)
    if s.get("n_fed", 0) > 0: fed.append((int(s["n_fed"]), float(s.get("policy_kl", 0.0))))
    return s
model.policy.update_critic = rec
model.learn(30_000, callback=GPValueCallback())
# window sums of drift over consecutive 4,096 fed points
sums, acc, pts = [], 0.0, 0
for n, kl in fed:
    acc += kl; pts += n
    if pts >= 4096: sums.append(acc * 4096 / pts); acc, pts = 0.0, 0
print(env_id, seed, "feeds", len(fed), "points per feed median", np.median([n for n, _ in fed]),
      "drift per 4096 pts: median %.4f mean %.4f" % (np.median(sums), np.mean(sums)), "windows", len(sums))
