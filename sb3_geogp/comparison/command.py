"""The ``sb3-geogp compare`` command (also ``examples/compare_critics.py``): options, main."""

from __future__ import annotations

import argparse
import ast
import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.hyperparams import ALGOS, CRITICS, ENVS, GP_KWARGS
from sb3_geogp.comparison.specs import SweepConfig
from sb3_geogp.comparison.sweep import run_sweep
from sb3_geogp.policies import build_gp_critic, check_gp_kwargs

#: First line of ``--help``.
DESCRIPTION = "Compare critics inside ordinary SB3 training: MLP vs RBF-GP vs geodesic-GP."


def add_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add the comparison's options to ``parser`` (shared by the example and the CLI)."""
    parser.add_argument("--out", type=Path, default=Path("results/compare"), help="results dir")
    parser.add_argument("--quick", action="store_true", help="smoke sweep: 5%% budgets, 2 seeds")
    parser.add_argument("--workers", type=int, default=2, help="parallel processes")
    parser.add_argument("--seeds", type=int, default=None, help="number of seeds (0..n-1)")
    parser.add_argument(
        "--timesteps-scale", type=float, default=None, help="multiply the per-env budgets"
    )
    parser.add_argument("--ray", action="store_true", help="run the runs as Ray tasks")
    parser.add_argument("--algos", nargs="+", choices=sorted(ALGOS), default=None)
    parser.add_argument("--critics", nargs="+", choices=CRITICS, default=None)
    parser.add_argument("--envs", nargs="+", choices=ENVS, default=None, metavar="ENV")
    parser.add_argument(
        "--gp-option",
        action="append",
        default=None,
        metavar="KEY=VALUE",
        type=_gp_option,
        help="option of both GP critics, e.g. forgetting=0.9 (repeatable)",
    )
    parser.add_argument(
        "--baseline",
        type=Path,
        default=None,
        metavar="DIR",
        help="also compare each critic with the same critic of the sweep in DIR",
    )
    parser.add_argument("--no-plots", action="store_true", help="skip figures and the table")
    parser.add_argument(
        "--estimate-from",
        type=Path,
        default=None,
        metavar="DIR",
        help="only print the sweep's estimated duration, calibrated on the results in DIR",
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    return parser


def _gp_option(text: str) -> tuple[str, Any]:
    key, sep, value = text.partition("=")
    if not sep or not key.isidentifier():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE (e.g. forgetting=0.9), got {text!r}")
    try:
        return key, ast.literal_eval(value)
    except (ValueError, SyntaxError):
        return key, value  # a bare word, e.g. dtype=float32


def _check_gp_options(options: list[tuple[str, Any]]) -> tuple[tuple[str, Any], ...]:
    """``options`` if both GP critics accept them; else exit naming the problem, before any run
    starts (a bad option would otherwise fail in every worker)."""
    merged = {**GP_KWARGS, **dict(options)}
    if "kernel" in merged:
        raise SystemExit(
            "--gp-option kernel=...: the kernel is the critic, choose it with --critics"
        )
    try:
        checked = check_gp_kwargs(merged)  # the policy's own checks and construction
        for kernel in ("rbf", "geodesic"):
            build_gp_critic({**checked, "kernel": kernel}, input_dim=1)
    except (TypeError, ValueError) as e:
        raise SystemExit(f"--gp-option: the GP critic rejects {dict(options)}: {e}") from e
    return tuple(options)


def config_from_args(args: argparse.Namespace) -> SweepConfig:
    """The :class:`SweepConfig` described by parsed :func:`add_arguments` options."""
    config = SweepConfig.quick() if args.quick else SweepConfig()
    changes: dict[str, Any] = {}
    if args.seeds is not None:
        if args.seeds < 1:
            raise SystemExit("--seeds must be positive")
        changes["seeds"] = tuple(range(args.seeds))
    if args.timesteps_scale is not None:
        if not args.timesteps_scale > 0:
            raise SystemExit("--timesteps-scale must be positive")
        changes["timesteps_scale"] = args.timesteps_scale
    for name in ("algos", "critics", "envs"):
        if getattr(args, name) is not None:
            changes[name] = tuple(getattr(args, name))
    if args.gp_option:
        changes["gp_options"] = _check_gp_options(args.gp_option)
    return dataclasses.replace(config, **changes)


def main(argv: Sequence[str] | None = None) -> int:
    """Run (or resume) a sweep, then aggregate it; returns the exit status."""
    parser = add_arguments(argparse.ArgumentParser(description=DESCRIPTION))
    args = parser.parse_args(argv)
    return run_from_args(args)


def run_from_args(args: argparse.Namespace) -> int:
    """Body of :func:`main` for already parsed arguments (used by ``sb3-geogp compare``)."""
    config = config_from_args(args)
    n_total = len(config.specs())
    if args.estimate_from is not None:
        from sb3_geogp.comparison.results import estimate_sweep_seconds, load_results

        est = estimate_sweep_seconds(
            load_results(args.estimate_from), config.specs(), workers=args.workers
        )
        print(
            f"estimate for {n_total} runs: {est['total_seconds'] / 3600:.2f} CPU hours, "
            f"{est['wall_seconds'] / 3600:.2f} h with {args.workers} workers on idle cores"
        )
        if est["missing"]:
            print(f"no calibration data (not counted): {', '.join(est['missing'])}")
        return 0
    print(f"sweep: {n_total} runs -> {args.out} ({args.workers} workers)")
    executed = run_sweep(
        config, args.out, workers=args.workers, use_ray=args.ray, progress=not args.no_progress
    )
    print(f"ran {len(executed)} runs, {n_total - len(executed)} were already done")
    if not args.no_plots:
        from sb3_geogp.comparison.report import matplotlib_available, write_report

        for path in write_report(args.out, baseline_dir=args.baseline):
            print(f"wrote {path}")
        if not matplotlib_available():
            print("figures skipped: matplotlib is not installed (pip install matplotlib)")
    return 0
