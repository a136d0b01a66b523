"""The oracle: geodesic attachments that never cross the wall."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import torch

from sb3_geogp.studies.wall.comparison import FitSettings, WalkSettings, fit_gp
from sb3_geogp.studies.wall.oracle import WallAwareGeodesicKernel, blocked_pairs
from sb3_geogp.studies.wall.rooms import TwoRooms, random_states
from sb3_geogp.toolbox.shepard import predict_mean

ROOMS = TwoRooms(door=(0.4, 0.6), goal=(0.2, 0.8))  # two door corners


def _segment_hits_wall(rooms: TwoRooms, a: np.ndarray, b: np.ndarray) -> bool:
    """Independent reference: walk the segment in fine steps and look for a wall crossing."""
    t = np.linspace(0.0, 1.0, 2001)[:, None]
    points = a + t * (b - a)
    side = np.sign(points[:, 0] - rooms.wall_x)
    flips = np.flatnonzero(side[1:] != side[:-1])
    lo, hi = rooms.door
    return any(not lo < points[i, 1] < hi for i in flips)


def test_blocked_pairs_are_the_segments_through_the_wall() -> None:
    rng = np.random.default_rng(0)
    x, b = random_states(ROOMS, 40, rng), random_states(ROOMS, 30, rng)
    got = blocked_pairs(ROOMS, torch.as_tensor(x), torch.as_tensor(b)).numpy()
    expected = np.array([[_segment_hits_wall(ROOMS, p, q) for q in b] for p in x])
    assert got.any() and not got.all()
    np.testing.assert_array_equal(got, expected)


def test_the_kernel_blocks_in_state_units_whatever_the_lengthscale() -> None:
    rng = np.random.default_rng(1)
    x, b = (
        torch.as_tensor(random_states(ROOMS, 25, rng)),
        torch.as_tensor(random_states(ROOMS, 20, rng)),
    )
    kernel = WallAwareGeodesicKernel([0.2, 0.05], ROOMS)
    kernel.bind(2, 8)
    scaled = kernel.blocked(kernel.scale(x), kernel.scale(b))
    assert torch.equal(scaled, blocked_pairs(ROOMS, x, b))


def test_the_oracle_gp_predicts_as_the_oracle_shepard_rule() -> None:
    """The two oracles agree: the wall-aware geodesic GP's own mean is the Shepard interpolation
    of its basis-vector means with the wall blocking (as the unblocked pair agrees,
    tests/toolbox/test_shepard.py)."""
    data = WalkSettings(n_episodes=15).generate(ROOMS, seed=0)
    gp = fit_gp("geo_wall_aware", data, 30, FitSettings(), rooms=ROOMS)
    grid, _ = ROOMS.grid(40)
    own = predict_mean(gp, grid)
    blocked = functools.partial(blocked_pairs, ROOMS)
    np.testing.assert_allclose(predict_mean(gp, grid, "shepard", blocked=blocked), own, atol=1e-8)
    blind = predict_mean(gp, grid, "shepard")
    assert np.abs(blind - own).max() > 0.05  # the wall changes predictions near it


def test_a_policy_with_a_blocking_kernel_saves_and_loads_bit_for_bit(tmp_path: Path) -> None:
    """A subclass of the geodesic kernel (``blocked`` overridden) given to the drop-in survives
    SB3's save/load: the same kernel class, basis and values."""
    from stable_baselines3 import PPO

    import sb3_geogp.envs  # noqa: F401  (registers WallMaze)
    from sb3_geogp import GPActorCriticPolicy, GPValueCallback
    from sb3_geogp.envs.wall_maze import WALL_MAZE_ID, MazeLayout

    kernel = WallAwareGeodesicKernel(None, MazeLayout())
    model = PPO(
        GPActorCriticPolicy, WALL_MAZE_ID, n_steps=64, batch_size=64, seed=0,
        policy_kwargs=dict(gp_kwargs=dict(kernel=kernel)),
    )  # fmt: skip
    model.learn(256, callback=GPValueCallback())
    model.save(tmp_path / "model.zip")
    loaded = PPO.load(tmp_path / "model.zip")
    assert type(loaded.policy.gp.kernel) is WallAwareGeodesicKernel
    assert loaded.policy.gp.n_basis == model.policy.gp.n_basis > 0
    obs = torch.as_tensor(np.random.default_rng(0).uniform(0, 1, (40, 2)), dtype=torch.float32)
    assert torch.equal(loaded.policy.predict_values(obs), model.policy.predict_values(obs))
