"""The wall study's comparison: a quick run, and the findings of the full run on a subset."""

from __future__ import annotations

import math
import statistics

import numpy as np
import pytest
from scipy import stats as sps

from sb3_geogp.studies.wall.comparison import (
    METRICS,
    ComparisonResult,
    WalkSettings,
    paired_table,
    run_comparison,
    summary_table,
)
from sb3_geogp.toolbox.tables import NO_INTERVAL

NOTE = f'With fewer than 5 seeds the MSE cells give the mean alone ("{NO_INTERVAL}").'


def test_quick_comparison_gives_finite_errors() -> None:
    result = run_comparison(
        max_basis=(5, 15), seeds=(0,), walks=WalkSettings(n_episodes=15), grid_nx=40
    )
    for model in result.values:
        for metric in ("mse", "mse_wall"):
            values = result.array(model, metric)
            assert values.shape == (2, 1)
            assert np.all(np.isfinite(values)) and np.all(values > 0)
    assert "geo_default" in summary_table(result)
    assert "euclid_lap_shepard" in paired_table(result)


def _result(mse: list[float], mse_wall: list[float]) -> ComparisonResult:
    """One model (``rbf``) at one capacity (10), one value per seed."""
    result = ComparisonResult([10], list(range(len(mse))))
    result.values = {"rbf": {k: [[0.5] * len(mse)] for k in METRICS}}
    result.values["rbf"]["mse"] = [mse]
    result.values["rbf"]["mse_wall"] = [mse_wall]
    return result


def _row(table: str) -> list[str]:
    line = next(line for line in table.splitlines() if line.startswith("| rbf |"))
    return [cell.strip() for cell in line.strip("|").split("|")]


def test_summary_table_gives_the_mean_alone_from_two_seeds() -> None:
    table = summary_table(_result([0.011, 0.017], [0.05, 0.07]))
    assert _row(table)[2:4] == [f"0.0140 ({NO_INTERVAL})", f"0.0600 ({NO_INTERVAL})"]
    assert "±" not in table
    assert table.count(NOTE) == 1 and table.endswith(NOTE)


def test_summary_table_gives_the_t_interval_from_five_seeds() -> None:
    mse, mse_wall = [0.011, 0.017, 0.013, 0.021, 0.0155], [0.05, 0.07, 0.062, 0.048, 0.081]
    table = summary_table(_result(mse, mse_wall))
    cells = []
    for x in (mse, mse_wall):  # mean and 95 % Student-t half-width, computed independently
        half = sps.t.ppf(0.975, len(x) - 1) * statistics.stdev(x) / math.sqrt(len(x))
        cells.append(f"{statistics.fmean(x):.4f} ± {half:.4f}")
    assert _row(table)[2:4] == cells
    assert NO_INTERVAL not in table and "fewer than" not in table


@pytest.fixture(scope="module")
def findings() -> dict[str, dict[str, np.ndarray]]:
    """A subset of the full run of examples/wall_experiment.py (same settings and grid)."""
    models = ("rbf", "euclid_laplacian", "geo_default", "geo_lap_nearest", "geo_wall_aware")
    result = run_comparison(max_basis=(20, 80), seeds=(0, 1, 2), models=models, grid_nx=160)
    return {m: {k: result.array(m, k) for k in ("mse", "mse_wall")} for m in models}


def test_geodesic_distance_beats_euclidean_with_the_same_profile(findings: dict) -> None:
    # Full run: every seed at max_basis 10-40 (per-seed ratio <= 0.94), 9/10 at 80, 5/10 at 160.
    assert np.all(findings["geo_default"]["mse"] < findings["euclid_laplacian"]["mse"])


def test_interpolating_attachment_beats_nearest_attachment(findings: dict) -> None:
    # Full run: every seed and capacity (per-seed ratio <= 0.32).
    assert np.all(findings["geo_default"]["mse"] < 0.6 * findings["geo_lap_nearest"]["mse"])


def test_geodesic_stays_within_a_small_factor_of_rbf(findings: dict) -> None:
    # Full run: per-seed ratio geodesic / RBF between 0.19 and 2.80 -- better only at 10 BVs.
    assert np.all(findings["geo_default"]["mse"] < 4 * findings["rbf"]["mse"])


def test_attachments_that_respect_the_wall_remove_the_near_wall_error(findings: dict) -> None:
    # Full run: near-wall ratio oracle / geo_default <= 0.46 in every seed at 20-160 BVs (0.05-0.14
    # geometric mean), oracle / RBF <= 0.50 there.
    oracle = findings["geo_wall_aware"]["mse_wall"]
    assert np.all(oracle < 0.5 * findings["geo_default"]["mse_wall"])
    assert np.all(oracle < 0.6 * findings["rbf"]["mse_wall"])
