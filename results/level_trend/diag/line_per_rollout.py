"""Exploratory (session 19): per PPO rollout, how much of its targets a ridge line explains
in-sample (r2_in), how well the previous rollout's line predicts it (r2_oos), the rollout's
target mean and standard deviation. Run: python line_per_rollout.py Acrobot-v1 11 (prints JSON).
"""
from __future__ import annotations
import json, sys
import torch as th
from sb3_geogp import GPValueCallback
from sb3_geogp.sparse_gp import SparseOnlineGP
from sb3_geogp.comparison.hyperparams import GP_KWARGS, hyperparams
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.specs import RunSpec

ROWS: list[dict] = []
orig = SparseOnlineGP._fit_trend

def fit_trend(self, x, y):
    prev = self._trend(x)
    var = float(y.var())
    r2_oos = 1 - float((y - prev).var()) / var if var > 0 else float("nan")
    mse_oos = float((y - prev).square().mean()) / var if var > 0 else float("nan")
    res = orig(self, x, y)
    r2_in = 1 - float(res.var()) / var if var > 0 else float("nan")
    # the model's full prediction before absorbing, with the old line, vs with the new line
    ROWS.append(dict(n=int(self.n_batches), r2_oos=r2_oos, mse_oos=mse_oos, r2_in=r2_in,
                     ystd=var ** 0.5, ymean=float(y.mean()),
                     coef=float(self.trend_coef[:-1].norm())))
    return res

SparseOnlineGP._fit_trend = fit_trend
env, seed = sys.argv[1], int(sys.argv[2])
th.set_num_threads(1)
params = hyperparams("ppo", env)
spec = RunSpec(algo="ppo", critic="laplacian", env_id=env, seed=seed, total_timesteps=30000,
               gp_kwargs=tuple(sorted({**GP_KWARGS, "trend": "linear"}.items())),
               hyperparams=params.values, hyperparams_source=params.source, threshold=0.0)
model = build_model(spec)
model.learn(30000, callback=GPValueCallback())
print(json.dumps(ROWS))
