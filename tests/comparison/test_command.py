"""The ``sb3-geogp compare`` options: sweep settings and GP options checked before any run."""

from __future__ import annotations

import argparse

import pytest

from sb3_geogp.comparison.command import add_arguments, config_from_args
from sb3_geogp.comparison.hyperparams import GP_KWARGS
from sb3_geogp.comparison.specs import SweepConfig


def test_cli_arguments() -> None:
    parser = add_arguments(argparse.ArgumentParser())
    args = parser.parse_args(["--quick", "--seeds", "3", "--timesteps-scale", "0.5"])
    config = config_from_args(args)
    assert config.seeds == (0, 1, 2) and config.timesteps_scale == 0.5
    assert config.n_eval_episodes == SweepConfig.quick().n_eval_episodes
    args = parser.parse_args(["--envs", "CartPole-v1", "--algos", "ppo", "--critics", "mlp"])
    config = config_from_args(args)
    assert config.envs == ("CartPole-v1",) and config.seeds == (0, 1, 2, 3, 4)
    assert len(config.specs()) == 5


def test_gp_options_reach_every_gp_run_and_bad_ones_fail_early() -> None:
    parser = add_arguments(argparse.ArgumentParser())
    args = parser.parse_args(["--algos", "a2c", "--gp-option", "forgetting=0.9"])
    specs = config_from_args(args).specs()
    for spec in specs:
        assert dict(spec.gp_kwargs) == {**GP_KWARGS, "forgetting": 0.9}
    default = SweepConfig(algos=("a2c",)).specs()
    assert [s.run_id for s in specs] == [s.run_id for s in default]
    assert all(dict(s.gp_kwargs) == GP_KWARGS for s in default)
    args = parser.parse_args(["--gp-option", "dtype=float64", "--gp-option", "forgetting=0.99"])
    assert config_from_args(args).gp_options == (("dtype", "float64"), ("forgetting", 0.99))
    for bad, message in (
        ("forgetting=1.5", "forgetting"),  # rejected by SparseOnlineGP
        ("no_such_option=1", "no_such_option"),
        ("kernel=rbf", "--critics"),
        ("dtype=float7", "dtype"),
        ("dtype=float32", "float32"),  # the RBF critic is not safe in float32
        ("device='cpu'", "device"),  # the policy sets it
    ):
        with pytest.raises(SystemExit, match=message):
            config_from_args(parser.parse_args(["--gp-option", bad]))
    with pytest.raises(SystemExit):  # argparse: not KEY=VALUE
        parser.parse_args(["--gp-option", "forgetting"])
