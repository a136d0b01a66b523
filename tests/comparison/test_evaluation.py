"""Measurements outside training: fixed probe states, the Monte Carlo horizon."""

from __future__ import annotations

import numpy as np

from sb3_geogp.comparison.evaluation import ProbeStates, mc_horizon


def test_probe_states_are_fixed() -> None:
    a = ProbeStates.build("sb3_geogp/WallMaze-v0", 6)
    b = ProbeStates.build("sb3_geogp/WallMaze-v0", 6)
    np.testing.assert_array_equal(a.obs, b.obs)
    assert len(np.unique(a.obs, axis=0)) == 6
    assert a.episode_steps == 200


def test_mc_horizon() -> None:
    assert mc_horizon(0.9, 200) == 44  # 0.9^44 = 0.0097
    assert mc_horizon(0.98, 500) == 228
    assert mc_horizon(0.9999, 999) == 5 * 999  # capped
    assert 0.9**44 < 0.01 < 0.9**43
