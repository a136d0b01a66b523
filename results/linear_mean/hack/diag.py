"""Exploratory: per-rollout diagnostics of PPO Acrobot, GP vs MLP critic (same seed, same spec)."""
import json, sys
import numpy as np, torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.specs import RunSpec

class Diag(BaseCallback):
    def __init__(self):
        super().__init__(); self.rows=[]; self.goal=0; self.eps=0
    def _on_step(self):
        for info in self.locals["infos"]:
            if "episode" in info:
                self.eps += 1; self.goal += info["episode"]["l"] < 500
        return True
    def _on_rollout_end(self):
        buf = self.model.rollout_buffer
        adv = buf.advantages.ravel(); ret = buf.returns.ravel(); val = buf.values.ravel()
        act = buf.actions.ravel().astype(int)
        obs = th.as_tensor(buf.observations.reshape(-1, buf.obs_shape[0]))
        with th.no_grad():
            ent = self.model.policy.get_distribution(obs).entropy().mean().item()
            probs = self.model.policy.get_distribution(obs).distribution.probs.mean(0).tolist()
        an = (adv - adv.mean()) / (adv.std() + 1e-8)
        row = dict(t=self.num_timesteps, goal=self.goal, eps=self.eps, ent=ent, probs=probs,
                   v_sd=float(val.std()), v_mean=float(val.mean()), ret_sd=float(ret.std()),
                   ret_mean=float(ret.mean()),
                   ev=float(1 - np.var(ret - val) / (np.var(ret) + 1e-12)),
                   adv_by_act=[float(an[act == a].mean()) if (act == a).any() else None for a in range(3)],
                   act_freq=np.bincount(act, minlength=3).tolist())
        o = buf.observations.reshape(-1, buf.obs_shape[0])
        height = -o[:, 0] - (o[:, 0] * o[:, 2] - o[:, 1] * o[:, 3])  # -cos t1 - cos(t1+t2)
        speed = o[:, 4] ** 2 + o[:, 5] ** 2
        c = lambda a, b: float(np.corrcoef(a, b)[0, 1]) if a.std() > 0 and b.std() > 0 else 0.0
        row.update(cV_h=c(val, height), cV_s=c(val, speed), cR_h=c(ret, height), cR_s=c(ret, speed))
        fast = speed > np.quantile(speed, 0.95)
        row["v_fast_minus_all"] = float(val[fast].mean() - val.mean())
        pol = self.model.policy
        if isinstance(pol, GPActorCriticPolicy):
            st = pol.gp.last_stats
            row.update({k: float(v) for k, v in st.items() if not k.startswith("lengthscale_")})
            row["ls"] = [float(x) for x in pol.gp.lengthscale]
            row["y_mean"] = float(pol.gp.y_mean); row["y_scale"] = float(pol.gp.y_scale)
            row["slope"] = [float(v) for v in pol.gp.y_slope]
            if hasattr(pol, "_lin_state") and pol._lin_state["w"] is not None:
                row["hack_w"] = [float(v) for v in pol._lin_state["w"]]
        self.rows.append(row); self.goal = 0; self.eps = 0

def add_linear_mean(policy, ridge=1e-3):
    """Exploratory hack: V = w.[x, 1] + GP(x); w refit by ridge on each rollout's targets,
    the GP fed the residuals."""
    state = {"w": None}
    policy._lin_state = state
    head = policy.value_net
    orig_forward = head.forward
    def lin(x):
        x = th.as_tensor(x, dtype=th.float64).reshape(x.shape[0], -1)
        if state["w"] is None:
            return th.zeros(x.shape[0], dtype=th.float64)
        return th.cat([x, th.ones(x.shape[0], 1, dtype=th.float64)], 1) @ state["w"]
    def forward(latent_vf):
        v = orig_forward(latent_vf)
        return v + lin(latent_vf.cpu()).to(v).unsqueeze(1)
    head.forward = forward
    orig_update = policy.update_critic
    def update_critic(obs, targets, starts, values=None):
        X = th.as_tensor(np.asarray(obs), dtype=th.float64).reshape(len(targets), -1)
        y = th.as_tensor(np.asarray(targets), dtype=th.float64).reshape(-1)
        A = th.cat([X, th.ones(X.shape[0], 1, dtype=th.float64)], 1)
        old = lin(X)
        state["w"] = th.linalg.solve(A.T @ A + ridge * len(y) * th.eye(A.shape[1], dtype=th.float64), A.T @ y)
        # the GP's earlier targets were residuals of the old fit: feed residuals of the new one
        resid = (y - lin(X)).numpy()
        vals = None if values is None else np.asarray(values) - old.numpy().reshape(np.shape(values))
        return orig_update(obs, resid.reshape(np.shape(targets)), starts, vals)
    policy.update_critic = update_critic

def main(critic, seed, out, steps=30000, gp_extra=None):
    spec0 = json.load(open(f"results/replication_s10/ppo/runs/ppo__laplacian__Acrobot-v1__s{seed}.json"))
    s = spec0["spec"]; gp = dict(s["gp_kwargs"]); gp.update(gp_extra or {})
    linear_mean = bool(gp.pop("linear_mean", False))
    spec = RunSpec(algo="ppo", critic=critic, env_id="Acrobot-v1", seed=seed, total_timesteps=steps,
                   gp_kwargs=tuple(sorted(gp.items())), hyperparams=spec0["hyperparams"]["values"], hyperparams_source="x", threshold=-100.0)
    model = build_model(spec)
    if linear_mean:
        add_linear_mean(model.policy)
    diag = Diag()
    cbs = [diag] if critic == "mlp" else [GPValueCallback(), diag]
    model.learn(steps, callback=CallbackList(cbs))
    json.dump(diag.rows, open(out, "w"))

if __name__ == "__main__":
    th.set_num_threads(1)
    extra = json.loads(sys.argv[4]) if len(sys.argv) > 4 else None
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3], gp_extra=extra)
