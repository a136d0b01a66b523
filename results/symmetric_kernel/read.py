"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``), with the check that
its ``full`` predictor equals ``results/additive_kernel``'s::

    python results/symmetric_kernel/read.py --plot results/symmetric_kernel/read.png \\
        > results/symmetric_kernel/read.md
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "read.py", "additive_kernel_read")
MODELS = ("full", "mirror", "mirror_learned")
PRIMARY = ("mirror", "full")
SECONDARY = ("mirror_learned", "full")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    runs, additive = ADDITIVE.load(HERE), ADDITIVE.load()
    seeds = list(runs)
    same = [s for s in seeds if s in additive and runs[s]["full"] == additive[s]["full"]]
    tail = {m: np.array([runs[s][m]["tail"] for s in seeds]) for m in MODELS}
    every = {
        m: np.array([np.mean(runs[s][m]["explained_variance"]) for s in seeds]) for m in MODELS
    }
    print(f"Acrobot-v1, PPO 30,000 steps, seeds {', '.join(map(str, seeds))}: each batch "
          "predicted by an exact GP on the batch before it (PLAN.md)\n")  # fmt: skip
    print(f"`full` equals `results/additive_kernel`'s `full` on {len(same)} of {len(seeds)} "
          f"seeds (every batch's score to the last digit).\n")  # fmt: skip
    print("| model | last 20 % of scored batches [lowest, highest] | all scored batches |")
    print("|---|---:|---:|")
    for m in MODELS:
        print(f"| {m} | {tail[m].mean():.3f} [{tail[m].min():.2f}, {tail[m].max():.2f}] | "
              f"{every[m].mean():.3f} |")  # fmt: skip
    print("\n| difference, paired by seed [95 % t] | last 20 % | all scored batches | up / down |")
    print("|---|---:|---:|---:|")
    for a, b in (PRIMARY, SECONDARY):
        diff = tail[a] - tail[b]
        both = ADDITIVE.interval(diff), ADDITIVE.interval(every[a] - every[b])
        print(f"| {a} − {b} | {' | '.join(both)} | "
              f"{int((diff > 0).sum())} / {int((diff < 0).sum())} |")  # fmt: skip
    weights = [v for s in seeds for v in runs[s]["mirror_learned"]["mirror_weight"]]
    quartiles = " / ".join(f"{q:.2f}" for q in np.quantile(weights, [0.25, 0.5, 0.75]))
    print(f"\nPrimary ({' − '.join(PRIMARY)}, last 20 %), by PLAN.md's rule: "
          f"**{ADDITIVE.verdict(tail[PRIMARY[0]] - tail[PRIMARY[1]])}** ({len(seeds)} seeds). "
          f"The learned mirror weight `w`, quartiles over its fits: {quartiles}.")  # fmt: skip
    if args.plot:
        title = "Acrobot-v1: exact GPs on the newest batch, by mirror weight"
        ADDITIVE.plot(tail, seeds, args.plot, MODELS, title)


if __name__ == "__main__":
    main()
