"""``PREREGISTRATION.md``'s reading of ``run.sh``'s runs (a partial run decides nothing)::

python results/pp_whole/read.py > results/pp_whole/read.md
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.comparison.results import METRICS, comparisons, load_results
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
WHOLE = load_script(HERE.parent / "whole_batch" / "read.py", "whole_batch")
SEEDS = range(783, 883)
ARMS = ("whole", "old", "mlp")
#: What a slow run is, and the test of their shares (``results/paper_pendulum_tail``).
TAIL = load_script(HERE.parent / "paper_pendulum_tail" / "read.py", "paper_pendulum_tail")


def arm_runs(arm: str) -> dict[int, dict[str, Any]]:
    """The finished runs of ``arm``, by seed."""
    return {r["spec"]["seed"]: r for r in load_results(HERE / arm)}


def plot(runs: dict[str, dict[int, dict[str, Any]]], path: Path) -> None:
    """Each arm's evaluation return along training: mean over seeds, and its 95 % t band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4))
    labels = {"whole": "GP critic, 0.35 (whole_batch)", "old": "GP critic, 0.34",
              "mlp": "SB3's MLP critic"}  # fmt: skip
    for arm, colour in zip(ARMS, ("C3", "C0", "0.3"), strict=True):
        steps = np.array(runs[arm][SEEDS.start]["eval"]["timesteps"])
        curves = np.array([runs[arm][s]["eval"]["mean_return"] for s in SEEDS])
        mean, half = mean_ci(curves.T, nan_policy="propagate")
        ax.plot(steps, mean, color=colour, label=labels[arm])
        ax.fill_between(steps, mean - half, mean + half, color=colour, alpha=0.2, lw=0)
    ax.set_xlabel("timesteps")
    ax.set_ylabel("evaluation return")
    ax.set_title(f"PPO PaperPendulum-v0, seeds {SEEDS.start}-{SEEDS.stop - 1}")
    ax.legend(loc="lower right")
    fig.text(0.01, 0.01, "bands: 95 % t interval of the mean over 100 seeds", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    runs = {arm: arm_runs(arm) for arm in ARMS}
    done = {arm: len(r) for arm, r in runs.items()}
    print(f"PPO PaperPendulum-v0, 30,000 steps, seeds {SEEDS.start}-{SEEDS.stop - 1}; runs "
          f"finished: {done}\n")  # fmt: skip
    if any(n != len(SEEDS) for n in done.values()):
        print("Not every run finished: nothing is decided (PREREGISTRATION.md).")
        return
    final = {arm: np.array([runs[arm][s]["final_return"] for s in SEEDS]) for arm in ARMS}
    auc = {arm: np.array([METRICS["mean_return"].of_run(runs[arm][s]) for s in SEEDS])
           for arm in ARMS}  # fmt: skip
    print("| arm | mean final return | median | runs below 115 | mean area under the curve |")
    print("|---|---:|---:|---:|---:|")
    for arm in ARMS:
        print(f"| {arm} | {final[arm].mean():.1f} | {np.median(final[arm]):.1f} | "
              f"{int((final[arm] < TAIL.SLOW).sum())} | {auc[arm].mean():.1f} |")  # fmt: skip
    diff = final["whole"] - final["old"]
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    low, high = mean - half, mean + half
    rule = "costs the cell" if high < 0 else "helps" if low > 0 else "no difference"
    print(f"\n**Rule 1** (primary): final return, whole − old, paired by seed: {mean:+.2f} "
          f"[{low:+.2f}, {high:+.2f}] (95 % t): **{rule}**.\n")  # fmt: skip
    slow_whole, slow_old, fisher_p = TAIL.slow_runs(final["whole"], final["old"])
    auc_diff = auc["whole"] - auc["old"]
    a_mean, a_half = (float(v) for v in mean_ci(auc_diff, nan_policy="propagate"))
    print("Secondary, decided on by nothing:\n")
    print(f"- whole − old: Wilcoxon signed-rank p = {WHOLE.wilcoxon(diff):.2g}, "
          f"{int((diff > 0).sum())} seeds up / {int((diff < 0).sum())} down; area under the "
          f"curve {a_mean:+.2f} [{a_mean - a_half:+.2f}, {a_mean + a_half:+.2f}]; runs below "
          f"115: {slow_whole} against {slow_old}, Fisher's exact p = {fisher_p:.2f}.")  # fmt: skip
    for arm in ("whole", "old"):
        pooled = [*runs[arm].values(), *runs["mlp"].values()]
        rows = {r["metric"]: r for r in comparisons(pooled) if r["b"] == "mlp"}
        mw = sps.mannwhitneyu(final[arm], final["mlp"])
        print(f"- {arm} − MLP by the table's rule: final return "
              f"{rows['final_return']['diff']:+.1f} [{rows['final_return']['low']:+.1f}, "
              f"{rows['final_return']['high']:+.1f}], {rows['final_return']['verdict']}; area "
              f"under the curve {rows['mean_return']['diff']:+.1f}, "
              f"{rows['mean_return']['verdict']}; Mann-Whitney p = {mw.pvalue:.2f}, P(run above "
              f"an MLP run) = {mw.statistic / len(SEEDS) ** 2:.3f}.")  # fmt: skip
    if args.plot:
        plot(runs, args.plot)


if __name__ == "__main__":
    main()
