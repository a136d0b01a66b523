"""The rule's untested middle: PPO Acrobot-v1 at ``gamma`` 0.999 (session 45, exploratory).

0.26 cuts PPO's Monte Carlo returns after 200 steps where ``gamma ** 200 >= 0.5``; the tasks
measured had 0.13 (Acrobot, ``gamma`` 0.99, frozen runs) and 0.98 (MountainCarContinuous,
0.9999, a gain). Many zoo configurations use ``gamma`` 0.999 (weight 0.82, cut by the rule).
This screen runs Acrobot with the zoo's hyperparameters but ``gamma`` 0.999, 100,000 steps, on
fresh PPO seeds 430-449, with the default feed (cut) and uncut returns: do cut runs freeze
there too? A screen on 20 seeds, not a test; no default changes on it.

    python results/acrobot100k_cut/gamma999.py > results/acrobot100k_cut/gamma999.md
"""

from __future__ import annotations

import dataclasses
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.run import result_path, run_one
from sb3_geogp.comparison.specs import RunSpec, SweepConfig, fed
from sb3_geogp.toolbox.stats import difference_ci

HERE = Path(__file__).resolve().parent
OUT = HERE / "gamma999"
SEEDS = tuple(range(430, 450))
GAMMA = 0.999
ARMS = {"cut (0.26 default)": None, "uncut": "monte_carlo"}


def specs(target: str | None) -> list[RunSpec]:
    config = SweepConfig(
        algos=("ppo",), critics=("laplacian",), envs=("Acrobot-v1",), seeds=SEEDS,
        timesteps=100_000, target=target,  # type: ignore[arg-type]
    )  # fmt: skip
    out = []
    for spec in config.specs():
        spec = dataclasses.replace(spec, hyperparams={**spec.hyperparams, "gamma": GAMMA})
        if target is None:  # the default feed at this discount, as GPValueCallback resolves it
            feed, horizon = fed(None, None, "ppo", "laplacian", GAMMA)
            spec = dataclasses.replace(spec, target=feed, horizon=horizon)
        out.append(spec)
    return out


def run(args: tuple[RunSpec, str]) -> dict[str, Any]:
    spec, folder = args
    path = result_path(OUT / folder, spec)
    if path.exists():  # resumed
        return json.loads(path.read_text())
    return run_one(spec, OUT / folder)


def main() -> None:
    jobs = [(s, name.split()[0]) for name, t in ARMS.items() for s in specs(t)]
    with ProcessPoolExecutor(2) as pool:
        results = list(pool.map(run, jobs))
    by_arm = {name: [r for r, (_, f) in zip(results, jobs, strict=True) if f == name.split()[0]]
              for name in ARMS}  # fmt: skip
    print(f"PPO Acrobot-v1, gamma {GAMMA}, 100,000 steps, seeds {SEEDS[0]}-{SEEDS[-1]}\n")
    print("| feed | mean final return | runs ending at -500 | all-zero warning |")
    print("|---|---:|---:|---:|")
    for name, runs in by_arm.items():
        finals = np.array([r["final_return"] for r in runs])
        warned = sum(any("is exactly 0" in w for w in r["warnings"]) for r in runs)
        print(f"| {name} | {finals.mean():.1f} | {int((finals <= -500).sum())} of {len(runs)} | "
              f"{warned} |")  # fmt: skip
    cut, uncut = (np.array([r["final_return"] for r in runs]) for runs in by_arm.values())
    estimate, lo, hi = difference_ci(uncut, cut)
    print(
        f"\nuncut − cut, final return: {estimate:+.1f} [{lo:+.1f}, {hi:+.1f}] "
        "(95 % percentile bootstrap of the difference of means)"
    )


if __name__ == "__main__":
    main()
