"""Exploratory: the replication's PPO Acrobot runs again with the linear-mean hack (diag.add_linear_mean).
usage: lin_sweep.py OUT SEED... ; result files as the compare writes them (critic 'laplacian')."""
import json, os, sys, multiprocessing as mp
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

def src(seed):
    base = {1: "results/replication_s10/ppo", 3: "results/linear_mean/acrobot_s30"}.get(
        seed // 10, "results/linear_mean/acrobot_s40")
    return f"{base}/runs/ppo__laplacian__Acrobot-v1__s{seed}.json"

def job(a):
    out, seed = a
    import dataclasses
    import sb3_geogp.comparison.run as run
    from sb3_geogp.comparison.specs import RunSpec
    import diag
    r = json.load(open(src(seed)))
    s = dict(r["spec"]); s["gp_kwargs"] = tuple(sorted(s["gp_kwargs"].items()))
    spec = RunSpec(**s, hyperparams=r["hyperparams"]["values"], hyperparams_source=r["hyperparams"]["source"], threshold=r["threshold"])
    orig = run.build_model
    def build(spec):
        m = orig(spec); diag.add_linear_mean(m.policy); return m
    run.build_model = build
    res = run.run_one(spec, out)
    return seed, res["final_return"]

if __name__ == "__main__":
    out = sys.argv[1]; seeds = [int(x) for x in sys.argv[2:]]
    os.makedirs(out + "/runs", exist_ok=True)
    with mp.get_context("spawn").Pool(2) as p:
        for seed, fr in p.imap_unordered(job, [(out, s) for s in seeds]):
            print("done", seed, fr, flush=True)
