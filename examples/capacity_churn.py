"""Basis churn and accuracy at capacity on Pendulum-v1 returns (the table in docs/method.md).

Feeds four 2,048-step rollouts of a noisy swing-up controller to the RBF and the geodesic GP
(default thresholds) and prints, per ``max_basis``, the basis size, the number of BVs added and
deleted, and the explained variance of held-out returns (another seed).

    python examples/capacity_churn.py
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from sb3_geogp import SparseOnlineGP
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg
from sb3_geogp.toolbox.streams import pendulum_rollouts


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--max-basis", type=count_arg, nargs="+", default=[64, 256])
    parser.add_argument("--batches", type=count_arg, default=4)
    args = parser.parse_args()
    torch.set_num_threads(1)
    batch = 2048
    obs, returns, starts = pendulum_rollouts(args.batches * batch, seed=0)
    test_obs, test_returns, _ = pendulum_rollouts(batch, seed=5)
    print("| kernel | max_basis | BVs | added | deleted | explained variance |")
    print("|---|---|---|---|---|---|")
    for kernel in ("rbf", "geodesic"):
        for max_basis in args.max_basis:
            gp = SparseOnlineGP(3, kernel, max_basis=max_basis)
            for i in range(0, len(obs), batch):
                gp.update(obs[i : i + batch], returns[i : i + batch], starts[i : i + batch])
            pred = gp.predict(test_obs, return_var=False)[0].numpy()
            ev = 1 - np.mean((pred - test_returns) ** 2) / np.var(test_returns)
            print(
                f"| {kernel} | {max_basis} | {gp.n_basis} | {int(gp.n_added)} | "
                f"{int(gp.n_deleted)} | {ev:.3f} |"
            )


if __name__ == "__main__":
    main()
