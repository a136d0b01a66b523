"""The GP critic's predictive intervals against the fixed-policy pendulum's Monte Carlo value
(``PLAN.md``, session 54)::

    python results/calibration/calibration.py            # resumes: finished cases are kept
    python results/calibration/calibration.py --read --plot results/calibration/calibration.png \\
        > results/calibration/read.md
    python results/calibration/calibration.py --matern      # addendum 5: the Matérn arms
    python results/calibration/calibration.py --matern --read \\
        --plot results/calibration/matern.png > results/calibration/matern.md

Each case feeds one on-line GP the stream of the fixed-policy check
(:func:`~sb3_geogp.studies.pendulum.batch_check.new_online_gp`, the configuration of
``docs/fixed_policy_check_prior``) and scores its predictive mean and latent variance on the
60 x 60 grid against the Monte Carlo value, whose standard error is added to the variance.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import torch
from scipy import stats
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from tqdm import tqdm

from sb3_geogp.adaptation import as_adaptation
from sb3_geogp.kernels import KernelName
from sb3_geogp.policies import (
    build_gp_critic,
    default_adaptation,
    default_forgetting,
    default_kernel,
    default_trend,
    resolved_gp_kwargs,
)
from sb3_geogp.sparse_gp import SparseOnlineGP
from sb3_geogp.studies.pendulum.batch_check import (
    CheckConfig,
    feed_stream,
    new_online_gp,
    stream,
)
from sb3_geogp.studies.pendulum.ground_truth import GridValue, mc_value
from sb3_geogp.studies.pendulum.task import Task
from sb3_geogp.toolbox.pools import worker_pool
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
SOURCE = HERE.parents[1] / "docs" / "fixed_policy_check_prior" / "results.json"
RUNS = HERE / "runs.json"
#: Arm -> (kernel, adaptive): the check's engine settings (``PLAN.md``).
ARMS: dict[str, tuple[KernelName, bool]] = {
    "laplacian, adaptive": ("laplacian", True),
    "laplacian, fixed": ("laplacian", False),
    "rbf, adaptive": ("rbf", True),
}
#: Arm -> the algorithm whose drop-in critic it is (``PLAN.md``, addendum 1).
DROP_INS: dict[str, type[OnPolicyAlgorithm]] = {"ppo drop-in": PPO, "a2c drop-in": A2C}
#: ``PLAN.md``'s addendum 5 (``--matern``, into :data:`MATERN_RUNS`): arms as :data:`ARMS`, ...
MATERN_ARMS: dict[str, tuple[KernelName, bool]] = {"matern52, adaptive": ("matern", True)}
#: ... and drop-ins with the Matérn kernel: arm -> (algorithm, its ``gp_kwargs``).
MATERN_DROP_INS: dict[str, tuple[type[OnPolicyAlgorithm], dict[str, Any]]] = {
    "ppo drop-in, matern": (PPO, {"kernel": "matern"}),
    "a2c drop-in, matern": (A2C, {"kernel": "matern"}),
}
#: Each Matérn arm's references: the published arms that differ from it in the kernel only.
MATERN_PAIRS: dict[str, tuple[str, ...]] = {
    "matern52, adaptive": ("laplacian, adaptive", "rbf, adaptive"),
    "ppo drop-in, matern": ("ppo drop-in",),
    "a2c drop-in, matern": ("a2c drop-in",),
}
MATERN_RUNS = HERE / "matern_runs.json"
#: Addendum 5's tables list each Matérn arm after its references.
MATERN_READ = list(dict.fromkeys(a for arm, refs in MATERN_PAIRS.items() for a in (*refs, arm)))
SEEDS = (0, 1, 2, 3, 4)
CAPACITIES = (20, 50, 100, 200)
#: Nominal coverages recorded (the plan reads 0.5, 0.9 and 0.95; the rest draw the curve).
LEVELS = (*np.round(np.arange(0.05, 1.0, 0.05), 2).tolist(), 0.99)
REGIONS = ("all", "visited", "unvisited")


def check_config() -> CheckConfig:
    """The fixed-policy check's configuration, as ``docs/fixed_policy_check_prior`` ran it."""
    saved = json.loads(SOURCE.read_text())["config"]
    adaptation = as_adaptation(saved.pop("adaptation"))
    tuples = {k: tuple(v) for k, v in saved.items() if isinstance(v, list)}
    return CheckConfig(**{**saved, **tuples, "adaptation": adaptation})


def cell_counts(task: Task, states: np.ndarray, n: int) -> np.ndarray:
    """How many of ``states`` lie in each cell of :meth:`Task.grid`'s ``n x n`` grid, shape
    (n * n,), the grid's order (``omega`` the slow index)."""
    theta = np.floor((states[:, 0] + np.pi) / (2 * np.pi / n)).astype(int).clip(0, n - 1)
    speed = task.speed_limit
    omega = np.floor((states[:, 1] + speed) / (2 * speed / n)).astype(int).clip(0, n - 1)
    return np.bincount(omega * n + theta, minlength=n * n)


def scores(
    mu: np.ndarray, var: np.ndarray, value: np.ndarray, stderr: np.ndarray
) -> dict[str, Any]:
    """How the intervals of predictive means ``mu`` and latent variances ``var`` hold the
    reference ``value`` (standard errors ``stderr``, added to the variance), all shape (n,):
    coverage per nominal level, ``z_rms``, sharpness (median and root-mean-square posterior
    standard deviation), RMSE and NLPD."""
    s2 = var + stderr**2
    z = (value - mu) / np.sqrt(s2)
    quantiles = stats.norm.ppf(0.5 + np.array(LEVELS) / 2)
    return {
        "cells": len(mu),
        "coverage": {
            str(p): float(np.mean(np.abs(z) <= q)) for p, q in zip(LEVELS, quantiles, strict=True)
        },
        "z_rms": float(np.sqrt(np.mean(z**2))),
        "median_sd": float(np.median(np.sqrt(var))),
        "rms_sd": float(np.sqrt(np.mean(var))),
        "rmse": float(np.sqrt(np.mean((value - mu) ** 2))),
        "nlpd": float(np.mean(0.5 * np.log(2 * np.pi * s2) + 0.5 * z**2)),
    }


def drop_in_critic(
    algorithm: type[OnPolicyAlgorithm],
    task: Task,
    capacity: int,
    gp_kwargs: dict[str, Any] | None = None,
) -> SparseOnlineGP:
    """The critic ``GPActorCriticPolicy`` builds under ``algorithm`` for the pendulum's
    observations with ``gp_kwargs`` (none: the defaults), ``max_basis=capacity``."""
    options = resolved_gp_kwargs(
        {**(gp_kwargs or {}), "max_basis": capacity},
        default_kernel(algorithm),
        default_trend(algorithm),
        default_adaptation(algorithm),
        default_forgetting(algorithm),
    )
    high = np.array([np.pi, task.params.max_speed])
    return build_gp_critic(options, 2, (-high, high))


def new_critic(arm: str, task: Task, capacity: int, config: CheckConfig) -> SparseOnlineGP:
    """The unfed GP of ``arm`` (of :data:`ARMS`, :data:`DROP_INS` or their Matérn forms)."""
    if arm in DROP_INS:
        return drop_in_critic(DROP_INS[arm], task, capacity)
    if arm in MATERN_DROP_INS:
        algorithm, gp_kwargs = MATERN_DROP_INS[arm]
        return drop_in_critic(algorithm, task, capacity, gp_kwargs)
    kernel, adaptive = {**ARMS, **MATERN_ARMS}[arm]
    return new_online_gp(task, kernel, 2, capacity, config, adapt=adaptive)


def run_case(arm: str, seed: int, capacity: int, truth: GridValue) -> dict[str, Any]:
    torch.set_num_threads(1)
    task, config = Task(), check_config()
    data = stream(task, config, seed)
    gp = feed_stream(new_critic(arm, task, capacity, config), data, config.episodes_per_batch)
    states, _, _ = task.grid(truth.n)
    mean, var = gp.predict(states)
    assert var is not None
    mu, v = mean.double().numpy(), var.double().numpy()
    visited = cell_counts(task, data.states, truth.n) > 0
    masks = {"all": np.ones_like(visited), "visited": visited, "unvisited": ~visited}
    cut = {
        region: scores(mu[m], v[m], truth.value[m], truth.stderr[m])
        for region, m in masks.items()
        if m.any()
    }
    return {"arm": arm, "seed": seed, "max_basis": capacity, "n_basis": gp.n_basis, **cut}


def key(row: dict[str, Any]) -> tuple[str, int, int]:
    return row["arm"], row["seed"], row["max_basis"]


def run(workers: int, arms: list[str], path: Path) -> None:
    """Run every case of ``arms`` not yet in ``path``, adding each to it as it ends."""
    done = json.loads(path.read_text()) if path.is_file() else {"rows": []}
    have = {key(r) for r in done["rows"]}
    cases = [
        (arm, seed, m)
        for m in sorted(CAPACITIES, reverse=True)
        for arm in arms
        for seed in SEEDS
        if (arm, seed, m) not in have
    ]
    if not cases:
        print(f"all {len(have)} cases in {path}")
        return
    config = check_config()
    done.setdefault("provenance", provenance())
    print("ground truth: Monte Carlo on the grid ...", flush=True)
    truth = mc_value(Task(), config.grid_n, config.mc_rollouts)
    with worker_pool(workers) as pool:
        futures = [pool.submit(run_case, *case, truth) for case in cases]
        for future in tqdm(cf.as_completed(futures), total=len(futures), unit="case"):
            done["rows"].append(future.result())
            done["rows"].sort(key=key)
            path.write_text(json.dumps(done, indent=1) + "\n")


def values(rows: list[dict[str, Any]], arm: str, m: int, region: str, metric: str) -> np.ndarray:
    """One value per seed (NaN where the region is empty), seeds in order."""
    out = []
    for seed in SEEDS:
        (row,) = [r for r in rows if key(r) == (arm, seed, m)]
        cell = row.get(region)
        if cell is None:
            out.append(np.nan)
        elif metric.startswith("coverage_"):
            out.append(cell["coverage"][metric.removeprefix("coverage_")])
        else:
            out.append(cell[metric])
    return np.array(out, dtype=np.float64)


def interval(x: np.ndarray, digits: int = 3) -> str:
    mean, half = mean_ci(x, nan_policy="omit")
    if not np.isfinite(mean):
        return "–"
    return f"{mean:.{digits}f} [{mean - half:.{digits}f}, {mean + half:.{digits}f}]"


METRICS = {
    "coverage_0.5": "50 %",
    "coverage_0.9": "90 %",
    "coverage_0.95": "95 %",
    "coverage_0.99": "99 %",
    "z_rms": "z_rms",
    "median_sd": "median sd",
    "rmse": "RMSE",
    "nlpd": "NLPD",
}


def read(rows: list[dict[str, Any]]) -> str:
    """``PLAN.md``'s reading of the arms and drop-ins (``read.md``)."""
    lines = arm_tables(rows, [*ARMS, *DROP_INS])
    lines += [
        "",
        "## Adaptive − fixed hyperparameters (Laplacian), paired by seed",
        "",
        "| max BV | log z_rms, adaptive − fixed | 95 % coverage, adaptive − fixed |",
        "|---:|---:|---:|",
    ]
    for m in CAPACITIES:
        pair = [
            np.log(values(rows, "laplacian, adaptive", m, "all", "z_rms"))
            - np.log(values(rows, "laplacian, fixed", m, "all", "z_rms")),
            values(rows, "laplacian, adaptive", m, "all", "coverage_0.95")
            - values(rows, "laplacian, fixed", m, "all", "coverage_0.95"),
        ]
        lines.append(f"| {m} | " + " | ".join(interval(d, 3) for d in pair) + " |")
    near = {
        m: np.abs(np.log(values(rows, "laplacian, adaptive", m, "all", "z_rms"))).mean()
        < np.abs(np.log(values(rows, "laplacian, fixed", m, "all", "z_rms"))).mean()
        for m in CAPACITIES
    }
    lines += ["", f"adaptive z_rms nearer 1 than fixed (mean |log z_rms|), per capacity: {near}"]
    return "\n".join(lines)


def read_matern(rows: list[dict[str, Any]]) -> str:
    """Addendum 5's reading (``matern.md``): the Matérn arms beside their references, and each
    minus its references paired by seed."""
    lines = arm_tables(rows, MATERN_READ)
    lines += [
        "",
        "## Matérn − the same critic with its published kernel, paired by seed",
        "",
        "| arm | reference | max BV | log z_rms | 95 % coverage | RMSE |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for arm, references in MATERN_PAIRS.items():
        for reference, m in ((r, m) for r in references for m in CAPACITIES):
            pair = [
                np.log(values(rows, arm, m, "all", "z_rms"))
                - np.log(values(rows, reference, m, "all", "z_rms")),
                *(
                    values(rows, arm, m, "all", k) - values(rows, reference, m, "all", k)
                    for k in ("coverage_0.95", "rmse")
                ),
            ]
            cells = " | ".join(interval(d, 3) for d in pair)
            lines.append(f"| {arm} | {reference} | {m} | {cells} |")
    between = {
        m: sorted(
            np.log(values(rows, a, m, "all", "z_rms")).mean()
            for a in ("laplacian, adaptive", "matern52, adaptive", "rbf, adaptive")
        )[1]
        == np.log(values(rows, "matern52, adaptive", m, "all", "z_rms")).mean()
        for m in CAPACITIES
    }
    lines += ["", f"matern52 z_rms between laplacian's and rbf's, per capacity: {between}"]
    return "\n".join(lines)


def arm_tables(rows: list[dict[str, Any]], arms: list[str]) -> list[str]:
    """The calibration table of ``arms`` over all cells, then over visited cells and the rest."""
    lines = [
        "## Calibration on the fixed-policy pendulum, all 3,600 cells",
        "",
        "Mean over stream seeds 0-4 [95 % Student-t interval]. Coverage: share of cells whose",
        "Monte Carlo value lies in the GP's central interval at that nominal level.",
        "",
        "| arm | max BV | " + " | ".join(METRICS.values()) + " |",
        "|---|---:|" + "---:|" * len(METRICS),
    ]
    for arm in arms:
        for m in CAPACITIES:
            cells = [interval(values(rows, arm, m, "all", k)) for k in METRICS]
            lines.append(f"| {arm} | {m} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "## Visited cells and the rest (95 % coverage; z_rms)",
        "",
        "| arm | max BV | visited cells | 95 %, visited | 95 %, rest | z_rms, visited | "
        "z_rms, rest |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for arm in arms:
        for m in CAPACITIES:
            n = values(rows, arm, m, "visited", "cells")
            cells = [
                interval(values(rows, arm, m, region, k))
                for k in ("coverage_0.95", "z_rms")
                for region in ("visited", "unvisited")
            ]
            lines.append(f"| {arm} | {m} | {np.mean(n):.0f} | " + " | ".join(cells) + " |")
    return lines


def plot(rows: list[dict[str, Any]], path: Path, arms: list[str]) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    levels = np.array(LEVELS)
    for i, arm in enumerate(arms):
        colour = f"C{i}"
        for ax, metric in zip(axes[:2], ("z_rms", "coverage_0.95"), strict=True):
            mean, half = mean_ci(
                np.stack([values(rows, arm, m, "all", metric) for m in CAPACITIES]),
                nan_policy="omit",
            )
            ax.errorbar(CAPACITIES, mean, half, marker="o", capsize=3, color=colour, label=arm)
        curve = np.stack([values(rows, arm, 100, "all", f"coverage_{p}") for p in LEVELS]).mean(
            axis=1
        )
        axes[2].plot(levels, curve, marker=".", color=colour, label=arm)
    axes[0].axhline(1, color="k", ls=":", lw=1)
    axes[0].set(
        xscale="log", yscale="log", xlabel="max basis vectors", ylabel="z_rms (1 = calibrated)"
    )
    axes[1].axhline(0.95, color="k", ls=":", lw=1)
    axes[1].set(xscale="log", xlabel="max basis vectors", ylabel="coverage of the 95 % interval")
    axes[2].plot([0, 1], [0, 1], color="k", ls=":", lw=1)
    axes[2].set(
        xlabel="nominal coverage",
        ylabel="observed coverage",
        title="100 basis vectors, mean of 5 seeds",
        xlim=(0, 1),
        ylim=(0, 1),
    )
    for ax in axes[:2]:
        ax.set_xticks(CAPACITIES, [str(m) for m in CAPACITIES])
        ax.minorticks_off()
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[2].legend(fontsize=8, loc="upper left")
    fig.suptitle(
        "Fixed-policy pendulum: the GP's predictive intervals against the Monte Carlo value "
        "(3,600 cells; error bars: 95 % interval over 5 seeds)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--read", action="store_true", help="print the tables of runs.json")
    parser.add_argument("--plot", type=Path, default=None, help="with --read: the figure")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--matern", action="store_true", help="addendum 5's Matérn arms")
    args = parser.parse_args(argv)
    if not args.read:
        if args.matern:
            run(args.workers, [*MATERN_ARMS, *MATERN_DROP_INS], MATERN_RUNS)
        else:
            run(args.workers, [*ARMS, *DROP_INS], RUNS)
        return
    rows = json.loads(RUNS.read_text())["rows"]
    arms = [*ARMS, *DROP_INS]
    if args.matern:
        rows += json.loads(MATERN_RUNS.read_text())["rows"]
        arms = MATERN_READ
    print(read_matern(rows) if args.matern else read(rows))
    if args.plot is not None:
        plot(rows, args.plot, arms)


if __name__ == "__main__":
    main()
