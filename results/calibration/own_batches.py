"""What the GP's own next batches say of its error bars (``PLAN.md``, addendum 3)::

    python results/calibration/own_batches.py > results/calibration/own_batches.md

Each case feeds one GP of ``calibration.py``'s arms the fixed-policy stream, scoring every
batch after the first before it is absorbed (predictive mean, latent variance and noise at its
states, against its targets), then scores the value's intervals on the grid as they are and
scaled by the latent scale the last 10 batches imply, over all cells and weighted by the
stream's states per cell.
"""

from __future__ import annotations

import concurrent.futures as cf
from pathlib import Path
from typing import Any

import numpy as np
import torch
from scipy import stats
from tqdm import tqdm

from sb3_geogp.studies.pendulum.batch_check import stream
from sb3_geogp.studies.pendulum.ground_truth import GridValue, mc_value
from sb3_geogp.studies.pendulum.task import Task
from sb3_geogp.toolbox.pools import worker_pool
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.streams import episode_batches
from sb3_geogp.toolbox.tables import markdown_table

CALIBRATION = load_script(Path(__file__).with_name("calibration.py"), "calibration")
CAPACITY = 100
#: Batches at the stream's end that the scale is read from.
TAIL = 10
Z95 = float(stats.norm.ppf(0.975))


def own_scores(residuals: np.ndarray, latent: np.ndarray, noise: np.ndarray) -> dict[str, float]:
    """Targets' ``z_rms`` and the latent scale ``c`` of pooled out-of-sample residuals, latent
    variances and noise variances, each shape (n,)."""
    scale = (np.sum(residuals**2) - np.sum(noise)) / np.sum(latent)
    return {
        "targets_z_rms": float(np.sqrt(np.mean(residuals**2 / (latent + noise)))),
        "scale": float(max(scale, 1e-3)),
    }


def value_scores(
    mu: np.ndarray, var: np.ndarray, truth: GridValue, weights: np.ndarray
) -> dict[str, float]:
    """95 % coverage and ``z_rms`` of the grid's value, cells weighted by ``weights``."""
    z = (truth.value - mu) / np.sqrt(var + truth.stderr**2)
    return {
        "coverage_95": float(np.average(np.abs(z) <= Z95, weights=weights)),
        "z_rms": float(np.sqrt(np.average(z**2, weights=weights))),
    }


def run_case(arm: str, seed: int, truth: GridValue) -> dict[str, Any]:
    torch.set_num_threads(1)
    task, config = Task(), CALIBRATION.check_config()
    data = stream(task, config, seed)
    gp = CALIBRATION.new_critic(arm, task, CAPACITY, config)
    batches: list[tuple[np.ndarray, ...]] = []
    for rows in episode_batches(data.episode_starts, config.episodes_per_batch):
        x, y = data.states[rows], data.returns[rows]
        if gp.n_basis > 0:
            mean, var = gp.predict(x)
            assert var is not None
            noise = float(gp.noise_var) * float(gp.y_scale) ** 2
            residual = y - mean.double().numpy()
            batches.append((residual, var.double().numpy(), np.full(len(y), noise)))
        gp.update(x, y, episode_starts=data.episode_starts[rows])
    whole = own_scores(*(np.concatenate(a) for a in zip(*batches, strict=True)))
    tail = own_scores(*(np.concatenate(a) for a in zip(*batches[-TAIL:], strict=True)))
    states, _, _ = task.grid(truth.n)
    mean, var = gp.predict(states)
    assert var is not None
    mu, v = mean.double().numpy(), var.double().numpy()
    counts = CALIBRATION.cell_counts(task, data.states, truth.n).astype(np.float64)
    uniform = np.ones_like(counts)
    grid = {
        f"{name}_{weighting}": value_scores(mu, latent, truth, w)
        for name, latent in (("raw", v), ("scaled", tail["scale"] * v))
        for weighting, w in (("grid", uniform), ("stream", counts))
    }
    return {"arm": arm, "seed": seed, "whole": whole, "tail": tail, **grid}


def interval(x: list[float]) -> str:
    return CALIBRATION.interval(np.array(x, dtype=np.float64), 2)


def read(rows: list[dict[str, Any]]) -> str:
    arms = [*CALIBRATION.ARMS, *CALIBRATION.DROP_INS]
    columns = {
        "targets' z_rms, whole stream": ("whole", "targets_z_rms"),
        f"targets' z_rms, last {TAIL}": ("tail", "targets_z_rms"),
        f"scale c, last {TAIL}": ("tail", "scale"),
        "95 %, grid": ("raw_grid", "coverage_95"),
        "95 %, grid, scaled": ("scaled_grid", "coverage_95"),
        "95 %, stream's states": ("raw_stream", "coverage_95"),
        "95 %, stream's states, scaled": ("scaled_stream", "coverage_95"),
        "z_rms, grid": ("raw_grid", "z_rms"),
        "z_rms, stream's states": ("raw_stream", "z_rms"),
    }
    table = [
        [arm]
        + [
            interval([r[part][metric] for r in rows if r["arm"] == arm])
            for part, metric in columns.values()
        ]
        for arm in arms
    ]
    return "\n".join(
        [
            f"## The GP's own next batches, {CAPACITY} basis vectors (PLAN.md, addendum 3)",
            "",
            "Mean over stream seeds 0-4 [95 % Student-t interval]. Targets' `z_rms`: of each",
            "batch's targets under the GP's predictive distribution before it absorbs them",
            "(latent variance plus noise; 1 = calibrated). Scale `c`: the factor on the latent",
            "variance that the targets' squared errors imply. Coverage: share of the grid's cells",
            "whose Monte Carlo value lies in the 95 % interval, uniform over the grid or weighted",
            "by the stream's states per cell; scaled: with `c` times the latent variance.",
            "",
            markdown_table(["arm", *columns], table),
        ]
    )


def main() -> None:
    task, config = Task(), CALIBRATION.check_config()
    truth = mc_value(task, config.grid_n, config.mc_rollouts)
    cases = [(arm, seed) for arm in [*CALIBRATION.ARMS, *CALIBRATION.DROP_INS] for seed in range(5)]
    rows = []
    with worker_pool(2) as pool:
        futures = [pool.submit(run_case, *case, truth) for case in cases]
        for future in tqdm(cf.as_completed(futures), total=len(futures), unit="case"):
            rows.append(future.result())
    print(read(rows))


if __name__ == "__main__":
    main()
