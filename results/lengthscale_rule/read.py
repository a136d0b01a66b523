"""The registered reading of ``PLAN.md`` (session 85): ``lengthscale_rule="distance"`` against
PPO's default GP critic (``"spread"``) on HalfCheetah-v5 and Hopper-v5, seeds 1143-1152::

    python results/lengthscale_rule/read.py > results/lengthscale_rule/read.md

Per cell and metric, ``distance`` − ``spread`` paired by seed (the mean of the per-seed
differences, 95 % percentile bootstrap over seeds); then each GP critic − SB3's MLP critic in
final return under the table's rule (groups resampled apart). ``--dir`` reads another folder of
the same layout (a frozen worktree's runs).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.results import METRICS, load_results
from sb3_geogp.toolbox.stats import bootstrap_ci, difference_ci

HERE = Path(__file__).resolve().parent
ENVS = ("HalfCheetah-v5", "Hopper-v5")
SEEDS = tuple(range(1143, 1153))
#: Arm: (folder, critic)
ARMS = {
    "spread": ("spread", "laplacian"),
    "distance": ("distance", "laplacian"),
    "mlp": ("spread", "mlp"),
}
#: Each cell's final-return reading (PLAN.md): its role, and its verdict from the paired
#: interval ``(low, high)``
DECISIONS: dict[str, tuple[str, Callable[[float, float], str]]] = {
    "HalfCheetah-v5": ("primary", lambda low, high: "confirmed" if low > 0 else "not confirmed"),
    "Hopper-v5": ("guard", lambda low, high: "worse" if high < 0 else "not worse"),
}


def arm_readings(root: Path) -> dict[tuple[str, str], dict[str, np.ndarray]]:
    """``(arm, env)`` -> metric -> readings on the seeds of :data:`SEEDS` that finished, in
    seed order."""
    runs: dict[str, list[dict[str, Any]]] = {}
    for folder in {f for f, _ in ARMS.values()}:
        runs[folder] = load_results(root / folder) if (root / folder / "runs").is_dir() else []
    out = {}
    for arm, (folder, critic) in ARMS.items():
        for env in ENVS:
            by_seed = {r["spec"]["seed"]: r for r in runs[folder]
                       if r["spec"]["env_id"] == env and r["spec"]["critic"] == critic}  # fmt: skip
            seeds = [s for s in SEEDS if s in by_seed]
            out[arm, env] = {
                "seeds": np.array(seeds),
                **{m: np.array([METRICS[m].of_run(by_seed[s]) for s in seeds]) for m in METRICS},
            }
    return out


def interval(estimate: Any, low: Any, high: Any) -> str:
    return f"{float(estimate):+.1f} [{float(low):+.1f}, {float(high):+.1f}]"


def paired_table(readings: dict[tuple[str, str], dict[str, np.ndarray]]) -> None:
    print("## `distance` − `spread`, paired by seed\n")
    print("| env | metric | seeds | spread | distance | distance − spread [95 %] | reading |")
    print("|---|---|---|---|---|---|---|")
    for env in ENVS:
        a, b = readings["distance", env], readings["spread", env]
        common = np.intersect1d(a["seeds"], b["seeds"])
        if not len(common):
            print(f"| {env} | | 0 | | | not run | |")
            continue
        pick = {k: np.isin(v["seeds"], common) for k, v in (("a", a), ("b", b))}
        for metric in ("final_return", "mean_return", "critic_rmse"):
            x, y = a[metric][pick["a"]], b[metric][pick["b"]]
            est, low, high = bootstrap_ci(x - y)
            reading = ""
            if metric == "final_return":
                role, verdict = DECISIONS[env]
                reading = f"{verdict(float(low), float(high))} ({role})"
            partial = "" if len(common) == len(SEEDS) else " (partial)"
            label = METRICS[metric].label.split(" (")[0]
            diff = interval(est, low, high)
            print(f"| {env} | {label} | {len(common)}{partial} | {y.mean():.1f} | {x.mean():.1f} "
                  f"| {diff} | {reading} |")  # fmt: skip
    print()


def mlp_table(readings: dict[tuple[str, str], dict[str, np.ndarray]]) -> None:
    print("## Each GP critic − SB3's MLP critic (`VecNormalize`), final return, table's rule\n")
    print("| env | MLP | spread − MLP [95 %] | distance − MLP [95 %] |")
    print("|---|---|---|---|")
    for env in ENVS:
        mlp = readings["mlp", env]["final_return"]
        if not len(mlp):
            continue
        cells = []
        for arm in ("spread", "distance"):
            gp = readings[arm, env]["final_return"]
            cells.append(interval(*difference_ci(gp, mlp)) if len(gp) else "not run")
        print(f"| {env} | {mlp.mean():.1f} ({len(mlp)}) | {cells[0]} | {cells[1]} |")
    print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", type=Path, default=HERE)
    args = parser.parse_args()
    print("# Lengthscales that grow with the number of inputs: the registered reading "
          "(session 85)\n")  # fmt: skip
    print("PPO, 50,000 steps, seeds 1143-1152, the held-out studies' primary protocol "
          "(`results/lengthscale_rule/PLAN.md`).\n")  # fmt: skip
    readings = arm_readings(args.dir)
    paired_table(readings)
    mlp_table(readings)


if __name__ == "__main__":
    main()
