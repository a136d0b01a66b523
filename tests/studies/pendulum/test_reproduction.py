"""The pendulum reproduction: helpers, controls, and the --quick command end to end."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from sb3_geogp import GeodesicKernel, LaplacianKernel, SparseOnlineGP
from sb3_geogp.studies.pendulum.reproduction import (
    GPSettings,
    ReproductionConfig,
    compute_ground_truth,
    fit_gp,
    jump_cells,
    normalised_variance,
    run_reproduction,
)
from sb3_geogp.studies.pendulum.task import Task, policy_episodes
from sb3_geogp.toolbox.shepard import shepard_mean
from tests.test_examples_engine import load_script


def test_euclidean_laplacian_kernel_is_exp_minus_r() -> None:
    k = LaplacianKernel(lengthscale=2.0, variance=3.0)
    r = torch.tensor([0.0, 1.0, 2.5], dtype=torch.float64)
    np.testing.assert_allclose(k(r).numpy(), 3.0 * np.exp(-r.numpy()))


def test_shepard_mean_is_the_geodesic_interpolation_rule() -> None:
    # For an interpolating geodesic GP, shepard_mean of its BV means equals its own mean.
    data = policy_episodes(Task(), n_episodes=4, seed=0, stride=3)
    gp = SparseOnlineGP(2, kernel=GeodesicKernel([0.3, 1.0]), max_basis=25, novelty_tol=0.01)
    gp.update(data.states, data.returns, episode_starts=data.episode_starts)
    x = Task().grid(10)[0]
    np.testing.assert_allclose(
        shepard_mean(gp, x), gp.predict(x, return_var=False)[0].numpy(), atol=1e-8
    )


def test_fit_gp_respects_capacity_and_normalised_variance_is_in_unit_interval() -> None:
    data = policy_episodes(Task(), n_episodes=4, seed=1, stride=4)
    gp = fit_gp("geodesic", data, 15, GPSettings(episodes_per_batch=2))
    assert gp.n_basis == 15
    _, var = gp.predict(Task().grid(8)[0])
    assert var is not None
    nvar = normalised_variance(gp, var.numpy())
    assert np.all(nvar >= 0) and np.all(nvar <= 1 + 1e-9)


def test_jump_cells_finds_a_step() -> None:
    n = 10
    v = np.zeros((n, n))
    v[:, 5:] = 10.0  # a vertical step between theta columns 4 and 5 (and 9 -> 0, periodic)
    mask = jump_cells(v.ravel(), n, fraction=0.4).reshape(n, n)
    assert mask[:, [0, 4, 5, 9]].all() and mask.sum() == 40


def test_quick_run_writes_every_promised_file(tmp_path: Path) -> None:
    example = load_script("reproduce_paper")
    example.main(["--quick", "--out", str(tmp_path)])
    for name in (*example.FIGURES, *example.TABLES):
        assert (tmp_path / name).stat().st_size > 0, name
    record = json.loads((tmp_path / "results.json").read_text())
    with (tmp_path / "results.csv").open() as fh:
        models = {(r["model"], r["setting"]) for r in csv.DictReader(fh)}
    for model in ("rbf", "euclid_laplacian", "euclid_lap_shepard", "geodesic"):
        for setting in ("fixed", "ml", "val"):
            assert (model, setting) in models
    assert ("mlp", "fixed") in models
    assert record["task"]["params"]["max_torque"] == 5.0
    assert {r["model"] for r in record["summary"]} >= {"geodesic", "mlp"}
    assert "| geodesic | fixed |" in (tmp_path / "results.md").read_text()
    with np.load(tmp_path / "ground_truth.npz") as gt:
        assert gt["mc_value"].shape == gt["td_value"].shape


def test_worker_processes_give_the_rows_of_one_process() -> None:
    """Two spawned workers (which Ctrl-C stops at once) compute what one process does."""
    config = replace(ReproductionConfig.quick(), max_basis=(10,), seeds=(0, 1))
    task = Task()
    truth = compute_ground_truth(task, config)

    def rows(workers: int) -> list[str]:
        result = run_reproduction(replace(config, workers=workers), task, truth)
        timeless = [{k: v for k, v in r.items() if k != "seconds"} for r in result.rows]
        return sorted(json.dumps(r, sort_keys=True) for r in timeless)

    serial = rows(1)
    assert len(serial) == 30 and rows(2) == serial


@pytest.mark.parametrize("bad", [0])
def test_policy_episodes_rejects_bad_stride(bad: int) -> None:
    with pytest.raises(ValueError, match="stride"):
        policy_episodes(Task(), 1, 0, stride=bad)
