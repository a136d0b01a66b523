"""Where PPO PaperPendulum-v0's verdict against SB3's MLP critic comes from (session 69,
descriptive): the final returns of issue 13's 50 seeds for SB3's MLP critic, 0.34's default GP
critic (the table's stored runs) and 0.35's (``results/whole_batch``'s registered runs)::

    python results/paper_pendulum_tail/read.py > results/paper_pendulum_tail/read.md
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
TABLE50 = load_script(RESULTS / "table50" / "read.py", "table50")
WHOLE = load_script(RESULTS / "whole_batch" / "read.py", "whole_batch")
ENV = "sb3_geogp/PaperPendulum-v0"
#: A final return below this is a run still climbing at the budget's end (every MLP run ends
#: above 120; see the table).
SLOW = 115.0


def slow_runs(a: np.ndarray, b: np.ndarray) -> tuple[int, int, float]:
    """The runs below :data:`SLOW` among final returns ``a`` and ``b``, and the two-sided
    Fisher's exact p of the difference in their shares."""
    slow_a, slow_b = int((a < SLOW).sum()), int((b < SLOW).sum())
    table = [[slow_a, len(a) - slow_a], [slow_b, len(b) - slow_b]]
    return slow_a, slow_b, float(sps.fisher_exact(table).pvalue)


def finals(runs: list[dict[str, Any]], critic: str) -> dict[int, dict[str, Any]]:
    """The PPO runs of ``critic`` on PaperPendulum, by seed."""
    return {
        r["spec"]["seed"]: r
        for r in runs
        if r["spec"]["algo"] == "ppo"
        and r["spec"]["critic"] == critic
        and r["spec"]["env_id"] == ENV
    }


def main() -> None:
    published = TABLE50.published_and_fresh()
    whole = pool_sweeps([RESULTS / "whole_batch" / f"table_s{b}" for b in WHOLE.BLOCKS])
    arms = {
        "SB3's MLP critic": finals(published, "mlp"),
        "0.34's default GP critic": finals(published, "laplacian"),
        "0.35's default GP critic": finals(whole, "laplacian"),
    }
    mlp = np.array([r["final_return"] for r in arms["SB3's MLP critic"].values()])
    print("PPO PaperPendulum-v0, 30,000 steps, issue 13's 50 seeds, final evaluation return\n")
    print("| critic | runs | mean | median | lowest | runs below 115 | mean without them | "
          "Mann-Whitney p against the MLP | P(run above an MLP run) |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, runs in arms.items():
        a = np.array([r["final_return"] for r in runs.values()])
        test = sps.mannwhitneyu(a, mlp)
        print(f"| {name} | {len(a)} | {a.mean():.1f} | {np.median(a):.1f} | {a.min():.1f} | "
              f"{int((a < SLOW).sum())} | {a[a >= SLOW].mean():.1f} | {test.pvalue:.2f} | "
              f"{test.statistic / (len(a) * len(mlp)):.3f} |")  # fmt: skip
    print("\nThe runs below 115 in either GP arm, evaluation return at each checkpoint "
          "(0.34's, then 0.35's; same seed):\n")  # fmt: skip
    print("| seed | 0.34 final | 0.35 final | 0.34's curve | 0.35's curve |")
    print("|---:|---:|---:|---|---|")
    old, new = arms["0.34's default GP critic"], arms["0.35's default GP critic"]
    for seed in sorted(old):
        a, b = old[seed], new[seed]
        if min(a["final_return"], b["final_return"]) < SLOW:
            curves = [" ".join(f"{v:.0f}" for v in r["eval"]["mean_return"]) for r in (a, b)]
            print(f"| {seed} | {a['final_return']:.1f} | {b['final_return']:.1f} | "
                  f"{curves[0]} | {curves[1]} |")  # fmt: skip
    slow_old, slow_new, p = slow_runs(*(np.array([r["final_return"] for r in arm.values()])
                                        for arm in (old, new)))  # fmt: skip
    print(f"\nRuns below 115: 0.34 {slow_old}, 0.35 {slow_new} of 50; Fisher's exact p = {p:.2f}.")


if __name__ == "__main__":
    main()
