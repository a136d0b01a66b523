"""The reading of ``PLAN.md``: exact GPs with Monte Carlo GPTD noise against independent
noise on the drop-in PPO default's Acrobot batches (``run.py``'s docstring has the commands)::

    python results/return_noise/read.py --plot results/return_noise/read.png \\
        > results/return_noise/read.md
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
TABLES = load_script(HERE.parent / "actor_features" / "read.py", "actor_features_read")
ROWS = {
    "independent": "exact Laplacian GP, newest batch, independent noise",
    "gptd": "exact Laplacian GP, newest batch, Monte Carlo GPTD noise",
}
READINGS = (("gptd", "independent"),)
RULE = (
    "the trajectory noise model predicts the next batch better",
    "it does not predict the next batch better",
    "it predicts the next batch worse",
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    by_seed = TABLES.load([HERE / "a", HERE / "b"])
    for result in by_seed.values():
        for name in ROWS:
            result[name]["noise_var"] = [f["noise_var"] for f in result[name]["fitted"]]
    title = "Monte Carlo GPTD noise against independent noise, exact GPs"
    print(TABLES.report(by_seed, ROWS, READINGS, RULE, title))
    for name in ROWS:
        fits = [f for r in by_seed.values() for f in r[name]["fitted"]]
        quartiles = np.percentile([f["noise_var"] for f in fits], [25, 50, 75])
        signal = np.median([f["signal_var"] for f in fits])
        print(
            f"{name}: fitted noise variance quartiles {quartiles[0]:.3g} / {quartiles[1]:.3g} / "
            f"{quartiles[2]:.3g}, median signal variance {signal:.3g} "
            f"(standardised targets; {len(fits)} fits of {min(f['points'] for f in fits)}-"
            f"{max(f['points'] for f in fits)} points)\n"
        )
    if args.plot is not None:
        TABLES.plot(
            by_seed, ROWS, "the returns' noise, independent or along trajectories", args.plot
        )


if __name__ == "__main__":
    main()
