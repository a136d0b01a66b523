"""The starting forgetting's effect on final return, pooled over the seed sets run both ways
(exploratory, session 26): the 0.15 PPO default (forgetting 0.1 per 4,096 points before the
first choice) against 0.13's critic (``gp_kwargs=dict(forgetting=1.0)``, otherwise the same),
and each against SB3's MLP critic, on Acrobot-v1 and PaperPendulum-v0.

    python results/replication_0_15/start_forgetting/start_pool.py

Difference of means with the comparison's percentile-bootstrap interval
(:func:`~sb3_geogp.toolbox.stats.difference_ci`, runs unpaired), at 95 % per seed set and, for
the pooled seeds, also at the published family-wise level (42 comparisons). On seeds 0-9
0.13's critic is the 0.11 default's runs (`results/snapshot_summary/candidate_s0_9`), which
0.13's critic repeats; on 10-19 the 0.12 default's (`results/fresh_0_12/ppo_default`), the
same critic.
"""

from __future__ import annotations

import numpy as np

from sb3_geogp.comparison.results import group_runs, load_results
from sb3_geogp.toolbox.stats import difference_ci

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
#: Per-comparison level of the published rule's family-wise verdicts (42 comparisons).
FAMILY_WISE = 1 - 0.05 / 42


def finals(folder: str, cell: str, critic: str) -> np.ndarray:
    """Final returns of the PPO runs of ``critic`` on ``cell`` in ``folder``, by seed."""
    runs = group_runs(load_results(folder))[(cell, "ppo", critic)]
    return np.array([r["final_return"] for r in runs])


def difference(a: np.ndarray, b: np.ndarray, level: float = 0.95) -> str:
    """``mean(a) - mean(b) [low, high]`` at ``level``."""
    d, low, high = (float(x) for x in difference_ci(a, b, level=level))
    return f"{d:+.1f} [{low:+.1f}, {high:+.1f}]"


def main() -> None:
    lines, family_wise, stall_line = [HEADER], [], ""
    for cell in CELLS:
        sets = {
            seeds: [finals(f, cell, c) for f, c in zip(dirs, CRITICS, strict=True)]
            for seeds, dirs in SETS.items()
        }
        sets["pooled"] = [np.concatenate(v) for v in zip(*sets.values(), strict=True)]
        for seeds, (new, old, mlp) in sets.items():
            cells = [f"{x.mean():.1f}" for x in (new, old, mlp)]
            cells += [difference(a, b) for a, b in ((new, old), (new, mlp), (old, mlp))]
            lines.append(f"| {cell} | {seeds} ({new.size}) | " + " | ".join(cells) + " |")
        new, old, mlp = sets["pooled"]
        pairs = ((new, old), (new, mlp), (old, mlp))
        cells = [difference(a, b, FAMILY_WISE) for a, b in pairs]
        family_wise.append(f"| {cell} | " + " | ".join(cells) + " |")
        if cell == "Acrobot-v1":
            capped = [int((v <= ACROBOT_CAP).sum()) for v in sets["pooled"]]
            stalls = ", ".join(
                f"{n} {c}" for n, c in zip(("0.15", "0.13", "MLP"), capped, strict=True)
            )
            stall_line = (
                f"Acrobot-v1 runs at the -500 cap, pooled: {stalls} (of {sets['pooled'][0].size})"
            )
    fw_header = (
        "Pooled, at the family-wise level:\n\n"
        "| cell (PPO) | 0.15 − 0.13 | 0.15 − MLP | 0.13 − MLP |\n|---|---|---|---|"
    )
    print("\n".join([*lines, "", stall_line, "", fw_header, *family_wise]))


if __name__ == "__main__":
    main()
