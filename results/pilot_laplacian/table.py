"""Setting A (laplacian, novelty_tol 0.1) in all 14 cells against the MLP (results/compare) and
the geodesic default (results/compare_ard): difference of mean final return, percentile bootstrap
(sb3_geogp.toolbox.stats.difference_ci) at 95 % and at the sweep's family-wise level (42).
Run from the repository root: python results/pilot_laplacian/table.py > results/pilot_laplacian/table.md
"""
import json, glob, numpy as np
from sb3_geogp.toolbox.stats import difference_ci
ENVS = ["Pendulum-v1", "MountainCarContinuous-v0", "CartPole-v1", "Acrobot-v1", "sb3_geogp-PaperPendulum-v0", "sb3_geogp-WallMaze-v0", "sb3_geogp-WallMazeDiscrete-v0"]
FW = 1 - 0.05 / 42
def load(srcs, algo, c, env):
    for src in srcs:
        fs = sorted(glob.glob(f"results/{src}/runs/{algo}__{c}__{env}__s*.json"))
        if fs: return [json.load(open(f)) for f in fs]
    return []
def verdict(a, b):
    e, l, h = (float(v) for v in difference_ci(a, b)); _, lf, hf = (float(v) for v in difference_ci(a, b, level=FW))
    v = "better" if l > 0 else "worse" if h < 0 else "no difference"
    if (lf > 0 or hf < 0): v = f"**{v}**"
    return e, l, h, v
def fmt(e, l, h, v): return f"{e:+.3g} [{l:+.3g}, {h:+.3g}] {v}"
rows, counts = [], {"A − MLP": [0] * 5, "A − geodesic": [0] * 5, "geodesic − MLP": [0] * 5}
def count(key, v):
    c = counts[key]
    if "better" in v: c[0] += 1; c[1] += v.startswith("**")
    elif "worse" in v: c[3] += 1; c[4] += v.startswith("**")
    else: c[2] += 1
print("| env | algo | final return A / MLP / geodesic | A − MLP [95%] | A − geodesic [95%] | geodesic − MLP [95%] | reached threshold A / MLP / geo | critic RMSE A / MLP / geo |")
print("|---|---|---|---|---|---|---|---|")
for algo in ("ppo", "a2c"):
    for env in ENVS:
        A = load(["pilot_laplacian/A", "pilot_laplacian/A_rest"], algo, "laplacian", env)
        M = load(["compare"], algo, "mlp", env); G = load(["compare_ard"], algo, "geodesic", env)
        if len(A) < 10: print("MISSING", algo, env, len(A)); continue
        f = lambda runs: np.array([r["final_return"] for r in runs])
        rm = lambda runs: np.mean([r["critic_accuracy"]["rmse"][-1] for r in runs])
        reach = lambda runs: sum(r["steps_to_threshold"] is not None for r in runs)
        am, ag, gm = verdict(f(A), f(M)), verdict(f(A), f(G)), verdict(f(G), f(M))
        count("A − MLP", am[3]); count("A − geodesic", ag[3]); count("geodesic − MLP", gm[3])
        print(f"| `{env.replace('-v0','-v0').replace('sb3_geogp-','sb3_geogp/')}` | {algo} | {f(A).mean():.4g} / {f(M).mean():.4g} / {f(G).mean():.4g} | {fmt(*am)} | {fmt(*ag)} | {fmt(*gm)} | {reach(A)} / {reach(M)} / {reach(G)} | {rm(A):.3g} / {rm(M):.3g} / {rm(G):.3g} |")
print()
for k, c in counts.items(): print(f"{k}: better {c[0]} ({c[1]}) / n.d. {c[2]} / worse {c[3]} ({c[4]})")
