import time, torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.policies import DEFAULT_ADAPTATION
import dataclasses
adapt = dataclasses.replace(DEFAULT_ADAPTATION, forgetting_score="lagged")
for dev in ("cpu", "cuda"):
    env = make_vec_env("Pendulum-v1", n_envs=4, seed=0)
    m = PPO(GPActorCriticPolicy, env, n_steps=1024, gamma=0.9, seed=0, device=dev, policy_kwargs=dict(gp_kwargs=dict(adapt=adapt)))
    t = time.perf_counter(); m.learn(16384, callback=GPValueCallback()); s = time.perf_counter() - t
    obs = torch.as_tensor(m.rollout_buffer.observations.reshape(-1, 3), device=m.device)
    v = m.policy.predict_values(obs)
    print(dev, "seconds", round(s, 1), "finite", bool(torch.isfinite(v).all()), "forgetting", m.policy.gp.last_stats.get("forgetting"), "basis", m.policy.gp.n_basis)
