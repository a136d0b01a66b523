"""The exploratory screen of ``screen.sh`` (session 84): PPO HalfCheetah-v5, seeds 1133-1137,
one change to the default GP critic per arm, against the registered study's own runs of the
same seeds (``normalized``: the default GP critic and SB3's MLP critic in ``VecNormalize``)::

    python results/heldout2/screen_read.py > results/heldout2/screen.md

Final return of the deterministic evaluations and area under the evaluation curve; differences
are paired by seed (mean of the per-seed differences, 95 % t interval over five seeds).
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.results import METRICS, load_results
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
ENV_ID = "HalfCheetah-v5"
SEEDS = list(range(1133, 1138))
#: Arm: (folder, critic); the first two are the registered study's runs.
ARMS = {
    "default GP critic (0.43)": (HERE / "normalized", "laplacian"),
    "SB3's MLP critic (`VecNormalize`)": (HERE / "normalized", "mlp"),
    "SB3's returns as targets (`target='returns'`)": (HERE / "screen/sb3_returns", "laplacian"),
    "no lengthscale hyperprior (`prior_sd=None`)": (HERE / "screen/no_prior", "laplacian"),
    "RBF kernel": (HERE / "screen/rbf", "rbf"),
    "512 basis vectors": (HERE / "screen/basis512", "laplacian"),
    "default GP critic, no `VecNormalize` (the table's rule)": (
        HERE / "screen/table_rule",
        "laplacian",
    ),
    "SB3's MLP critic, no `VecNormalize` (the table's rule)": (HERE / "screen/table_rule", "mlp"),
}
LABELS = {"final_return": "final return", "mean_return": "area under the curve"}


@cache
def arm_runs(arm: str) -> dict[int, dict[str, Any]]:
    """The arm's runs on :data:`ENV_ID` by seed, read once (empty: not run)."""
    folder, critic = ARMS[arm]
    if not (folder / "runs").is_dir():
        return {}
    return {r["spec"]["seed"]: r for r in load_results(folder)
            if r["spec"]["env_id"] == ENV_ID and r["spec"]["critic"] == critic}  # fmt: skip


def readings(arm: str, metric: str) -> np.ndarray | None:
    """The arm's ``metric`` on seeds :data:`SEEDS`, in seed order (None: not run)."""
    runs = arm_runs(arm)
    if not set(SEEDS) <= set(runs):
        return None
    return np.array([METRICS[metric].of_run(runs[s]) for s in SEEDS])


def paired(a: np.ndarray, b: np.ndarray) -> str:
    """Mean of ``a - b`` per seed with its 95 % t interval."""
    mean, half = (float(v) for v in mean_ci(a - b, nan_policy="propagate"))
    return f"{mean:+.1f} [{mean - half:+.1f}, {mean + half:+.1f}]"


def main() -> None:
    print(f"# Why the GP critic trails on PPO {ENV_ID}: a screen (session 84, exploratory)\n")
    print(f"Seeds {SEEDS[0]}-{SEEDS[-1]}, 50,000 steps, the registered study's protocol; "
          "differences paired by seed, 95 % t intervals.\n")  # fmt: skip
    default, mlp = list(ARMS)[:2]
    for metric, label in LABELS.items():
        print(f"## {label}\n")
        print("| arm | mean | − default GP critic | − SB3's MLP critic | per seed |")
        print("|---|---|---|---|---|")
        bases = {name: readings(name, metric) for name in (default, mlp)}
        for arm in ARMS:
            r = readings(arm, metric)
            if r is None:
                print(f"| {arm} | not run | | | |")
                continue
            cells = ["" if arm == name else paired(r, b) for name, b in bases.items()]
            seeds = " ".join(f"{v:.0f}" for v in r)
            print(f"| {arm} | {r.mean():.1f} | {cells[0]} | {cells[1]} | {seeds} |")
        print()
        gp, mlp_raw = (readings(arm, metric) for arm in list(ARMS)[-2:])
        if gp is not None and mlp_raw is not None:
            print(f"Both critics without `VecNormalize`, GP − MLP: {paired(gp, mlp_raw)}.\n")


if __name__ == "__main__":
    main()
