"""Two-room domain: exact ground truth and wall-respecting walks."""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np
import pytest
import torch
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from sb3_geogp import LaplacianKernel
from sb3_geogp.studies.wall.rooms import TwoRooms, goal_walks, random_states

ROOMS = [
    TwoRooms(),
    TwoRooms(door=(0.4, 0.6), goal=(0.2, 0.8)),  # door in the middle: two corners
    TwoRooms(width=3.0, wall_x=2.0, door=(0.0, 0.3), goal=(1.5, 0.9)),  # door at the bottom
]


# -- independent references ---------------------------------------------------------------------
def _wall_segments(rooms: TwoRooms) -> list[tuple[np.ndarray, np.ndarray]]:
    lo, hi = rooms.door
    spans = [(0.0, lo), (hi, rooms.height)]
    return [(np.array([rooms.wall_x, a]), np.array([rooms.wall_x, b])) for a, b in spans if b > a]


def _properly_intersect(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Generic orientation test: do segments pq and ab cross (touching counts)."""

    def orient(u: np.ndarray, v: np.ndarray, w: np.ndarray) -> float:
        return float((v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0]))

    d1, d2 = orient(a, b, p), orient(a, b, q)
    d3, d4 = orient(p, q, a), orient(p, q, b)
    return d1 * d2 <= 0 and d3 * d4 <= 0


def _visibility_graph_distance(rooms: TwoRooms, s: np.ndarray) -> float:
    """Dijkstra over {s, goal, door corners nudged into the door} with a generic visibility test."""
    lo, hi = rooms.door
    nudge = 1e-9
    corners = [np.array([rooms.wall_x, y + d]) for y, d in ((lo, nudge), (hi, -nudge))]
    corners = [c for c in corners if 0 < c[1] < rooms.height]
    nodes = [s, np.asarray(rooms.goal, float), *corners]
    walls = _wall_segments(rooms)

    def visible(i: int, j: int) -> bool:
        return not any(_properly_intersect(nodes[i], nodes[j], a, b) for a, b in walls)

    best = {0: 0.0}
    heap = [(0.0, 0)]
    while heap:
        d, i = heapq.heappop(heap)
        if i == 1:
            return d
        for j in range(len(nodes)):
            if j != i and visible(i, j):
                nd = d + float(np.linalg.norm(nodes[i] - nodes[j]))
                if nd < best.get(j, math.inf):
                    best[j] = nd
                    heapq.heappush(heap, (nd, j))
    return math.inf


def _grid_dijkstra(rooms: TwoRooms, h: float) -> tuple[np.ndarray, np.ndarray]:
    """16-connected lattice of spacing ``h``; moves whose midpoint-line crosses the wall dropped.

    Returns lattice points and their lattice distance to the goal (the goal is a lattice node).
    """
    gx, gy = rooms.goal
    xs = gx + h * np.arange(-round(gx / h), round((rooms.width - gx) / h) + 1)
    ys = gy + h * np.arange(-round(gy / h), round((rooms.height - gy) / h) + 1)
    xs, ys = xs[(xs >= 0) & (xs <= rooms.width)], ys[(ys >= 0) & (ys <= rooms.height)]
    xs = xs[np.abs(xs - rooms.wall_x) > 1e-9]  # no node on the wall line
    ix, iy = np.meshgrid(np.arange(len(xs)), np.arange(len(ys)), indexing="ij")
    index = ix * len(ys) + iy
    pts = np.stack([xs[ix.ravel()], ys[iy.ravel()]], axis=1)
    moves = [(1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2)]
    rows, cols, weights = [], [], []
    for dx, dy in moves:
        a = index[max(0, -dx) : len(xs) - max(0, dx), max(0, -dy) : len(ys) - max(0, dy)]
        b = index[max(0, dx) : len(xs) + min(0, dx), max(0, dy) : len(ys) + min(0, dy)]
        p, q = pts[a.ravel()], pts[b.ravel()]
        side = (p[:, 0] - rooms.wall_x) * (q[:, 0] - rooms.wall_x) < 0
        t = (rooms.wall_x - p[:, 0]) / np.where(side, q[:, 0] - p[:, 0], 1.0)
        y = p[:, 1] + t * (q[:, 1] - p[:, 1])
        ok = ~side | ((y > rooms.door[0]) & (y < rooms.door[1]))
        rows += [a.ravel()[ok]]
        cols += [b.ravel()[ok]]
        weights += [np.linalg.norm(p - q, axis=1)[ok]]
    n = len(pts)
    ij = (np.concatenate(rows), np.concatenate(cols))
    graph = coo_matrix((np.concatenate(weights), ij), shape=(n, n))
    goal_index = int(np.argmin(np.linalg.norm(pts - np.asarray(rooms.goal), axis=1)))
    return pts, dijkstra(graph.tocsr(), directed=False, indices=goal_index)


# -- ground truth ---------------------------------------------------------------------------------
@pytest.mark.parametrize("rooms", ROOMS)
def test_value_matches_visibility_graph(rooms: TwoRooms) -> None:
    rng = np.random.default_rng(0)
    states = random_states(rooms, 400, rng)
    exact = -rooms.value(states)
    reference = np.array([_visibility_graph_distance(rooms, s) for s in states])
    np.testing.assert_allclose(exact, reference, rtol=1e-7, atol=1e-7)


@pytest.mark.parametrize("rooms", ROOMS)
def test_value_matches_grid_dijkstra(rooms: TwoRooms) -> None:
    pts, lattice = _grid_dijkstra(rooms, h=0.02)
    exact = rooms.geodesic(pts, np.asarray(rooms.goal))
    # A 16-connected lattice path is never shorter than the true one and at most
    # 2 sin(13.3°) / sin(26.6°) - 1 = 2.75% longer (plus a few cells near the door corner).
    assert np.all(lattice >= exact - 1e-9)
    assert np.all(lattice <= 1.0276 * exact + 0.05)


def test_value_jumps_across_the_wall_and_is_continuous_through_the_door() -> None:
    rooms = TwoRooms()
    eps = 1e-6
    left, right = rooms.value(np.array([[1 - eps, 0.2], [1 + eps, 0.2]]))
    assert left - right > 0.5
    left, right = rooms.value(np.array([[1 - eps, 0.9], [1 + eps, 0.9]]))
    assert abs(left - right) < 1e-5


@pytest.mark.parametrize("rooms", ROOMS)
def test_one_state_is_valued_as_in_a_batch(rooms: TwoRooms) -> None:
    """Shape (2,) in, shape () out, the batch's number: one state on each side of the wall,
    whose straight path to the goal is blocked for one of them."""
    states = random_states(rooms, 50, np.random.default_rng(2))
    batch = rooms.value(states)
    singles = [rooms.value(s) for s in states]
    assert all(np.shape(v) == () for v in singles)
    np.testing.assert_array_equal(np.array(singles), batch)
    assert rooms.crosses_wall(states, np.asarray(rooms.goal)[None]).any()


def test_geodesic_is_symmetric_and_a_metric_on_samples() -> None:
    rooms = TwoRooms(door=(0.4, 0.6), goal=(0.2, 0.8))
    s = random_states(rooms, 60, np.random.default_rng(1))
    d = rooms.geodesic(s[:, None], s[None, :])
    np.testing.assert_allclose(d, d.T, atol=1e-12)
    assert np.all(np.diag(d) == 0)
    for i, j, k in itertools.islice(itertools.permutations(range(60), 3), 5000):
        assert d[i, k] <= d[i, j] + d[j, k] + 1e-12


# -- walks ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("rooms", ROOMS)
def test_moves_never_cross_the_wall(rooms: TwoRooms) -> None:
    """Property test: random states, random (large, wall-seeking) displacements."""
    rng = np.random.default_rng(2)
    p = random_states(rooms, 2000, rng)
    for _ in range(50):
        toward_wall = np.stack([rooms.wall_x - p[:, 0], np.zeros(len(p))], axis=1)
        step = rng.uniform(0, 2.5, (len(p), 1)) * toward_wall + rng.normal(0, 0.3, p.shape)
        q = rooms.move(p, step)
        assert not rooms.crosses_wall(p, q).any()
        assert np.all((q >= 0) & (q <= [rooms.width, rooms.height]))
        p = q


@pytest.mark.parametrize("rooms", ROOMS)
def test_goal_walks_stay_legal_and_reach_the_goal(rooms: TwoRooms) -> None:
    data = goal_walks(rooms, n_episodes=60, seed=3, step_noise=0.05, target_noise=0.0)
    same_walk = ~data.episode_starts[1:]
    assert not rooms.crosses_wall(data.states[:-1], data.states[1:])[same_walk].any()
    np.testing.assert_allclose(data.targets, rooms.value(data.states))
    ends = np.r_[np.flatnonzero(data.episode_starts)[1:] - 1, len(data.states) - 1]
    reached = np.linalg.norm(data.states[ends] - np.asarray(rooms.goal), axis=1) <= 0.05
    assert reached.mean() > 0.9
    assert data.episode_starts[0] and data.episode_starts.sum() == 60
    assert (data.states[data.episode_starts, 0] > rooms.wall_x).any()  # starts in both rooms
    assert (data.states[data.episode_starts, 0] < rooms.wall_x).any()


def test_batches_partition_the_walks() -> None:
    data = goal_walks(TwoRooms(), n_episodes=25, seed=4)
    batches = list(data.batches(10))
    assert [int(b.episode_starts.sum()) for b in batches] == [10, 10, 5]
    np.testing.assert_array_equal(np.concatenate([b.states for b in batches]), data.states)


def test_euclidean_laplacian_profile() -> None:
    kernel = LaplacianKernel(0.5)
    r = torch.tensor([0.0, 1.0, 2.0], dtype=torch.float64)
    torch.testing.assert_close(kernel.profile(r), torch.exp(-r))
