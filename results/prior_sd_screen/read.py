"""A wider lengthscale hyperprior under PPO at 100,000 steps: a screen (session 46, exploratory).

0.23's PPO critic keeps its fitted lengthscales near their start with ``prior_sd=0.1``, which
stopped CartPole-v1's late falls at 100,000 steps (docs/results.md, "A hyperprior on the
lengthscales"). Session 46's critic-fit screen found that prior costing Acrobot-v1's fit about
0.07 of explained variance at 100,000 steps and ``prior_sd=0.3`` giving it back. Does the wider
prior change the returns, and does CartPole fall again? The default critic (``default``) and
the same with ``prior_sd=0.3`` (``prior30``), PPO, 100,000 steps, fresh seeds 490-509, both on
this machine, read after the runs (no registration: a screen that decides nothing):

    A=$(python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import \\
        default_adaptation; import json; d = default_adaptation(PPO).as_dict(); \\
        d['prior_sd'] = 0.3; print(json.dumps(d))")
    sb3-geogp compare --algos ppo --critics laplacian --envs CartPole-v1 Acrobot-v1 \\
        --timesteps 100000 --seeds 20 --first-seed 490 --workers 2 --no-progress --no-plots \\
        --out results/prior_sd_screen/default
    sb3-geogp compare --algos ppo --critics laplacian --envs CartPole-v1 Acrobot-v1 \\
        --timesteps 100000 --seeds 20 --first-seed 490 --workers 2 --no-progress --no-plots \\
        --gp-option "adapt=$A" --out results/prior_sd_screen/prior30
    python results/prior_sd_screen/read.py > results/prior_sd_screen/read.md
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import difference_ci, mean_ci

HERE = Path(__file__).resolve().parent
FALLS = load_script(HERE.parent / "budget100k" / "falls.py", "budget100k_falls")
ARMS = ("default", "prior30")


def by_seed(runs: list[dict[str, Any]], env_id: str) -> dict[int, dict[str, Any]]:
    return {r["spec"]["seed"]: r for r in runs if r["spec"]["env_id"] == env_id}


def main() -> None:
    runs = {arm: load_results(HERE / arm) for arm in ARMS}
    print("PPO, 100,000 steps, seeds 490-509; `prior30` − `default`, final return\n")
    print("| env | default: mean final | prior30: mean final | difference [95 % bootstrap] | "
          "paired by seed [95 % t] | runs at -500 (default / prior30) |")  # fmt: skip
    print("|---|---:|---:|---|---|---:|")
    for env_id in ("CartPole-v1", "Acrobot-v1"):
        default, wide = (by_seed(runs[arm], env_id) for arm in ARMS)
        seeds = sorted(set(default) & set(wide))
        a, b = (np.array([arm[s]["final_return"] for s in seeds]) for arm in (default, wide))
        est, lo, hi = difference_ci(b, a)
        mean, half = (float(v) for v in mean_ci(b - a, nan_policy="propagate"))
        stuck = " / ".join(str(int((x <= -500).sum())) for x in (a, b))
        stuck = stuck if env_id == "Acrobot-v1" else "–"
        print(f"| {env_id} ({len(seeds)} seeds) | {a.mean():.1f} | {b.mean():.1f} | "
              f"{est:+.1f} [{lo:+.1f}, {hi:+.1f}] | {mean:+.1f} [{mean - half:+.1f}, "
              f"{mean + half:+.1f}] | {stuck} |")  # fmt: skip
    print(f"\nCartPole-v1 falls (reach {FALLS.THRESHOLD:g} at a checkpoint, end below "
          f"{FALLS.FALLEN:g}; `results/budget100k/falls.py`'s definition):\n")  # fmt: skip
    print("| arm | runs | reached the threshold | fell | seeds that fell |")
    print("|---|---:|---:|---:|---|")
    for arm in ARMS:
        cartpole = [r for r in runs[arm] if r["spec"]["env_id"] == "CartPole-v1"]
        n, k, fell = FALLS.counts(cartpole, "laplacian")
        print(f"| {arm} | {n} | {k} | {len(fell)} | {', '.join(map(str, fell)) or '–'} |")


if __name__ == "__main__":
    main()
