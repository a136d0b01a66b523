"""Reproduce the paper's pendulum experiment: value maps, BV graph, MSE and variance vs max BV.

Runs :func:`sb3_geogp.studies.pendulum.reproduction.run_reproduction` (Monte Carlo and TD
ground truth on the 60 x 60 grid; RBF, Euclidean-Laplacian and geodesic GPs plus geodesic
variants and an MLP; three hyperparameter settings; a sweep of max_basis over seeds) and
writes to ``--out``:

* ``fig1_value_maps.png``: MC truth, its standard error, the TD baseline, GP value maps;
* ``fig2_bv_graph.png``: the geodesic GP's basis-vector graph and value map;
* ``fig3_mse_variance.png``: MSE and normalised variance vs max BV (mean, 95% CI);
* ``fig4_controls.png``: geodesic / control error ratios, error at the discontinuities;
* ``results.csv`` (one row per seed, capacity, model and setting), ``results.json``
  (provenance, configuration, ground-truth summary, mean and 95% CI per model,
  setting and max_basis), ``results.md``
  (markdown tables), ``ground_truth.npz`` (grid, MC value and standard error, TD value).

Usage::

    python examples/reproduce_paper.py --out docs/reproduction  # full run (~4 min, 2 cores)
    python examples/reproduce_paper.py --quick --out runs/quick  # smoke run (< 1 min)
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import torch
from rich.console import Console
from tqdm import tqdm

from sb3_geogp.studies.pendulum.report import FIGURES, TABLES, write_figures, write_tables
from sb3_geogp.studies.pendulum.reproduction import (
    ReproductionConfig,
    compute_ground_truth,
    run_reproduction,
)
from sb3_geogp.studies.pendulum.task import Task
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line options (``argv`` defaults to ``sys.argv[1:]``)."""
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="smoke run: tiny sizes, < 1 min")
    parser.add_argument("--out", type=Path, default=Path("runs/reproduce_paper"))
    parser.add_argument(
        "--workers", type=count_arg, default=None, help="processes (default 2; quick 1)"
    )
    parser.add_argument("--seeds", type=count_arg, default=None, help="seeds (default 8; quick 2)")
    parser.add_argument("--map-basis", type=int, default=None, help="max BV of Figure 1's GP maps")
    parser.add_argument("--graph-basis", type=int, default=None, help="max BV of Figure 2")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Run the reproduction and write every figure and table to ``--out``."""
    args = parse_args(argv)
    console = Console()
    config = ReproductionConfig.quick() if args.quick else ReproductionConfig()
    workers = args.workers if args.workers is not None else (1 if args.quick else 2)
    config = replace(config, workers=workers)
    if args.seeds is not None:
        config = replace(config, seeds=tuple(range(args.seeds)))
    map_basis = args.map_basis or (10 if args.quick else 40)
    graph_basis = args.graph_basis or (40 if args.quick else 100)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)
    task = Task()
    start = time.perf_counter()

    with console.status("ground truth: Monte Carlo on the grid and the TD baseline"):
        truth = compute_ground_truth(task, config)
    console.print(f"ground truth done ({time.perf_counter() - start:.0f} s)")

    def progress(jobs: Any, total: int) -> Any:
        return tqdm(jobs, total=total, desc="fits (seed x max_basis)", unit="job")

    result = run_reproduction(config, task, truth, progress=progress)
    with console.status("figures"):
        write_figures(result, out, map_basis, graph_basis)
    minutes = (time.perf_counter() - start) / 60
    text = write_tables(result, out, minutes)
    console.print(text)
    console.print(f"[bold]wrote[/bold] {', '.join(FIGURES + TABLES)} to {out} in {minutes:.1f} min")


if __name__ == "__main__":
    main()
