"""The reading of PLAN.md: PPO CartPole-v1, PPO's default with ``follow_spread=True`` minus the
stored 0.39 default runs of issue 13's table, paired by seed (session 82, registered)::

    python results/follow_spread_default/read.py > results/follow_spread_default/read.md
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
TABLE = HERE.parent / "fit_spacing" / "table"
RUN = "ppo__laplacian__CartPole-v1__s{}.json"
PRIMARY = (*range(150, 170), *range(570, 580))
#: Seen before the plan (exploratory, ``results/follow_spread_cartpole/follow``).
SEEN = tuple(range(20))
READINGS = {
    "final return": (lambda r: r["final_return"], -1),
    "area under the curve": (lambda r: float(np.mean(r["eval"]["mean_return"])), -1),
    "final critic RMSE": (lambda r: r["critic_accuracy"]["rmse"][-1], +1),
}


@functools.cache
def run(folder: Path, seed: int) -> dict[str, Any]:
    """A run's result file, read once."""
    return json.loads((folder / "runs" / RUN.format(seed)).read_text())


def candidate(seed: int) -> dict[str, Any]:
    if seed in SEEN:
        return run(HERE.parent / "follow_spread_cartpole" / "follow", seed)
    return run(HERE / ("s150" if seed < 570 else "s570"), seed)


def block(seed: int) -> int:
    """The first seed of the table's sweep that holds ``seed`` (0, 150 or 570)."""
    return 0 if seed < 150 else 150 if seed < 570 else 570


def default(seed: int) -> dict[str, Any]:
    return run(TABLE / f"CartPole-v1_s{block(seed)}", seed)


Runs = Callable[[int], dict[str, Any]]


def rows(seeds: tuple[int, ...], candidate: Runs = candidate, default: Runs = default) -> list[str]:
    """The table's rows: each reading, ``candidate``'s runs minus ``default``'s (by default
    the stored PPO CartPole-v1 runs of 0.39's table)."""
    out = []
    for name, (read, worse_sign) in READINGS.items():
        a = np.array([read(candidate(s)) for s in seeds])
        b = np.array([read(default(s)) for s in seeds])
        mean, half = (float(v) for v in mean_ci(a - b, nan_policy="omit"))
        lo, hi = mean - half, mean + half
        better = lo > 0 if worse_sign < 0 else hi < 0
        worse = hi < 0 if worse_sign < 0 else lo > 0
        verdict = "worse at 95 %" if worse else "better at 95 %" if better else "no difference"
        interval = f"{mean:+.2f} [{lo:+.2f}, {hi:+.2f}]"
        out.append(f"| {name} | {a.mean():.2f} | {b.mean():.2f} | {interval} | {verdict} |")
    return out


def reproductions() -> list[str]:
    out = []
    for seed in (150, 570):
        again = run(HERE / f"repro{seed}", seed)
        same = all(
            again[k] == default(seed)[k] for k in ("eval", "critic_accuracy", "final_return")
        )
        out.append(f"- seed {seed}: the default re-run equals the stored run: {same}")
    return out


def main() -> None:
    head = [
        "| reading | `follow_spread` | 0.39 default | difference [95 % t] | verdict |",
        "|---|---|---|---|---|",
    ]
    print("# `follow_spread` in PPO's default: PPO CartPole-v1 (session 82, registered)\n")
    print(f"## Primary: seeds 150-169 and 570-579 ({len(PRIMARY)}, paired)\n")
    print("\n".join(head + rows(PRIMARY)))
    print("\n## Secondary: all 50 table seeds (0-19 seen before the plan)\n")
    print("\n".join(head + rows(SEEN + PRIMARY)))
    print("\n## The stored default runs reproduce\n")
    print("\n".join(reproductions()))
    commits = {candidate(s)["provenance"]["git_commit"][:8] for s in PRIMARY}
    print(f"\nThe primary candidate runs were made at commit(s) {', '.join(sorted(commits))}.")


if __name__ == "__main__":
    main()
