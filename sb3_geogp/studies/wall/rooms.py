"""A two-room domain with an exact geodesic value function and noisy goal-directed walks.

The state space is the box ``[0, width] x [0, height]`` (default ``[0, 2] x [0, 1]``) split by
a vertical wall at ``x = wall_x`` (default 1) that is open only in the door
``door[0] < y < door[1]`` (default ``0.8 < y < 1``). The goal lies in the left room.

Ground truth: ``V(s) = -L(s)``, ``L(s)`` the length of the shortest path from ``s`` to the goal
that does not pass through the wall. Both rooms are convex and the wall is a union of at most
two segments ending at the door corners, so a shortest path is either the straight segment
(when it does not meet the wall) or bends once, at a door corner ``c``:
``L(s) = min_c |s - c| + |c - g|``. The value is continuous everywhere except across the wall,
where it jumps (by up to ~0.9 with the defaults).

Data: :func:`goal_walks` simulates noisy walks that head along the shortest path (towards the
goal when it is in sight, else towards a point just inside the door), with Gaussian step
noise; a step that would pass through the wall is mirrored back into its own room
(:meth:`TwoRooms.move`). The regression targets are the *true* values at the visited states
plus i.i.d. Gaussian noise (no Monte-Carlo returns), so that fitting error is all the
estimator's.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from sb3_geogp.toolbox.streams import episode_batches

#: Positions are kept this far off the wall line, so a state never sits on the wall.
_WALL_EPS = 1e-9


@dataclass(frozen=True)
class TwoRooms:
    """Geometry of the two-room domain.

    Parameters
    ----------
    width, height : float
        The box ``[0, width] x [0, height]``.
    wall_x : float
        Abscissa of the wall, ``0 < wall_x < width``.
    door : tuple of float
        Open interval ``(y_low, y_high)`` of the wall, ``0 <= y_low < y_high <= height``.
    goal : tuple of float
        Goal state, in the left room (``x < wall_x``).
    """

    width: float = 2.0
    height: float = 1.0
    wall_x: float = 1.0
    door: tuple[float, float] = (0.8, 1.0)
    goal: tuple[float, float] = (0.3, 0.3)

    def __post_init__(self) -> None:
        lo, hi = self.door
        if not 0 < self.wall_x < self.width:
            raise ValueError(f"wall_x must lie in (0, width), got {self.wall_x}")
        if not 0 <= lo < hi <= self.height:
            raise ValueError(f"door must satisfy 0 <= lo < hi <= height, got {self.door}")
        gx, gy = self.goal
        if not (0 <= gx < self.wall_x and 0 <= gy <= self.height):
            raise ValueError(f"goal must lie in the left room, got {self.goal}")

    # -- geometry ---------------------------------------------------------------------------
    @property
    def corners(self) -> np.ndarray:
        """Door corners that end a wall segment, shape (n_corners, 2) (at most 2)."""
        lo, hi = self.door
        ys = [y for y, inner in ((lo, lo > 0), (hi, hi < self.height)) if inner]
        return np.array([[self.wall_x, y] for y in ys], dtype=np.float64).reshape(-1, 2)

    def in_wall(self, y: np.ndarray) -> np.ndarray:
        """Whether height ``y`` on the wall line is wall (closed) rather than door (open)."""
        return (y <= self.door[0]) | (y >= self.door[1])

    def crosses_wall(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Whether the straight moves ``a -> b`` pass through the wall.

        Parameters
        ----------
        a, b : ndarray, shape (..., 2)
            Start and end points (broadcast against each other).

        Returns
        -------
        ndarray of bool, shape (...)
            ``True`` where the segment meets the wall line strictly between its two sides at
            a wall height, or where an end point lies on the wall itself.
        """
        da, db = a[..., 0] - self.wall_x, b[..., 0] - self.wall_x
        opposite = da * db < 0
        t = np.where(opposite, da / np.where(opposite, da - db, 1.0), 0.0)
        y_cross = a[..., 1] + t * (b[..., 1] - a[..., 1])
        through = opposite & self.in_wall(y_cross)
        on_wall = ((da == 0) & self.in_wall(a[..., 1])) | ((db == 0) & self.in_wall(b[..., 1]))
        return through | on_wall

    def geodesic(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Exact shortest-path length between points, avoiding the wall.

        Parameters
        ----------
        a, b : ndarray, shape (..., 2)
            End points (broadcast against each other), not on the wall itself.

        Returns
        -------
        ndarray, shape (...)
            ``|a - b|`` where the segment misses the wall, else the shortest detour through
            one door corner, ``min_c |a - c| + |c - b|``.
        """
        a, b = np.broadcast_arrays(np.asarray(a, np.float64), np.asarray(b, np.float64))
        shape = a.shape[:-1]
        a, b = a.reshape(-1, 2), b.reshape(-1, 2)  # one pair, shape (2,), as a batch of one
        out = np.linalg.norm(a - b, axis=-1)
        blocked = np.asarray(self.crosses_wall(a, b))
        if blocked.any():
            corners = self.corners[:, None, :]
            a_b, b_b = a[blocked], b[blocked]
            detour = np.linalg.norm(a_b - corners, axis=-1)
            out[blocked] = (detour + np.linalg.norm(corners - b_b, axis=-1)).min(axis=0)
        return out.reshape(shape)

    def value(self, s: np.ndarray) -> np.ndarray:
        """Ground-truth value ``V(s) = -geodesic(s, goal)``; ``s : ndarray, shape (..., 2)``."""
        return -self.geodesic(s, np.asarray(self.goal, np.float64))

    def near_wall(self, s: np.ndarray, band: float = 0.1) -> np.ndarray:
        """States within ``band`` of the wall line on either side, ``|x - wall_x| < band``."""
        return np.abs(s[..., 0] - self.wall_x) < band

    def grid(self, n_x: int) -> tuple[np.ndarray, tuple[int, int]]:
        """Cell-centred grid of ``n_x`` columns and square cells.

        No point lies on the wall line when ``n_x * wall_x / width`` is an integer (any even
        ``n_x`` with the default geometry).

        Returns
        -------
        points : ndarray, shape (n_y * n_x, 2)
            Row-major over ``y`` then ``x`` (``points.reshape(n_y, n_x, 2)`` is an image).
        shape : tuple of int
            ``(n_y, n_x)``.
        """
        h = self.width / n_x
        n_y = max(1, round(self.height / h))
        xs = (np.arange(n_x) + 0.5) * h
        ys = (np.arange(n_y) + 0.5) * (self.height / n_y)
        gx, gy = np.meshgrid(xs, ys)
        return np.stack([gx.ravel(), gy.ravel()], axis=1), (n_y, n_x)

    # -- motion -----------------------------------------------------------------------------
    def move(self, p: np.ndarray, step: np.ndarray) -> np.ndarray:
        """Apply displacements ``step`` at states ``p``, staying in the box and out of the wall.

        The target is clipped to the box; a move that would pass through the wall is mirrored
        in the wall line back into its own room (and clipped to it again). A state never lies
        on the wall itself.

        Parameters
        ----------
        p : ndarray, shape (n, 2)
            Current states (in the box, not on the wall).
        step : ndarray, shape (n, 2)
            Intended displacements.

        Returns
        -------
        ndarray, shape (n, 2)
            New states; ``crosses_wall(p, new)`` is ``False`` for every row.
        """
        q = np.clip(p + step, 0.0, [self.width, self.height])
        blocked = self.crosses_wall(p, q)
        q[blocked, 0] = np.clip(2 * self.wall_x - q[blocked, 0], 0.0, self.width)
        # A state on the wall line at a wall height goes back to its own side of the line.
        on_line = (q[:, 0] == self.wall_x) & self.in_wall(q[:, 1])
        side = np.where(p[:, 0] < self.wall_x, -1.0, 1.0)
        q[on_line, 0] = self.wall_x + side[on_line] * _WALL_EPS
        return q

    def heading(self, p: np.ndarray, door_margin: float = 0.05) -> np.ndarray:
        """Unit directions along the shortest path: to the goal if in sight, else to the door.

        The door waypoint is the blocking corner moved ``door_margin`` into the door, so that
        walks pass through the door rather than graze the wall end.

        Parameters
        ----------
        p : ndarray, shape (n, 2)
        door_margin : float

        Returns
        -------
        ndarray, shape (n, 2)
            Unit vectors (zero at the goal itself).
        """
        goal = np.asarray(self.goal, np.float64)
        target = np.broadcast_to(goal, p.shape).copy()
        blocked = self.crosses_wall(p, target)
        if blocked.any():
            corners = self.corners
            via = np.linalg.norm(p[blocked, None] - corners, axis=-1) + np.linalg.norm(
                corners - goal, axis=-1
            )
            corner = corners[via.argmin(axis=1)]
            inward = np.where(corner[:, 1] <= self.door[0], 1.0, -1.0)
            target[blocked] = corner + np.stack([np.zeros_like(inward), door_margin * inward], 1)
        direction = target - p
        norm = np.linalg.norm(direction, axis=1, keepdims=True)
        return direction / np.where(norm > 0, norm, 1.0)


@dataclass(frozen=True)
class WalkData:
    """Trajectories of :func:`goal_walks`, concatenated in time order.

    Attributes
    ----------
    states : ndarray, shape (n, 2)
    targets : ndarray, shape (n,)
        ``V(s) + N(0, target_noise^2)``.
    episode_starts : ndarray of bool, shape (n,)
        ``True`` on the first state of each walk.
    """

    states: np.ndarray
    targets: np.ndarray
    episode_starts: np.ndarray

    def batches(self, episodes_per_batch: int) -> Iterator[WalkData]:
        """Consecutive chunks of ``episodes_per_batch`` whole walks (for on-line feeding)."""
        for rows in episode_batches(self.episode_starts, episodes_per_batch):
            yield WalkData(self.states[rows], self.targets[rows], self.episode_starts[rows])


def random_states(rooms: TwoRooms, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` states uniform over the box (both rooms), none on the wall line."""
    s = rng.uniform(0.0, 1.0, size=(n, 2)) * [rooms.width, rooms.height]
    s[s[:, 0] == rooms.wall_x, 0] -= _WALL_EPS
    return s


def goal_walks(
    rooms: TwoRooms,
    n_episodes: int,
    seed: int = 0,
    step_size: float = 0.05,
    step_noise: float = 0.03,
    target_noise: float = 0.05,
    goal_radius: float = 0.05,
    max_steps: int = 200,
) -> WalkData:
    """Noisy walks towards the goal along shortest paths, from random states in both rooms.

    Each step moves ``step_size`` along :meth:`TwoRooms.heading` plus isotropic Gaussian noise
    of standard deviation ``step_noise`` per coordinate, through :meth:`TwoRooms.move` (box
    clipping, mirroring at the wall). A walk ends within ``goal_radius`` of the goal or after
    ``max_steps`` states. All walks advance together (vectorised); the output lists them one
    after the other.

    Parameters
    ----------
    rooms : TwoRooms
    n_episodes : int
        Number of walks; their start states are uniform over the box.
    seed : int
        Seeds the start states, the step noise and the target noise.
    step_size, step_noise : float
        Mean step length and step noise (state units).
    target_noise : float
        Standard deviation of the Gaussian noise added to the true values.
    goal_radius : float
        A walk stops once it is this close to the goal (its last state is recorded).
    max_steps : int
        Longest walk, in states.

    Returns
    -------
    WalkData

    Raises
    ------
    AssertionError
        If a step passed through the wall (cannot happen; checked on every step).
    """
    rng = np.random.default_rng(seed)
    goal = np.asarray(rooms.goal, np.float64)
    p = random_states(rooms, n_episodes, rng)
    path = [p]
    active = np.ones((1, n_episodes), dtype=bool)
    for _ in range(max_steps - 1):
        running = active[-1] & (np.linalg.norm(p - goal, axis=1) > goal_radius)
        if not running.any():
            break
        step = step_size * rooms.heading(p) + rng.normal(0.0, step_noise, size=p.shape)
        q = np.where(running[:, None], rooms.move(p, step), p)
        assert not rooms.crosses_wall(p, q).any(), "a walk passed through the wall"
        p = q
        path.append(p)
        active = np.vstack([active, running])
    states = np.stack(path, axis=1)[active.T]
    starts = np.zeros(active.shape[::-1], dtype=bool)
    starts[:, 0] = True
    starts = starts[active.T]
    targets = rooms.value(states) + rng.normal(0.0, target_noise, size=len(states))
    return WalkData(states, targets, starts)
