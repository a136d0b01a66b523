"""The wall study's comparison: a quick run, and the findings of the full run on a subset."""

from __future__ import annotations

import numpy as np
import pytest

from sb3_geogp.studies.wall.comparison import (
    WalkSettings,
    paired_table,
    run_comparison,
    summary_table,
)


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


@pytest.fixture(scope="module")
def findings() -> np.ndarray:
    """A subset of the full run of examples/wall_experiment.py (same settings and grid)."""
    models = ("rbf", "euclid_laplacian", "geo_default", "geo_lap_nearest")
    result = run_comparison(max_basis=(20, 80), seeds=(0, 1, 2), models=models, grid_nx=160)
    return {m: result.array(m, "mse") for m in models}


def test_geodesic_distance_beats_euclidean_with_the_same_profile(findings: dict) -> None:
    # Full run: every seed at max_basis 10-40 (per-seed ratio <= 0.94), 9/10 at 80, 5/10 at 160.
    assert np.all(findings["geo_default"] < findings["euclid_laplacian"])


def test_interpolating_attachment_beats_nearest_attachment(findings: dict) -> None:
    # Full run: every seed and capacity (per-seed ratio <= 0.35).
    assert np.all(findings["geo_default"] < 0.6 * findings["geo_lap_nearest"])


def test_geodesic_stays_within_a_small_factor_of_rbf(findings: dict) -> None:
    # Full run: per-seed ratio geodesic / RBF between 0.18 and 2.89 -- better only at 10 BVs.
    assert np.all(findings["geo_default"] < 4 * findings["rbf"])
