"""Write ``sparse_gp_releases.pt``: states and predictions of small GPs, each made by a
release's own code (the test that reads it: ``tests/test_sparse_gp.py``).

Run once per release with that release's package first on the path, then merge::

    for rev in 8be28f46 c9a28d84 62845774 aa6eec97; do   # the last commits of 0.3.0,
        mkdir -p /tmp/$rev                                 # 0.8.0, 0.19.0 and 0.31.3
        git archive $rev sb3_geogp | tar -x -C /tmp/$rev
        PYTHONPATH=/tmp/$rev python tests/data/make_release_states.py /tmp/$rev.pt
    done

and save ``{version: torch.load(file)}`` of the four files as ``sparse_gp_releases.pt``, keyed
by the release (``"0.3"``, ``"0.8"``, ``"0.19"``, ``"0.31.3"``). Only the API every release
since 0.3 has is used.
"""

from __future__ import annotations

import sys

import numpy as np
import torch

import sb3_geogp
from sb3_geogp import Adaptation, SparseOnlineGP


def main(out: str) -> None:
    """A geodesic GP and an RBF one with forgetting 0.9, 160 points of a random walk in 3
    dimensions in 4 trajectories, each state with its predictions at 6 probe points."""
    rng = np.random.default_rng(0)
    pos, xs = np.zeros(3), []
    for _ in range(160):
        pos = 0.9 * pos + 0.4 * rng.normal(size=3)
        xs.append(pos.copy())
    x = np.array(xs)
    y = np.sin(2 * x[:, 0]) + x[:, 1] + 0.05 * rng.normal(size=160)
    starts = np.zeros(160, bool)
    starts[::40] = True
    probe = torch.as_tensor(rng.normal(size=(6, 3)))
    configs = {"geodesic": {"kernel": "geodesic"}, "rbf": {"kernel": "rbf", "forgetting": 0.9}}
    saved = {"version": sb3_geogp.__version__, "probe": probe}
    for name, options in configs.items():
        adapt = Adaptation(window=64, interval=32)
        gp = SparseOnlineGP(3, max_basis=8, adapt=adapt, **options)
        for i in range(0, 160, 40):
            gp.update(x[i : i + 40], y[i : i + 40], starts[i : i + 40])
        mean, var = gp.predict(probe)
        saved[name] = {"state": gp.state_dict(), "mean": mean, "var": var}
    torch.save(saved, out)


if __name__ == "__main__":
    main(sys.argv[1])
