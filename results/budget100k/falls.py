"""How often a PPO CartPole-v1 run falls after reaching the threshold, per critic (session 37).

A fall: the evaluation curve reaches 475 at some checkpoint and the run ends below 300. Counted
on the 100,000-step runs of ``s170``, on the 40 seeds per critic of issue 13's table at
30,000 steps (the pool of ``results/replication_0_15/pool30.py --add ppo160``) and on the
pre-registered fresh seeds 180-199 (``falls_s180``, ``FALLS_PREREGISTRATION.md``: one-sided,
the GP critic's rate higher), with Fisher's exact test of the two critics' fall rates among
the runs that reached 475.

    python results/budget100k/falls.py > results/budget100k/falls.md
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.comparison.results import load_results

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent / "replication_0_15"))
from pool30 import pooled_runs  # noqa: E402

THRESHOLD, FALLEN = 475.0, 300.0
CRITICS = ("mlp", "laplacian")


def counts(runs: list[dict[str, Any]], critic: str) -> tuple[int, int, list[int]]:
    """Runs, runs that reached the threshold, and the seeds of those that then fell."""
    mine = [r for r in runs if r["spec"]["critic"] == critic]
    curves = {r["spec"]["seed"]: np.array(r["eval"]["mean_return"]) for r in mine}
    reached = {s: c for s, c in curves.items() if c.max() >= THRESHOLD}
    fell = sorted(s for s, c in reached.items() if c[-1] < FALLEN)
    return len(mine), len(reached), fell


def table(name: str, runs: list[dict[str, Any]], alternative: str = "two-sided") -> list[str]:
    cartpole = [
        r for r in runs if (r["spec"]["env_id"], r["spec"]["algo"]) == ("CartPole-v1", "ppo")
    ]
    rows = {critic: counts(cartpole, critic) for critic in CRITICS}
    lines = [f"| {name} | {c} | {n} | {k} | {len(f)} | {', '.join(map(str, f)) or '–'} |"
             for c, (n, k, f) in rows.items()]  # fmt: skip
    (_, k_mlp, f_mlp), (_, k_gp, f_gp) = rows["mlp"], rows["laplacian"]
    table_2x2 = [[len(f_gp), k_gp - len(f_gp)], [len(f_mlp), k_mlp - len(f_mlp)]]
    p = sps.fisher_exact(table_2x2, alternative=alternative).pvalue
    return [*lines, f"| {name} | GP vs MLP, Fisher's exact p ({alternative}) | | | {p:.3f} | |"]


def main() -> None:
    print(
        f"PPO CartPole-v1: runs that reach {THRESHOLD:g} at a checkpoint and end below {FALLEN:g}."
    )
    print()
    print("| runs | critic | runs | reached the threshold | fell | seeds that fell |")
    print("|---|---|---:|---:|---:|---|")
    for line in table("100,000 steps, seeds 170-179", load_results(HERE / "s170")):
        print(line)
    for line in table("30,000 steps, issue 13's 40 seeds", pooled_runs("0.22", ("ppo160",))):
        print(line)
    # The pre-registered test (FALLS_PREREGISTRATION.md): fresh seeds, one-sided.
    fresh = HERE / "falls_s180"
    if (fresh / "runs").is_dir():
        for line in table("100,000 steps, seeds 180-199", load_results(fresh), "greater"):
            print(line)


if __name__ == "__main__":
    main()
