"""The comparison's runs: the same zoo hyperparameters and budget for every critic."""

from __future__ import annotations

import pytest

from sb3_geogp.comparison.hyperparams import ENVS, ZOO_HYPERPARAMS, algo_kwargs
from sb3_geogp.comparison.specs import SweepConfig


def test_hyperparams_identical_across_critics_and_from_the_zoo() -> None:
    specs = SweepConfig(seeds=(0,)).specs()
    assert len(specs) == 2 * 3 * len(ENVS)
    n_envs, kwargs, policy_kwargs = algo_kwargs("ppo", "Pendulum-v1")
    assert n_envs == 4 and kwargs["n_steps"] == 1024 and kwargs["gamma"] == 0.9
    assert "normalize" not in kwargs and "n_timesteps" not in kwargs
    _, kwargs, _ = algo_kwargs("ppo", "CartPole-v1")
    assert kwargs["learning_rate"](1.0) == pytest.approx(1e-3)  # lin_0.001
    assert kwargs["learning_rate"](0.5) == pytest.approx(5e-4)
    _, _, policy_kwargs = algo_kwargs("a2c", "MountainCarContinuous-v0")
    assert policy_kwargs == dict(log_std_init=0.0, ortho_init=False)
    assert set(ZOO_HYPERPARAMS["a2c"]) == set(ZOO_HYPERPARAMS["ppo"])
    by_cell: dict[tuple[str, str], set[int]] = {}
    for s in specs:
        by_cell.setdefault((s.algo, s.env_id), set()).add(s.total_timesteps)
    assert all(len(v) == 1 for v in by_cell.values())  # same budget for the three critics
