"""The screens of ``docs/critic_fit_lag/PLAN.md`` (addenda 2 and 3, session 63): each setting's
GP critic on Acrobot-v1 at 30,000 PPO steps, seeds 0-9, minus the default GP critic's runs of
``docs/critic_fit_lag``, paired by seed (mean [95 % t], median)::

    python docs/critic_fit_lag_screens/read.py > docs/critic_fit_lag_screens/read.md

Readings: the goal's (the mean of the scored rollouts' explained variance), the same rollouts
pooled, on G (pooled; the rollouts' own returns bootstrapped with ``V^pi``, every run), and the
RMSE of the critic's values to ``V^pi`` (mean over the scored rollouts).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
DEFAULT = HERE.parent / "critic_fit_lag"
SCREENS = {
    "refit_every_block": "laplacian",
    "refit_whole_rollout": "laplacian",
    "rbf": "rbf",
    "rbf_no_prior": "rbf",
}
SEEDS = range(10)
READINGS: dict[str, Callable[[dict[str, Any]], float]] = {
    "goal's reading": lambda r: r["tail_mean"],
    "pooled": lambda r: r["tail_pooled"],
    "on G, pooled": lambda r: r["ceiling"]["mc_critic_pooled"],
    "value RMSE to V^pi": lambda r: float(
        np.mean([c["value_rmse"] for c in r["ceiling"]["rollouts"]])
    ),
}


def run(folder: Path, critic: str, seed: int) -> dict[str, Any]:
    return json.loads((folder / "runs" / f"{critic}__Acrobot-v1__s{seed}.json").read_text())


def main() -> None:
    print("# Adaptation and kernel screens against the default GP critic (Acrobot-v1, 30k)\n")
    print("| setting | reading | setting | default | setting − default [95 % t] | median |")
    print("|---|---|---:|---:|---:|---:|")
    for name, critic in SCREENS.items():
        for reading, get in READINGS.items():
            a = np.array([get(run(HERE / name, critic, s)) for s in SEEDS])
            b = np.array([get(run(DEFAULT, "laplacian", s)) for s in SEEDS])
            d = a - b
            mean, half = (float(v) for v in mean_ci(d, nan_policy="propagate"))
            cells = [
                f"{a.mean():.3f}",
                f"{b.mean():.3f}",
                f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]",
                f"{np.median(d):+.3f}",
            ]
            print(f"| `{name}` | {reading} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
