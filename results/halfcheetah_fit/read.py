"""``PLAN.md``'s reading of ``runs/``: each predictor's explained variance on the tail batches,
per seed and over the seeds, and each off-line predictor minus the on-line critic::

    python results/halfcheetah_fit/read.py > results/halfcheetah_fit/read.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy import stats

HERE = Path(__file__).resolve().parent
NAMES = (
    "online", "exact_gp", "mlp_newest", "mlp_all", "gbt_newest", "gbt_all", "ridge_newest",
    "ridge_all",
)  # fmt: skip


def main() -> None:
    runs = [json.loads(p.read_text()) for p in sorted((HERE / "runs").glob("s*.json"))]
    seeds = [r["seed"] for r in runs]
    tails = {n: np.array([np.mean(r["scores"][n]) for r in runs]) for n in NAMES}
    print("# What HalfCheetah-v5's episodes allow (PLAN.md)\n")
    print(f"Seeds {', '.join(map(str, seeds))}; tail: batches {runs[0]['scores']['batches']} ")
    print("(explained variance of each batch's fed returns, before learning it; tail mean).\n")
    head = " | ".join(f"seed {s}" for s in seeds)
    print(f"| predictor | {head} | mean | − online [95 % t] |")
    print("|---|" + "---:|" * (len(seeds) + 2))
    for n in NAMES:
        cells = " | ".join(f"{v:.3f}" for v in tails[n])
        diff = ""
        if n != "online":
            d = tails[n] - tails["online"]
            half = stats.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d))
            diff = f"{d.mean():+.3f} [{d.mean() - half:+.3f}, {d.mean() + half:+.3f}]"
        print(f"| `{n}` | {cells} | {tails[n].mean():.3f} | {diff} |")


if __name__ == "__main__":
    main()
