"""Measurements outside training: fixed probe states, the Monte Carlo horizon."""

from __future__ import annotations

import itertools
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import EzPickle

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


class _Walk(gym.Env):
    """A walk on the integers: reset at a seeded start in 0-9, each action steps -1 or +1.
    With ``unseeded`` the start is the count of such resets so far, modulo 10: no seed fixes
    it."""

    resets = itertools.count()

    observation_space = gym.spaces.Box(-100.0, 100.0, (1,))
    action_space = gym.spaces.Discrete(2)

    def __init__(self, unseeded: bool = False) -> None:
        self.unseeded = unseeded
        self.x = 0

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.x = next(self.resets) % 10 if self.unseeded else int(self.np_random.integers(10))
        return np.array([self.x], dtype=np.float32), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.x += 1 if int(action) == 1 else -1
        return np.array([self.x], dtype=np.float32), float(self.x), False, False, {}


class _PickledWalk(_Walk, EzPickle):
    """The walk as gymnasium's MuJoCo and Box2D environments are: ``EzPickle``, whose
    ``deepcopy`` builds a new walk at 0 instead of copying the state."""

    def __init__(self, unseeded: bool = False) -> None:
        _Walk.__init__(self, unseeded)
        EzPickle.__init__(self, unseeded)


for _name, _cls, _unseeded in (
    ("Walk", _Walk, False),
    ("PickledWalk", _PickledWalk, False),
    ("UnseededWalk", _PickledWalk, True),
):
    gym.register(
        f"test_evaluation/{_name}-v0",
        entry_point=_cls,
        max_episode_steps=40,
        kwargs={"unseeded": _unseeded},
    )


@pytest.mark.parametrize(("name", "copies"), [("Walk", True), ("PickledWalk", False)])
def test_probe_rollouts_start_at_the_probe_state(name: str, copies: bool) -> None:
    """Each rollout's environment is at its probe's state, whether a deepcopy holds the state
    (a plain environment) or not (``EzPickle``: then the probe is replayed)."""
    probes = ProbeStates.build(f"test_evaluation/{name}-v0", 5)
    assert probes.copies is copies
    assert len(np.unique(probes.obs)) > 1  # the probes are not all the start
    for k in range(5):
        for _ in range(2):
            env = probes.start(k)
            assert env.step(1)[0][0] == probes.obs[k][0] + 1  # one step up from the probe


def test_probe_states_that_neither_copy_nor_replay_are_refused() -> None:
    """An ``EzPickle`` environment whose start no seed fixes: the probes cannot be measured."""
    with pytest.raises(ValueError, match=r"neither copied \(copy.deepcopy .* nor replayed"):
        ProbeStates.build("test_evaluation/UnseededWalk-v0", 5)
