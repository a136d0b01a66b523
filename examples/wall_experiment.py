"""Geodesic vs Euclidean sparse GPs on the two-room value function, across basis sizes.

Fits every model of :data:`sb3_geogp.studies.wall.comparison.MODELS` to the same noisy
goal-directed walks for each seed and basis capacity, then writes to ``--out``:

* ``results.json``: provenance, settings, raw per-seed metrics and their mean / 95% CI;
* ``results.md``: the markdown tables (also printed): mean ± 95% CI per model and capacity,
  and same-seed error ratios of the default geodesic GP to the controls, then of the oracle
  (``geo_wall_aware``, attachments that never cross the wall) to its controls;
* ``mse_vs_max_basis.png``: MSE overall and near the wall with 95% CI bands;
* ``value_maps.png``: truth, RBF, the default geodesic GP and the oracle (BVs and graph drawn)
  at one capacity, with the walks and the error maps.

Usage::

    python examples/wall_experiment.py --out runs/wall            # full run (~2 min, 1 core)
    python examples/wall_experiment.py --quick --out runs/wall_q  # smoke run (seconds)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import torch
from tqdm import tqdm

from sb3_geogp.studies.wall.comparison import (
    FitSettings,
    WalkSettings,
    fit_gp,
    paired_table,
    run_comparison,
    summarize,
    summary_table,
)
from sb3_geogp.studies.wall.plots import mse_curves, value_maps
from sb3_geogp.studies.wall.rooms import TwoRooms
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg

FULL = {"max_basis": (10, 20, 40, 80, 160), "grid_nx": 160, "n_episodes": 100}
QUICK = {"max_basis": (10, 40), "grid_nx": 60, "n_episodes": 40}
#: What the oracle is compared with: the same kernel attached blindly, RBF, and the Euclidean
#: Laplacian GP predicting by Shepard interpolation with and without the same oracle.
ORACLE_REFERENCES = ("geo_default", "rbf", "euclid_lap_shepard_wall", "euclid_lap_shepard")


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="small smoke run (seconds)")
    parser.add_argument("--out", type=Path, default=Path("runs/wall_experiment"))
    parser.add_argument("--seeds", type=count_arg, default=None, help="seeds (default 10; quick 2)")
    parser.add_argument("--lengthscale", type=float, default=FitSettings.lengthscale)
    parser.add_argument(
        "--episodes-per-batch", type=count_arg, default=None, help="walks per update (default: all)"
    )
    parser.add_argument(
        "--novelty-tol", type=float, default=None, help="shared novelty_tol (default: library's)"
    )
    parser.add_argument("--map-basis", type=int, default=40, help="capacity of the value maps")
    return parser.parse_args()


def main() -> None:
    args = parse_args()
    torch.set_num_threads(1)
    preset = QUICK if args.quick else FULL
    n_seeds = args.seeds if args.seeds is not None else (2 if args.quick else 10)
    fit = FitSettings(lengthscale=args.lengthscale, novelty_tol=args.novelty_tol)
    walks = WalkSettings(n_episodes=preset["n_episodes"])
    rooms = TwoRooms()
    source = provenance()  # before the run: the engine files may change meanwhile
    start = time.perf_counter()
    result = run_comparison(
        max_basis=preset["max_basis"],
        seeds=range(n_seeds),
        rooms=rooms,
        fit=fit,
        walks=walks,
        grid_nx=preset["grid_nx"],
        episodes_per_batch=args.episodes_per_batch,
        progress=lambda jobs: tqdm(jobs, desc="fits", unit="fit"),
    )
    elapsed = time.perf_counter() - start
    table = "\n\n".join(
        [
            f"Mean ± 95% CI over {len(result.seeds)} seeds ({elapsed:.0f} s):",
            summary_table(result),
            "Same-seed ratios, geometric mean [min, max] and wins:",
            paired_table(result),
            "The oracle's same-seed ratios (attachments that never cross the wall):",
            paired_table(result, "geo_wall_aware", ORACLE_REFERENCES),
        ]
    )
    print(table)

    args.out.mkdir(parents=True, exist_ok=True)
    record = {
        "provenance": source,
        "config": result.config,
        "max_basis": result.max_basis,
        "seeds": result.seeds,
        "raw": result.values,
        "summary": summarize(result),
        "seconds": elapsed,
    }
    (args.out / "results.json").write_text(json.dumps(record, indent=1))
    (args.out / "results.md").write_text(table + "\n")
    mse_curves(result).savefig(args.out / "mse_vs_max_basis.png", dpi=120)
    data = walks.generate(rooms, seed=0)
    map_basis = min(args.map_basis, max(result.max_basis))
    gps = {
        name: fit_gp(name, data, map_basis, fit, args.episodes_per_batch, rooms)
        for name in ("rbf", "geo_default", "geo_wall_aware")
    }
    value_maps(rooms, data, gps).savefig(args.out / "value_maps.png", dpi=110)
    print(f"wrote {args.out}/results.json, results.md, mse_vs_max_basis.png, value_maps.png")


if __name__ == "__main__":
    main()
