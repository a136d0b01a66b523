"""WallMaze: gymnasium compliance, walls never crossed, value discontinuous across walls."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from sb3_geogp.envs.wall_maze import (
    DOOR_LAYOUT,
    MAX_EPISODE_STEPS,
    WALL_MAZE_CORNER_ID,
    WALL_MAZE_DISCRETE_ID,
    WALL_MAZE_DOOR_ID,
    WALL_MAZE_ID,
    MazeLayout,
    WallMaze,
    WallMazeDiscrete,
    distance_to_walls,
    distances_to_walls,
    register_wall_maze,
)

register_wall_maze()


def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


def crosses(a: np.ndarray, b: np.ndarray, wall: np.ndarray) -> bool:
    """Independent check: the move ``a -> b`` passes from one side of ``wall`` to the other.

    True when ``a`` and ``b`` lie strictly on opposite sides of the wall's line and the
    crossing point lies on the (closed) wall segment, or when ``b`` lands on the wall.
    """
    x0, y0, x1, y1 = (float(v) for v in wall)
    oa = _orient(x0, y0, x1, y1, a[0], a[1])
    ob = _orient(x0, y0, x1, y1, b[0], b[1])
    w0 = _orient(a[0], a[1], b[0], b[1], x0, y0)
    w1 = _orient(a[0], a[1], b[0], b[1], x1, y1)
    on_wall_line = ob == 0.0 and min(x0, x1) <= b[0] <= max(x0, x1)
    on_wall_line = on_wall_line and min(y0, y1) <= b[1] <= max(y0, y1)
    return bool((oa * ob < 0 and w0 * w1 <= 0) or on_wall_line)


def point_segment_distance(p: np.ndarray, wall: np.ndarray) -> float:
    """Independent distance from point ``p`` to the closed segment ``wall``."""
    a, b = np.asarray(wall[:2], float), np.asarray(wall[2:], float)
    ab = b - a
    t = min(1.0, max(0.0, float((p - a) @ ab) / float(ab @ ab)))
    return float(np.linalg.norm(p - (a + t * ab)))


@pytest.mark.parametrize("cls", [WallMaze, WallMazeDiscrete])
def test_check_env(cls: type[WallMaze]) -> None:
    check_env(cls())
    check_env(cls(render_mode="rgb_array"))


def test_render() -> None:
    env = WallMaze(render_mode="rgb_array")
    env.reset(options={"start": (0.9, 0.1)})
    img = env.render()
    assert img is not None and img.shape == (128, 128, 3) and img.dtype == np.uint8
    assert (img == 0).all(axis=-1).sum() > 128  # walls drawn
    assert (img[..., 0] == 220).sum() > 0  # agent drawn


@pytest.mark.parametrize(
    "env_id", [WALL_MAZE_ID, WALL_MAZE_DISCRETE_ID, WALL_MAZE_CORNER_ID, WALL_MAZE_DOOR_ID]
)
def test_registered(env_id: str) -> None:
    env = gym.make(env_id)
    check_env(env.unwrapped)
    assert env.spec is not None and env.spec.max_episode_steps == MAX_EPISODE_STEPS
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)


@pytest.mark.parametrize("slide", [False, True])
@pytest.mark.parametrize("cls", [WallMaze, WallMazeDiscrete])
def test_random_actions_never_cross_a_wall(cls: type[WallMaze], slide: bool) -> None:
    env = cls(MazeLayout(slide=slide))
    walls = env.layout.segments()
    rng = np.random.default_rng(0)
    env.action_space.seed(0)
    n_collisions = 0
    for episode in range(60):
        env.reset(seed=episode)
        for step in range(150):
            if cls is WallMaze and step % 3 == 1:
                # Large, out-of-box actions: many moves at full speed, many collisions.
                action = rng.normal(0.0, 3.0, size=2).astype(np.float32)
            elif cls is WallMaze and step % 3 == 2:
                # Aim at a wall's free end: grazing and collinear moves along walls.
                corner = walls[rng.integers(2), 2 * rng.integers(2) :][:2]
                action = ((corner - env.position) * rng.uniform(5, 50)).astype(np.float32)
            else:
                action = env.action_space.sample()
            before = env.position.copy()
            _, _, terminated, _, info = env.step(action)
            after = env.position
            assert np.array_equal(info["previous_position"], before)
            step_len = float(np.hypot(*(after - before)))
            assert step_len <= env.layout.max_step * (1 + 1e-12)
            for wall in walls:
                assert not crosses(before, after, wall), (before, after, wall)
                assert point_segment_distance(after, wall) >= env.layout.margin * (1 - 1e-9)
            assert np.all(after > 0) and np.all(after < env.layout.size)
            n_collisions += step_len < env.layout.max_step * (1 - 1e-9)
            if terminated:
                break
    assert n_collisions > 100  # the property was exercised against walls


@pytest.mark.parametrize("layout", [MazeLayout(), DOOR_LAYOUT], ids=["stop", "slide"])
def test_a_batch_of_moves_is_each_move_alone(layout: MazeLayout) -> None:
    """``moves`` (what Monte Carlo value estimates step thousands of agents with) gives every
    agent the end point its own ``move`` gives, bit for bit, and crosses no wall."""
    rng = np.random.default_rng(3)
    walls = layout.segments()
    pos = rng.uniform(0.0, 1.0, size=(3000, 2))
    pos = pos[[min(point_segment_distance(p, w) for w in walls) >= layout.margin for p in pos]]
    delta = rng.normal(0.0, 0.1, size=pos.shape)
    delta[::7] = 0.0  # standing still
    delta[1::5, 1] = 0.0  # parallel to the horizontal walls
    pushed = layout.moves(pos, 10 * delta)  # pressed against walls
    start = np.concatenate([pos, pushed])
    step = np.concatenate([delta, delta])
    batch = layout.moves(start, step)
    alone = np.array([layout.move(p, d) for p, d in zip(start, step, strict=True)])
    assert np.array_equal(batch, alone)
    stopped = np.hypot(*(batch - start - step).T) > 1e-9
    assert stopped.sum() > 300  # walls were met
    for a, b in zip(start, batch, strict=True):
        assert not any(crosses(a, b, w) for w in walls)
    distances = np.array([min(point_segment_distance(p, w) for w in walls) for p in batch])
    np.testing.assert_allclose(distances_to_walls(batch, walls), distances, rtol=1e-12)


def test_batches_of_the_wrong_shape_are_refused() -> None:
    layout, env = MazeLayout(), WallMaze()
    with pytest.raises(ValueError, match=r"one shape \(N, 2\)"):
        layout.moves(np.full((3, 2), 0.2), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="for one agent use move"):
        layout.moves(np.array([0.2, 0.2]), np.zeros(2))
    with pytest.raises(ValueError, match="one action per position"):
        env.transitions(np.full((3, 2), 0.2), np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"shape \(N, 2\), got \(2, 3\)"):
        env.displacements(np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"in 0\.\.7"):
        WallMazeDiscrete().transitions(np.full((2, 2), 0.2), np.array([1, 8]))


def test_move_stops_at_the_wall() -> None:
    lay = MazeLayout()
    # Straight up into the upper wall (y = 0.5) from 0.02 below it: stops just short of it.
    end = lay.move(np.array([0.3, 0.48]), np.array([0.0, 0.05]))
    assert end[1] < 0.5
    assert end[1] == pytest.approx(0.5 - 2 * lay.margin, abs=1e-12)
    assert end[0] == 0.3
    # Pushing on from there does not move past it.
    again = lay.move(end, np.array([0.0, 0.05]))
    assert again[1] < 0.5
    # A move that misses the wall (through the gap, x > 0.7) is not stopped.
    free = lay.move(np.array([0.8, 0.48]), np.array([0.0, 0.05]))
    np.testing.assert_allclose(free, [0.8, 0.53])
    # Just inside the wall's free end (x = 0.7) the move is stopped, just outside it is not.
    assert lay.move(np.array([0.699, 0.48]), np.array([0.0, 0.05]))[1] < 0.5
    assert lay.move(np.array([0.701, 0.48]), np.array([0.0, 0.05]))[1] > 0.5


def test_a_sliding_move_goes_on_along_the_wall() -> None:
    lay = MazeLayout(slide=True)
    # Up and right into the upper wall (y = 0.5): the whole x displacement is kept, since the
    # wall is horizontal, and the move stays just below the wall.
    end = lay.move(np.array([0.3, 0.48]), np.array([0.03, 0.04]))
    assert end[0] == pytest.approx(0.33, abs=1e-12)
    assert 0.5 - 2 * lay.margin <= end[1] < 0.5
    # Without sliding the same move stops at the contact point, 3/4 of the way in x.
    stopped = MazeLayout().move(np.array([0.3, 0.48]), np.array([0.03, 0.04]))
    assert stopped[0] == pytest.approx(0.315, abs=2e-6)
    # Into the top-left corner: slides left along the top side, then the left side stops it.
    end = lay.move(np.array([0.03, 0.98]), np.array([-0.08, 0.06]))
    assert lay.margin <= end[0] < 3 * lay.margin and 1 - 3 * lay.margin < end[1] < 1
    # Straight into a wall (no component along it): no slide.
    np.testing.assert_allclose(
        lay.move(np.array([0.3, 0.48]), np.array([0.0, 0.05])),
        MazeLayout().move(np.array([0.3, 0.48]), np.array([0.0, 0.05])),
    )


@pytest.mark.parametrize("start", [(0.6, 0.9), (0.05, 0.6)])
def test_pushing_into_a_side_reaches_the_corner_goal_only_when_moves_slide(
    start: tuple[float, float],
) -> None:
    """A constant push up and left, from the top or the left side of the top corridor, ends in
    WallMazeCorner's goal; in the published layout it stays stuck on the side."""
    corner = gym.make(WALL_MAZE_CORNER_ID).unwrapped
    assert isinstance(corner, WallMaze) and corner.layout.slide
    published = WallMaze()
    for env, reaches in ((corner, True), (published, False)):
        env.reset(options={"start": start})
        terminated = False
        for _ in range(MAX_EPISODE_STEPS):
            _, _, terminated, _, _ = env.step(np.array([-1.0, 1.0], dtype=np.float32))
            if terminated:
                break
        assert terminated == reaches


def test_starts_keep_the_start_clearance() -> None:
    for clearance in (None, 0.03):
        env = WallMaze(MazeLayout(max_step=0.1, start_clearance=clearance))
        expected = 0.2 if clearance is None else clearance
        assert env.layout.clearance == expected
        env.reset(seed=0)
        starts = np.array([env.reset()[1]["position"] for _ in range(300)])
        gaps = [distance_to_walls(p, env.layout.segments()) for p in starts]
        assert min(gaps) >= expected
        # The bound is attained, not merely respected: some start lies near it.
        assert min(gaps) < expected + 0.02


def test_grazing_and_collinear_moves_keep_clear_of_the_wall() -> None:
    lay = MazeLayout()
    # In the gap, exactly on the upper wall's line, moving along it into the wall: stops
    # before the wall's free end (x = 0.7), clear of it.
    end = lay.move(np.array([0.72, 0.5]), np.array([-0.05, 0.0]))
    assert end[0] > 0.7 and np.hypot(end[0] - 0.7, end[1] - 0.5) >= lay.margin
    # A grazing approach (angle 1e-9) towards the wall from just below it: stays below.
    start = np.array([0.3, 0.5 - 2e-6])
    end = lay.move(start, 0.05 * np.array([np.cos(1e-9), np.sin(1e-9)]))
    assert end[1] < 0.5 and 0.5 - end[1] >= lay.margin * (1 - 1e-9)
    # Straight at the free end point: stopped short of it.
    end = lay.move(np.array([0.68, 0.48]), np.array([0.04, 0.04]) / np.sqrt(2) * 1.25)
    assert np.hypot(end[0] - 0.7, end[1] - 0.5) >= lay.margin * (1 - 1e-9)
    assert not crosses(np.array([0.68, 0.48]), end, np.array(lay.walls[0]))


def test_moves_aimed_exactly_at_a_wall_tip_stop_before_it() -> None:
    """In exact arithmetic a move through a wall's free end meets the (closed) wall there, so
    it stops before the tip. In float64 the crossing lands a few ulps either side of the tip;
    2,000 moves from random free starts, each through a tip at its midpoint, must all stop."""
    lay = MazeLayout()
    rng = np.random.default_rng(5)
    tips = np.array([(0.7, 0.5), (0.3, 0.25)])  # the default layout's two free wall ends
    starts = rng.uniform(0.0, lay.size, (4000, 2))
    starts = starts[distances_to_walls(starts, lay.segments()) >= 0.01][:2000]
    tip = tips[rng.integers(len(tips), size=len(starts))]
    end = lay.moves(starts, 2 * (tip - starts))
    moved, to_tip = (np.hypot(*(p - starts).T) for p in (end, tip))
    assert len(starts) == 2000 and np.all(moved < to_tip)


def test_start_on_a_wall_is_rejected() -> None:
    with pytest.raises(ValueError, match="on a wall"):
        WallMaze().reset(options={"start": (0.3, 0.5)})


def test_continuous_speed_bound_and_discrete_directions() -> None:
    env = WallMaze()
    env.reset(options={"start": (0.5, 0.375)})
    env.step(np.array([1.0, 1.0], dtype=np.float32))
    assert np.hypot(*(env.position - [0.5, 0.375])) == pytest.approx(env.layout.max_step)
    denv = WallMazeDiscrete()
    denv.reset(options={"start": (0.5, 0.375)})
    denv.step(np.int64(2))  # +y
    np.testing.assert_allclose(denv.position, [0.5, 0.425], atol=1e-12)


def test_goal_terminates() -> None:
    env = WallMaze()
    gx, gy = env.layout.goal
    env.reset(options={"start": (gx + 0.14, gy)})
    _, reward, terminated, truncated, _ = env.step(np.array([-1.0, 0.0], dtype=np.float32))
    assert (reward, terminated, truncated) == (-1.0, False, False)
    _, _, terminated, _, _ = env.step(np.array([-1.0, 0.0], dtype=np.float32))
    assert terminated


def test_optimal_value_jumps_across_walls() -> None:
    lay = MazeLayout()
    above, below = lay.optimal_steps(np.array([[0.3, 0.51], [0.3, 0.49]]))
    assert below - above >= 10  # 0.02 apart in the plane, a corridor apart along the path
    above, below = lay.optimal_steps(np.array([[0.6, 0.26], [0.6, 0.24]]))
    assert below - above >= 5
    # Continuous within a room: nearby points differ by at most one step or so.
    a, b = lay.optimal_steps(np.array([[0.3, 0.40], [0.3, 0.42]]))
    assert abs(a - b) <= 1


@pytest.mark.parametrize("start", [(0.1, 0.3), (0.9, 0.1), (0.45, 0.2)])
def test_door_layout_pushing_towards_the_goal_slides_through_the_door(
    start: tuple[float, float],
) -> None:
    """In WallMazeDoor a constant push straight at the goal from below the wall slides along
    the wall into the door and ends in the goal (no dead end), within a few steps of the
    shortest path's length."""
    env = gym.make(WALL_MAZE_DOOR_ID).unwrapped
    assert isinstance(env, WallMaze) and env.layout.slide
    env.reset(options={"start": start})
    goal = np.asarray(env.layout.goal)
    steps, terminated = 0, False
    while not terminated and steps < MAX_EPISODE_STEPS:
        direction = goal - env.position
        action = (direction / np.linalg.norm(direction)).astype(np.float32)
        _, _, terminated, _, _ = env.step(action)
        steps += 1
    assert terminated
    assert steps <= int(env.layout.optimal_steps(np.asarray(start))) + 10


def test_door_layout_value_jumps_across_the_wall() -> None:
    """Just below the wall, away from the door, the goal is a detour through the door away;
    just above it, a straight line: the optimal return jumps by the detour."""
    layout = gym.make(WALL_MAZE_DOOR_ID).unwrapped.layout
    below, above = layout.optimal_steps(np.array([[0.05, 0.48], [0.05, 0.52]]))
    # Below: to the door's left post (0.4, 0.5), then to the goal's centre; above: straight.
    detour = np.hypot(0.35, 0.02) + np.hypot(0.1, 0.35) - np.hypot(0.45, 0.33)
    assert abs((below - above) - detour / layout.max_step) <= 1
    assert below - above >= 3


@pytest.mark.parametrize("layout", [MazeLayout(), DOOR_LAYOUT])
def test_crosses_wall_is_the_move_test_on_every_pair(layout: MazeLayout) -> None:
    """Batched over pairs, against the independent orientation test, wall by wall."""
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0, layout.size, (60, 2)), rng.uniform(0, layout.size, (50, 2))
    got = layout.crosses_wall(a[:, None], b[None])
    walls = np.asarray(layout.walls, dtype=np.float64)
    expected = np.array([[any(crosses(p, q, w) for w in walls) for q in b] for p in a])
    assert got.shape == (60, 50) and got.any() and not got.all()
    np.testing.assert_array_equal(got, expected)
