"""The starting forgetting's effect on final return, pooled over the seed sets run both ways
(exploratory, session 26): the 0.15 PPO default (forgetting 0.1 per 4,096 points before the
first choice) against 0.13's critic (``gp_kwargs=dict(forgetting=1.0)``, otherwise the same),
and each against SB3's MLP critic, on Acrobot-v1 and PaperPendulum-v0.

    python results/replication_0_15/start_forgetting/start_pool.py

Difference of means with a 95 % percentile-bootstrap interval (seed 0, 10,000 resamples),
runs unpaired as in the comparison. On seeds 0-9 0.13's critic is the 0.11 default's runs
(`results/snapshot_summary/candidate_s0_9`), which 0.13's critic repeats; on 10-19 the 0.12
default's (`results/fresh_0_12/ppo_default`), the same critic.
"""

from __future__ import annotations

import numpy as np

from sb3_geogp.comparison.results import load_results

HERE = "results/replication_0_15/start_forgetting"
#: seeds -> (0.15 default, 0.13's critic, MLP): folders holding their PPO runs
SETS = {
    "0-9": (
        "results/shrink_points/s0_9",
        "results/snapshot_summary/candidate_s0_9",
        "results/compare",
    ),
    "10-19": (
        "results/replication_0_15/ppo_s10",
        "results/fresh_0_12/ppo_default",
        "results/replication_s10/ppo",
    ),
    "20-29": (f"{HERE}/default_s20", f"{HERE}/f1_s20", f"{HERE}/default_s20"),
    "140-149": (
        f"{HERE}/default_s140",
        "results/lagged_points/s140_reference",
        "results/lagged_points/s140_reference",
    ),
    "150-159": (
        "results/shrink_points/s150_candidate",
        f"{HERE}/f1_s150",
        "results/shrink_points/s150_reference",
    ),
}
CRITICS = ("laplacian", "laplacian", "mlp")
HEADER = (
    "| cell (PPO) | seeds | 0.15 | 0.13's critic | MLP | 0.15 − 0.13 | 0.15 − MLP | 0.13 − MLP |\n"
    "|---|---|---|---|---|---|---|---|"
)
CELLS = ("Acrobot-v1", "sb3_geogp/PaperPendulum-v0")
#: Acrobot-v1's return at its 500-step cap: a run that never reached the goal
ACROBOT_CAP = -500.0


def finals(folder: str, cell: str, critic: str) -> np.ndarray:
    """Final returns of the PPO runs of ``critic`` on ``cell`` in ``folder``, by seed."""
    runs = [
        r for r in load_results(folder)
        if (r["spec"]["env_id"], r["spec"]["algo"], r["spec"]["critic"]) == (cell, "ppo", critic)
    ]  # fmt: skip
    return np.array([r["final_return"] for r in sorted(runs, key=lambda r: r["spec"]["seed"])])


def interval(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of ``mean(a) - mean(b)``."""
    diffs = [rng.choice(a, a.size).mean() - rng.choice(b, b.size).mean() for _ in range(10_000)]
    low, high = np.percentile(diffs, [2.5, 97.5])
    return float(low), float(high)


def main() -> None:
    rng = np.random.default_rng(0)
    lines, stall_line = [HEADER], ""
    for cell in CELLS:
        sets = {
            seeds: [finals(f, cell, c) for f, c in zip(dirs, CRITICS, strict=True)]
            for seeds, dirs in SETS.items()
        }
        sets["pooled"] = [np.concatenate(v) for v in zip(*sets.values(), strict=True)]
        for seeds, (new, old, mlp) in sets.items():
            cells = [f"{x.mean():.1f}" for x in (new, old, mlp)]
            for a, b in ((new, old), (new, mlp), (old, mlp)):
                low, high = interval(a, b, rng)
                cells.append(f"{a.mean() - b.mean():+.1f} [{low:+.1f}, {high:+.1f}]")
            lines.append(f"| {cell} | {seeds} ({new.size}) | " + " | ".join(cells) + " |")
        if cell == "Acrobot-v1":
            capped = [int((v <= ACROBOT_CAP).sum()) for v in sets["pooled"]]
            stalls = ", ".join(
                f"{n} {c}" for n, c in zip(("0.15", "0.13", "MLP"), capped, strict=True)
            )
            stall_line = (
                f"Acrobot-v1 runs at the -500 cap, pooled: {stalls} (of {sets['pooled'][0].size})"
            )
    print("\n".join([*lines, "", stall_line]))


if __name__ == "__main__":
    main()
