"""Fixed-policy value-estimation check: on-line adaptive GP against a batch sparse GP (issue 13).

Runs :func:`sb3_geogp.studies.pendulum.batch_check.run_check` (Monte Carlo ground truth on the
60 x 60 grid; per kernel, seed and max BV an adaptive and a default on-line GP over the same
stream of episodes, and a batch DTC/VFE sparse GP on all the data with the adaptive GP's
basis vectors and marginal-likelihood hyperparameters) and writes to ``--out``:

* ``results.json``: provenance, configuration, one row per kernel, seed and max BV, summary;
* ``table.md``: MSEs (mean ± 95% CI) and MSE ratios (geometric mean [95% CI]) per max BV;
* ``mse_ratio.png``: MSE and on-line / batch ratio against max BV, per kernel.

Usage::

    python examples/fixed_policy_check.py --out docs/fixed_policy_check  # full run
    python examples/fixed_policy_check.py --quick --out runs/fixed_quick   # smoke run (seconds)
    python examples/fixed_policy_check.py --prior-sd 0.1 --out runs/fixed_prior  # with a hyperprior
    python examples/fixed_policy_check.py --adapt '{"max_gap": 8}' --out runs/fixed_gap8
    python examples/fixed_policy_check.py --kernels laplacian --trend level --out runs/fixed_level
"""

from __future__ import annotations

import argparse
import json
import textwrap
import time
import typing
from dataclasses import replace
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.ticker import FormatStrFormatter, LogLocator
from rich.console import Console
from tqdm import tqdm

from sb3_geogp.adaptation import Adaptation, as_adaptation
from sb3_geogp.kernels import KernelName
from sb3_geogp.studies.pendulum.batch_check import ONLINE, CheckConfig, CheckResult, run_check
from sb3_geogp.studies.pendulum.ground_truth import mc_value
from sb3_geogp.studies.pendulum.task import Task
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.tables import MIN_SAMPLES_FOR_INTERVAL

#: The on-line / batch ratio the issue asks for at 50-200 basis vectors.
GOAL_RATIO = 1.2
#: Legend label and colour of each model.
STYLE = {
    "adaptive": ("on-line, adaptive", "C0"),
    "default": ("on-line, no adaptation", "C1"),
    "batch": ("batch DTC/VFE, ML hyperparameters", "C2"),
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line options (``argv`` defaults to ``sys.argv[1:]``)."""
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="smoke run: tiny sizes, seconds")
    parser.add_argument("--out", type=Path, default=Path("runs/fixed_policy_check"))
    parser.add_argument("--seeds", type=count_arg, default=None, help="seeds (default 5; quick 1)")
    parser.add_argument(
        "--max-basis",
        type=count_arg,
        nargs="+",
        default=None,
        help="max BVs, each once (default 20 50 100 200)",
    )
    parser.add_argument(
        "--prior-sd", type=float, default=None, help="Adaptation.prior_sd (default: no prior)"
    )
    parser.add_argument(
        "--adapt",
        type=json.loads,
        default=None,
        help='other Adaptation settings as JSON, e.g. \'{"max_gap": 8, "fold_points": 512}\'',
    )
    parser.add_argument(
        "--trend",
        choices=("none", "level", "constant", "linear"),
        default="none",
        help="the adaptive on-line GP's trend (the PPO default since 0.9: level)",
    )
    parser.add_argument(
        "--forgetting",
        type=float,
        default=1.0,
        help="the adaptive on-line GP's forgetting until its adaptation first chooses (the "
        "PPO default since 0.14: 0.1)",
    )
    parser.add_argument(
        "--forgetting-points",
        type=int,
        default=None,
        help="what that forgetting is per, in points (the PPO default since 0.14: 4096; "
        "default: per batch)",
    )
    parser.add_argument(
        "--kernels",
        nargs="+",
        choices=typing.get_args(KernelName),
        default=None,
        help="kernels checked (default: rbf geodesic)",
    )
    args = parser.parse_args(argv)
    if args.max_basis is not None and len(set(args.max_basis)) < len(args.max_basis):
        # Rows are placed by capacity: a repeated one would be run twice and tabled once.
        parser.error(f"--max-basis names a capacity twice: {args.max_basis}")
    return args


#: Labelled ticks of the ratio axis.
RATIO_TICKS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.5, 2.0, 3.0, 5.0)


def plot(result: CheckResult, path: Path) -> None:
    """MSE (top) and on-line / batch MSE ratio (bottom) against max BV, one column per kernel.

    Error bars are 95% Student-t intervals over seeds (of the mean MSE; of the mean log ratio),
    drawn only from :data:`~sb3_geogp.toolbox.tables.MIN_SAMPLES_FOR_INTERVAL` seeds on.
    """
    cfg = result.config
    n_seeds = len(cfg.seeds)
    bars = n_seeds >= MIN_SAMPLES_FOR_INTERVAL
    m = np.asarray(cfg.max_basis)
    fig, axes = plt.subplots(2, len(cfg.kernels), figsize=(5.5 * len(cfg.kernels), 7.5))
    axes = np.asarray(axes).reshape(2, len(cfg.kernels))
    for col, kernel in enumerate(cfg.kernels):
        top, bottom = axes[:, col]
        for name, (label, colour) in STYLE.items():
            mean, half = mean_ci(result.values(kernel, f"mse_{name}"), nan_policy="omit")
            # A log axis cannot show a bar below zero: clip the lower half at 1% of the mean.
            low = np.minimum(half, 0.99 * mean)
            yerr = np.vstack([low, half]) if bars else None
            top.errorbar(m, mean, yerr=yerr, label=label, color=colour, marker="o", capsize=3)
        top.set(yscale="log", xscale="log", ylabel="MSE vs Monte Carlo value", title=kernel)
        for online in ONLINE:
            label, colour = STYLE[online]
            ratio, lo, hi = result.ratio(kernel, online)
            yerr = np.vstack([ratio - lo, hi - ratio]) if bars else None
            bottom.errorbar(
                m, ratio, yerr=yerr, label=f"{label} / batch", color=colour, marker="o", capsize=3
            )
        bottom.axhline(1.0, color="0.5", lw=0.8)
        bottom.axhline(GOAL_RATIO, color="C3", ls="--", lw=1, label=f"goal {GOAL_RATIO}x")
        bottom.set(
            yscale="log",
            xscale="log",
            xlabel="max BV",
            ylabel="MSE ratio on-line / batch (geometric mean)",
        )
        for ax in (top, bottom):
            ax.set_xticks(m, [str(v) for v in m])
            ax.minorticks_off()
            # Plain numbers at 1, 2, 5 x 10^k: the values span less than two decades.
            ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        # The ratios often span less than a factor of 2, where 1-2-5 ticks would leave one label.
        low, high = bottom.get_ylim()
        bottom.set_yticks([t for t in RATIO_TICKS if low <= t <= high])
    what = (
        f"error bars: 95% Student-t interval over {n_seeds} seeds"
        if bars
        else f"{n_seeds} seed(s): no error bars (fewer than {MIN_SAMPLES_FOR_INTERVAL})"
    )
    options = [f"trend={cfg.trend}"] if cfg.trend != "none" else []
    if (cfg.forgetting, cfg.forgetting_points) != (1.0, None):
        options += [f"forgetting={cfg.forgetting:g}", f"forgetting_points={cfg.forgetting_points}"]
    engine = Adaptation().as_dict()
    options += [f"{k}={v}" for k, v in cfg.adaptation.as_dict().items() if v != engine[k]]
    listed = textwrap.fill(f"adaptive on-line GP: {', '.join(options)}", 60)
    setting = f"\n{listed}" if options else ""
    # Lines: a one-kernel figure is too narrow for the title and its captions in one.
    fig.suptitle(f"Fixed-policy check, pendulum: on-line GP vs batch sparse GP\n({what}){setting}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    """Run the check and write ``results.json``, ``table.md`` and ``mse_ratio.png``."""
    args = parse_args(argv)
    console = Console()
    config = CheckConfig.quick() if args.quick else CheckConfig()
    if args.seeds is not None:
        config = replace(config, seeds=tuple(range(args.seeds)))
    if args.max_basis is not None:
        config = replace(config, max_basis=tuple(args.max_basis))
    if args.kernels is not None:
        config = replace(config, kernels=tuple(args.kernels))
    config = replace(
        config,
        trend=args.trend,
        forgetting=args.forgetting,
        forgetting_points=args.forgetting_points,
    )
    settings = dict(args.adapt or {})
    if args.prior_sd is not None:
        settings["prior_sd"] = args.prior_sd
    if settings:
        adaptation = as_adaptation({**config.adaptation.as_dict(), **settings})
        assert adaptation is not None
        config = replace(config, adaptation=adaptation)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)
    record = provenance()  # before the run: the engine files may change meanwhile
    task = Task()
    start = time.perf_counter()
    with console.status("ground truth: Monte Carlo on the grid"):
        truth = mc_value(task, config.grid_n, config.mc_rollouts)

    def progress(cases: Any, total: int) -> Any:
        return tqdm(cases, total=total, desc="cases (kernel x seed x max BV)", unit="case")

    result = run_check(config, task, truth, progress=progress)
    result.provenance = record
    minutes = (time.perf_counter() - start) / 60
    table = result.table()
    (out / "results.json").write_text(
        json.dumps({**result.to_json(), "minutes": minutes}, indent=1) + "\n"
    )
    (out / "table.md").write_text(table + "\n")
    plot(result, out / "mse_ratio.png")
    console.print(table, soft_wrap=True, markup=False)
    console.print(f"[bold]wrote[/bold] results.json, table.md, mse_ratio.png to {out}")
    console.print(f"{minutes:.1f} min")


if __name__ == "__main__":
    main()
