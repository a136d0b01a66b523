"""The held-out study's PPO cells with the spread-following options (sessions 82-83,
exploratory): InvertedPendulum-v5, InvertedDoublePendulum-v5 and Reacher-v5, seeds 1023-1032,
final return of the deterministic evaluations, against the study's own default and MLP runs
(``results/heldout/normalized``, made with 0.39's default, whose code the options leave as it
was)::

    python results/heldout_follow_widen/read.py > results/heldout_follow_widen/read.md

``follow_spread=True``'s runs are session 82's (``results/heldout_follow_spread``; none on
InvertedPendulum-v5, which session 82 ran with ``results/heldout_noise``'s protocol instead),
``"widen"``'s this folder's (0.43's default: named in the options, or ``adapt=True`` with
0.43's code). Intervals: 95 % percentile bootstrap, each arm's seeds resampled separately.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.results import load_results
from sb3_geogp.toolbox.stats import bootstrap_ci, difference_ci

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
ENVS = ("InvertedPendulum-v5", "InvertedDoublePendulum-v5", "Reacher-v5")
#: Arm name: (folder, critic, whether the run's adaptation must follow the spread as named).
ARMS = {
    "0.39 default": (RESULTS / "heldout" / "normalized", "laplacian", False),
    "`follow_spread=True`": (RESULTS / "heldout_follow_spread", "laplacian", True),
    '`"widen"` (0.43 default)': (HERE, "laplacian", "widen"),
    "SB3's MLP critic (`VecNormalize`)": (RESULTS / "heldout" / "normalized", "mlp", None),
}


def final_returns(arm: str, env_id: str) -> np.ndarray | None:
    """The arm's final returns on ``env_id``, in seed order (None: the arm has no runs there)."""
    folder, critic, follow = ARMS[arm]
    runs = [r for r in load_results(folder)
            if r["spec"]["env_id"] == env_id and r["spec"]["critic"] == critic]  # fmt: skip
    if not runs:
        return None
    runs.sort(key=lambda r: r["spec"]["seed"])
    if critic != "mlp":
        assert all(follows(r) == follow for r in runs), f"{arm}: not follow_spread={follow!r}"
    assert [r["spec"]["seed"] for r in runs] == list(range(1023, 1033)), arm
    return np.array([r["final_return"] for r in runs])


def follows(run: dict[str, Any]) -> bool | str:
    """The run's ``follow_spread``: as its options name it, else (``adapt=True``) its
    version's PPO default, ``"widen"`` since 0.43."""
    adapt = run["spec"]["gp_kwargs"].get("adapt")
    if isinstance(adapt, dict):
        return adapt.get("follow_spread", False)
    major, minor = (int(v) for v in run["provenance"]["versions"]["sb3_geogp"].split(".")[:2])
    return "widen" if adapt is True and (major, minor) >= (0, 43) else False


def main() -> None:
    print("# The held-out study's PPO cells with the spread-following options\n")
    print("Seeds 1023-1032, final return; exploratory (sessions 82-83).\n")
    for env_id in ENVS:
        returns = {arm: final_returns(arm, env_id) for arm in ARMS}
        default, mlp = returns["0.39 default"], returns["SB3's MLP critic (`VecNormalize`)"]
        assert default is not None and mlp is not None
        print(f"## {env_id}\n")
        print("| arm | final return [95 %] | − 0.39 default | − SB3's MLP critic |")
        print("|---|---|---|---|")
        for arm, r in returns.items():
            if r is None:
                print(f"| {arm} | not run | | |")
                continue
            mean, lo, hi = bootstrap_ci(r)
            cells = [f"{mean:.2f} [{lo:.2f}, {hi:.2f}]"]
            for base in (default, mlp):
                d, dlo, dhi = difference_ci(r, base)
                cells.append("" if base is r else f"{d:+.2f} [{dlo:+.2f}, {dhi:+.2f}]")
            print(f"| {arm} | " + " | ".join(cells) + " |")
        print()


if __name__ == "__main__":
    main()
