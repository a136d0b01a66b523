"""Print the runs of ``run.sh`` next to the stored ones they explain (session 69).

python results/cpu_model/read.py > results/cpu_model/read.md
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
RUN = "runs/ppo__laplacian__MountainCarContinuous-v0__s0.json"
ROWS = {
    "stored table run (results/ppo_horizon200/mcc_s0)": RESULTS / "ppo_horizon200" / "mcc_s0",
    "the same commit, this machine (old_commit)": HERE / "old_commit",
    "0.34.1's default (results/whole_batch/check_default)": RESULTS / "whole_batch/check_default",
    "0.35.0's default (results/mcc_refresh/s0)": RESULTS / "mcc_refresh" / "s0",
    **{f"today's code, MKL_CBWR {v} (mkl_{v})": HERE / f"mkl_{v}"
       for v in ("unset", "COMPATIBLE", "AVX2", "AVX512")},
}  # fmt: skip


def row(label: str, folder: Path) -> str:
    """One run's record: its code, its machine, its first two evaluations and its last."""
    run = json.loads((folder / RUN).read_text())
    evals = run["eval"]
    prov, curve = (
        run["provenance"],
        dict(zip(evals["timesteps"], evals["mean_return"], strict=True)),
    )
    machine = prov["machine"]
    return (
        f"| {label} | {prov['git_commit'][:8]} ({prov['versions']['sb3_geogp']}) | "
        f"{machine['cpu_model']}, {machine['torch_cpu_capability']}, "
        f"{machine['torch_threads']} thread | {curve[0]!r} | {curve[1000]!r} | "
        f"{run['num_timesteps']} | {run['final_return']!r} |"
    )


def first_evaluations() -> Counter[tuple[str, str, str, bool]]:
    """Pair every stored table run that records its CPU with its session-68 re-run (the same
    env and seed) and count, by env and the two CPUs, whether their evaluations at 0 steps (the
    untrained actor, before any update or GP feed) are equal to the last bit."""
    stored: dict[tuple[str, int], dict[str, Any]] = {}
    for folder in ("table50/ppo_s570", "ppo_horizon200"):
        for path in sorted((RESULTS / folder).rglob("runs/ppo__laplacian__*.json")):
            run = json.loads(path.read_text())
            stored[(run["spec"]["env_id"], run["spec"]["seed"])] = run
    pairs: Counter[tuple[str, str, str, bool]] = Counter()
    for folder in ("whole_batch", "mcc_refresh"):
        for path in sorted((RESULTS / folder).glob("*s*/runs/ppo__laplacian__*.json")):
            rerun = json.loads(path.read_text())
            old = stored.get((rerun["spec"]["env_id"], rerun["spec"]["seed"]))
            if old is None or "machine" not in old["provenance"]:
                continue
            cpus = (
                old["provenance"]["machine"]["cpu_model"],
                rerun["provenance"]["machine"]["cpu_model"],
            )
            equal = old["eval"]["mean_return"][0] == rerun["eval"]["mean_return"][0]
            pairs[(rerun["spec"]["env_id"], *cpus, equal)] += 1
    return pairs


def main() -> None:
    print("PPO MountainCarContinuous-v0, seed 0, the GP critic: evaluation returns at 0 and "
          "1,000 steps and at the run's end\n")  # fmt: skip
    print("| run | commit (version) | machine | at 0 | at 1,000 | run's steps | at its end |")
    print("|---|---|---|---:|---:|---:|---:|")
    for label, folder in ROWS.items():
        print(row(label, folder))
    print(
        "\nThe evaluation at 0 steps of the table's stored PPO GP runs that record their CPU "
        "(`results/table50/ppo_s570`, `results/ppo_horizon200`) against their session-68 "
        "re-runs (`results/whole_batch/*`, `results/mcc_refresh/*`), same env and seed\n"
    )
    print("| env | stored on | re-run on | equal to the last bit | runs |")
    print("|---|---|---|---|---:|")
    for (env, old, new, equal), n in sorted(first_evaluations().items()):
        print(f"| {env} | {old} | {new} | {'yes' if equal else 'no'} | {n} |")


if __name__ == "__main__":
    main()
