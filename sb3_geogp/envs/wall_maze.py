"""WallMaze: 2-D continuous navigation with walls the agent can never cross.

The arena is the unit square ``[0, 1] x [0, 1]``. Two horizontal walls split it into three
corridors joined by gaps at alternating ends, a zig-zag::

    y = 1  +-----------------------------+
           |  (G)                        |   top corridor, goal disk G at (0.15, 0.85)
    y = .5 |=====================  gap   |   upper wall from x = 0 to x = 0.7
           |                             |   middle corridor
    y = .25|  gap   =====================|   lower wall from x = 0.3 to x = 1
           |                             |   bottom corridor
    y = 0  +-----------------------------+

A point agent moves by a bounded displacement per step. Every move is a straight segment;
if it meets a wall (or the arena boundary, which is four more walls) the move stops just
before the first contact (no sliding), so no trajectory ever crosses a wall. The reward is
``-1`` per step until the agent enters the goal disk, which terminates the episode. The optimal
value is therefore minus the number of steps along the shortest wall-avoiding path
(discounting aside), and it jumps across each wall: the two sides of a wall are close in the
plane but a whole corridor apart along the path. This is the case geodesic kernels are for.

Four variants, registered by :func:`register_wall_maze`:

* ``sb3_geogp/WallMaze-v0``: :class:`WallMaze`, continuous actions, a velocity in
  ``[-1, 1]^2`` scaled by ``max_step`` (its norm is clipped to 1, so the speed is bounded by
  ``max_step`` per step in every direction);
* ``sb3_geogp/WallMazeDiscrete-v0``: :class:`WallMazeDiscrete`, 8 actions, unit moves of
  length ``max_step`` in the compass directions ``k * 45`` degrees (0 = +x, counter-clockwise);
* ``sb3_geogp/WallMazeCorner-v0``: :class:`WallMaze` on :data:`CORNER_LAYOUT`, where moves
  slide along walls and the goal fills the top-left corner, so that a policy pushing into
  the arena's sides is not stuck; what remains hard is the dead end under the upper wall's
  left end (docs/results.md, "WallMaze");
* ``sb3_geogp/WallMazeDoor-v0``: :class:`WallMaze` on :data:`DOOR_LAYOUT`, one wall across
  the middle with a door in its centre, sliding moves, the goal above the door: the setting in
  which SB3's MLP critic reaches the threshold (at 100,000 steps; docs/results.md).

All four truncate episodes after :data:`MAX_EPISODE_STEPS` steps.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.envs.registration import register, registry

#: Registered id of the continuous-action variant.
WALL_MAZE_ID = "sb3_geogp/WallMaze-v0"
#: Registered id of the discrete-action (8 directions) variant.
WALL_MAZE_DISCRETE_ID = "sb3_geogp/WallMazeDiscrete-v0"
#: Registered id of the continuous-action variant on :data:`CORNER_LAYOUT`.
WALL_MAZE_CORNER_ID = "sb3_geogp/WallMazeCorner-v0"
#: Registered id of the continuous-action variant on :data:`DOOR_LAYOUT`.
WALL_MAZE_DOOR_ID = "sb3_geogp/WallMazeDoor-v0"
#: Episode length of the registered variants (time-limit truncation), steps. The longest
#: shortest path (from the bottom-right corner to the goal) takes 36 steps at full speed, at
#: most 34 from the start distribution's states.
MAX_EPISODE_STEPS = 200
#: ``reward_threshold`` of the registered variants: mean evaluation return counted as
#: "solved", used for steps-to-threshold. The mean optimal return over the start
#: distribution is about -12.1 (-12.13 +- 0.11 over 6,000 starts,
#: :meth:`MazeLayout.optimal_steps`; -12.6 was once quoted from 2,000); a random
#: policy rarely reaches the goal within the time limit (mean return about -180).
REWARD_THRESHOLD = -20.0

#: Side of :meth:`WallMaze.render`'s image, pixels.
RENDER_SIZE = 128

# Moves at an angle below this (radians) to a wall count as parallel to it, and a wall end
# point this close (arena units) to the move's line counts as on it.
_COLLINEAR_TOL = 1e-12
# A crossing this close beyond a wall's end (a fraction of the wall's length) counts as meeting
# it: a move aimed exactly at a wall tip crosses the wall's line a few ulps either side of the
# tip, and without it 2 % of such moves slipped past the tip (float64 moves).
_END_TOL = 1e-12


def _default_walls() -> tuple[tuple[float, float, float, float], ...]:
    return ((0.0, 0.5, 0.7, 0.5), (0.3, 0.25, 1.0, 0.25))


@dataclass(frozen=True)
class MazeLayout:
    """Geometry and constants of :class:`WallMaze`.

    Attributes
    ----------
    size : float
        Side of the square arena ``[0, size]^2``.
    walls : tuple of (x0, y0, x1, y1)
        Interior wall segments (closed segments: their end points block too). The defaults
        are the upper wall ``(0, 0.5)-(0.7, 0.5)`` and the lower wall ``(0.3, 0.25)-(1, 0.25)``.
    goal : tuple of float
        Centre of the goal disk.
    goal_radius : float
        Radius of the goal disk; the episode terminates when a move ends inside it.
    max_step : float
        Largest displacement per step (speed bound), in arena units.
    margin : float
        Clearance: every position stays at least this far from every wall, so the agent
        never sits on a wall (see :meth:`move`).
    step_reward : float
        Reward of every step, including the one that reaches the goal.
    start_clearance : float or None
        Reset draws starts at least this far from every wall and the boundary. ``None``:
        ``2 * max_step`` (0.1 in the default layout).
    slide : bool
        ``False`` (the published variant): a move that meets a wall stops there, so a policy
        pushing diagonally into a wall stays put. ``True``: the rest of the move slides along
        the wall (:meth:`move`).
    """

    size: float = 1.0
    walls: tuple[tuple[float, float, float, float], ...] = field(default_factory=_default_walls)
    goal: tuple[float, float] = (0.15, 0.85)
    goal_radius: float = 0.08
    max_step: float = 0.05
    margin: float = 1e-6
    step_reward: float = -1.0
    start_clearance: float | None = None
    slide: bool = False

    @property
    def clearance(self) -> float:
        """Distance of every start from the walls and the boundary (``start_clearance``)."""
        return 2 * self.max_step if self.start_clearance is None else self.start_clearance

    def segments(self) -> np.ndarray:
        """All blocking segments (interior walls, then the 4 arena sides), shape (W, 4)."""
        s = self.size
        border = [(0.0, 0.0, s, 0.0), (s, 0.0, s, s), (s, s, 0.0, s), (0.0, s, 0.0, 0.0)]
        return np.array([*self.walls, *border], dtype=np.float64)

    def crosses_wall(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Whether the straight segments ``a -> b`` meet an interior wall (closed segments).

        The visibility an oracle attachment needs (``sb3_geogp/studies/wall/oracle.py``);
        the arena's sides are left out (both ends lie inside it). A segment parallel to a wall
        (angle below ``1e-12`` rad) counts as missing it.

        Parameters
        ----------
        a, b : ndarray, shape (..., 2)
            Start and end points (broadcast against each other).

        Returns
        -------
        ndarray of bool, shape (...)
        """
        a, b = np.broadcast_arrays(np.asarray(a, np.float64), np.asarray(b, np.float64))
        walls = np.asarray(self.walls, dtype=np.float64).reshape(-1, 4)
        t, u, parallel = _line_crossings(a, b - a, walls)
        meets = ~parallel & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
        return np.asarray(meets.any(axis=-1))

    def in_goal(self, pos: np.ndarray) -> np.ndarray:
        """Whether positions ``pos : (..., 2)`` lie in the goal disk, shape (...)."""
        d = np.asarray(pos, dtype=np.float64) - np.asarray(self.goal)
        return np.asarray(np.hypot(d[..., 0], d[..., 1]) <= self.goal_radius)

    def move(self, pos: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """End point of the move ``pos -> pos + delta``, stopped before any wall.

        Parameters
        ----------
        pos : ndarray, shape (2,)
            Current position (off every wall).
        delta : ndarray, shape (2,)
            Intended displacement.

        Returns
        -------
        ndarray, shape (2,)
            ``pos + s * delta``: ``s = 1`` if the move meets no wall, otherwise the first
            contact parameter minus ``2 * margin / |delta|`` (at least 0): the move stops just
            before the wall. The end point must then keep the clearance ``margin`` from every
            wall and the segment ``pos -> end`` must meet none (:func:`segments_hit_walls`);
            otherwise ``s`` is halved until both hold (a grazing approach, where stopping
            ``2 * margin`` back along the move is closer than ``margin`` to the wall), or the
            agent stays at ``pos`` after 64 halvings. With :attr:`slide`, a stopped move goes
            on from there by the rest of ``delta`` projected onto the wall it met, stopped in
            the same way (once: no second slide).
        """
        return self.moves(np.reshape(pos, (1, 2)), np.reshape(delta, (1, 2)))[0]

    def moves(self, pos: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """:meth:`move` for many agents at once (the same arithmetic, agent by agent).

        Parameters
        ----------
        pos, delta : ndarray, shape (N, 2)

        Returns
        -------
        ndarray, shape (N, 2)
        """
        pos = np.asarray(pos, dtype=np.float64)
        delta = np.asarray(delta, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 2 or delta.shape != pos.shape:
            raise ValueError(
                f"moves needs positions and displacements of one shape (N, 2), got {pos.shape} "
                f"and {delta.shape}; for one agent use move"
            )
        walls = self.segments()
        end, hit = _straight_moves(pos, delta, walls, self.margin)
        slid = np.flatnonzero(hit >= 0) if self.slide else np.empty(0, dtype=np.intp)
        if slid.size:
            along = walls[hit[slid], 2:4] - walls[hit[slid], 0:2]
            rest = pos[slid] + delta[slid] - end[slid]
            slide = along * _dot(rest, along)[:, None] / _dot(along, along)[:, None]
            end[slid] = _straight_moves(end[slid], slide, walls, self.margin)[0]
        return end

    def optimal_steps(self, pos: np.ndarray) -> np.ndarray:
        """Steps along the shortest wall-avoiding path at full speed, ``ceil(L / max_step)``.

        ``L`` is the length of the shortest path from ``pos`` to the goal *centre* that meets
        no wall (a visibility graph over the walls' free end points, solved with Dijkstra),
        minus ``goal_radius``: exact for the default layout, where the last leg of every
        shortest path sees the centre. It ignores ``margin`` (1e-6).

        Parameters
        ----------
        pos : ndarray, shape (N, 2) or (2,)

        Returns
        -------
        ndarray of float, shape (N,) or ()
            0 inside the goal disk.
        """
        pts = np.atleast_2d(np.asarray(pos, dtype=np.float64))
        lengths = np.array([self.shortest_path_length(p) for p in pts])
        steps = np.ceil(np.maximum(lengths - self.goal_radius, 0.0) / self.max_step - 1e-9)
        return steps.reshape(np.shape(pos)[:-1])

    def shortest_path_length(self, pos: np.ndarray) -> float:
        """Length of the shortest wall-avoiding path from ``pos : (2,)`` to the goal centre."""
        walls = self.segments()
        corners = [
            np.array(p)
            for w in self.walls
            for p in ((w[0], w[1]), (w[2], w[3]))
            if 0.0 < p[0] < self.size and 0.0 < p[1] < self.size
        ]
        nodes = [np.asarray(pos, dtype=np.float64), *corners, np.asarray(self.goal, float)]
        n = len(nodes)
        goal_index = n - 1
        best = [math.inf] * n
        best[0] = 0.0
        heap: list[tuple[float, int]] = [(0.0, 0)]
        while heap:
            d, i = heapq.heappop(heap)
            if d > best[i]:
                continue
            if i == goal_index:
                return d
            for j in range(n):
                if j == i or _blocked(nodes[i], nodes[j], walls):
                    continue
                nd = d + float(np.hypot(*(nodes[j] - nodes[i])))
                if nd < best[j]:
                    best[j] = nd
                    heapq.heappush(heap, (nd, j))
        return math.inf


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of two ``(N, 2)`` arrays, shape (N,).

    ``matmul`` rounds as a single ``a @ b`` does (``einsum`` does not, bit for bit), so one
    agent's move is the same alone and in a batch."""
    return (a[:, None, :] @ b[:, :, None])[:, 0, 0]


def _straight_moves(
    pos: np.ndarray, delta: np.ndarray, walls: np.ndarray, margin: float
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`MazeLayout.moves` without sliding: the end points, shape (N, 2), and the index
    of the wall that stopped each move (``-1`` where none did), shape (N,)."""
    length = np.hypot(delta[:, 0], delta[:, 1])
    t, wall = first_hits(pos, delta, walls)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(wall >= 0, np.maximum(0.0, t - 2 * margin / length), 1.0)
    end = pos.copy()
    pending = np.flatnonzero(length > 0.0)
    for _ in range(64):
        if not pending.size:
            break
        trial = pos[pending] + scale[pending, None] * delta[pending]
        ok = (distances_to_walls(trial, walls) >= margin) & ~segments_hit_walls(
            pos[pending], trial, walls
        )
        end[pending[ok]] = trial[ok]
        pending = pending[~ok]
        scale[pending] *= 0.5
    return end, np.where(length > 0.0, wall, -1)


def _cross(ax: Any, ay: Any, bx: Any, by: Any) -> Any:
    return ax * by - ay * bx


def _line_crossings(
    a: np.ndarray, d: np.ndarray, walls: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where moves ``a -> a + d`` (``(..., 2)`` each, broadcast) cross the lines of ``walls :
    (W, 4)``: ``t`` along each move and ``u`` along each wall, shape (..., W), and whether the
    two are parallel (angle below ``1e-12`` rad), where ``t`` and ``u`` mean nothing. A move
    meets a wall's interior-or-end where it is not parallel and both lie in ``[0, 1]``."""
    p, r = walls[:, 0:2], walls[:, 2:4] - walls[:, 0:2]  # (W, 2)
    d = np.asarray(d)[..., None, :]  # (..., 1, 2)
    qp = p - np.asarray(a)[..., None, :]  # (..., W, 2)
    denom = _cross(d[..., 0], d[..., 1], r[:, 0], r[:, 1])  # (..., W)
    scale = np.hypot(d[..., 0], d[..., 1]) * np.hypot(r[:, 0], r[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        t = _cross(qp[..., 0], qp[..., 1], r[:, 0], r[:, 1]) / denom
        u = _cross(qp[..., 0], qp[..., 1], d[..., 0], d[..., 1]) / denom
    return t, u, np.abs(denom) <= _COLLINEAR_TOL * scale


def first_hit(pos: np.ndarray, delta: np.ndarray, walls: np.ndarray) -> tuple[float, int] | None:
    """Smallest ``t`` in ``[0, 1]`` where ``pos + t * delta`` meets a wall (closed segments),
    and the index of that wall (:func:`first_hits` for one move).

    Parameters
    ----------
    pos, delta : ndarray, shape (2,)
    walls : ndarray, shape (W, 4)
        Segments ``(x0, y0, x1, y1)``.

    Returns
    -------
    (float, int) or None
        ``None`` if the move meets no wall.
    """
    t, wall = first_hits(np.reshape(pos, (1, 2)), np.reshape(delta, (1, 2)), walls)
    return None if wall[0] < 0 else (float(t[0]), int(wall[0]))


def first_hits(
    pos: np.ndarray, delta: np.ndarray, walls: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Smallest ``t`` in ``[0, 1]`` where each move ``pos + t * delta`` meets a wall (closed
    segments, each lengthened by ``1e-12`` of its length at both ends against rounding at its
    tips), and the index of that wall.

    Parameters
    ----------
    pos, delta : ndarray, shape (N, 2)
        Moves; one of zero length meets no wall.
    walls : ndarray, shape (W, 4)
        Segments ``(x0, y0, x1, y1)``.

    Returns
    -------
    t : ndarray, shape (N,)
        ``inf`` where the move meets no wall.
    wall : ndarray of int, shape (N,)
        ``-1`` where the move meets no wall. A move parallel to a wall (angle below ``1e-12``
        rad) meets it only if it runs along the wall's own line and overlaps it; then ``t`` is
        the start of the overlap. Of walls met at the same ``t`` (a corner), the first in
        ``walls``.
    """
    pos, delta = np.asarray(pos, np.float64), np.asarray(delta, np.float64)
    t, u, parallel = _line_crossings(pos, delta, walls)  # (N, W) each
    hits = ~parallel & (t >= 0.0) & (t <= 1.0) & (u >= -_END_TOL) & (u <= 1.0 + _END_TOL)
    candidates = np.where(hits, t, np.inf)
    # Collinear: the wall's start lies on the move's line; overlap of the projections.
    r = walls[:, 2:4] - walls[:, 0:2]  # (W, 2)
    qp = walls[:, 0:2] - pos[:, None, :]  # (N, W, 2)
    dx, dy = delta[:, None, 0], delta[:, None, 1]  # (N, 1)
    len_d = np.hypot(dx, dy)
    with np.errstate(divide="ignore", invalid="ignore"):
        offline = np.abs(_cross(qp[..., 0], qp[..., 1], dx, dy)) / len_d
    collinear = parallel & (offline <= _COLLINEAR_TOL)
    for n, w in zip(*np.nonzero(collinear), strict=True):  # rare: a loop, in Python floats
        squared = float(len_d[n, 0]) ** 2
        t0 = float(qp[n, w] @ delta[n]) / squared
        t1 = float((qp[n, w] + r[w]) @ delta[n]) / squared
        lo, hi = max(0.0, min(t0, t1)), min(1.0, max(t0, t1))
        if lo <= hi:
            candidates[n, w] = lo
    wall = np.argmin(candidates, axis=1)
    first = candidates[np.arange(len(pos)), wall]
    return first, np.where(np.isfinite(first), wall, -1)


def segments_hit_walls(a: np.ndarray, b: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Whether each closed segment ``a -> b`` meets any wall (:func:`first_hits`).

    Parameters
    ----------
    a, b : ndarray, shape (N, 2)
    walls : ndarray, shape (W, 4)

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    a = np.asarray(a, dtype=np.float64)
    delta = np.asarray(b, dtype=np.float64) - a
    moving = np.any(delta != 0, axis=1)
    hit = np.zeros(len(a), dtype=bool)
    if moving.any():
        hit[moving] = first_hits(a[moving], delta[moving], walls)[1] >= 0
    return hit


def _blocked(a: np.ndarray, b: np.ndarray, walls: np.ndarray) -> bool:
    """Visibility test of the path planner: the open segment ``a b`` crosses a wall interior.

    Touching a wall at an end point (the path bends around a free wall end) is allowed.
    """
    delta = b - a
    p = walls[:, 0:2]
    r = walls[:, 2:4] - p
    denom = _cross(delta[0], delta[1], r[:, 0], r[:, 1])
    qp = p - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t = _cross(qp[:, 0], qp[:, 1], r[:, 0], r[:, 1]) / denom
        u = _cross(qp[:, 0], qp[:, 1], delta[0], delta[1]) / denom
    eps = 1e-9
    hit = (np.abs(denom) > _COLLINEAR_TOL) & (t > eps) & (t < 1 - eps) & (u > eps) & (u < 1 - eps)
    return bool(np.any(hit))


class WallMaze(gym.Env[np.ndarray, np.ndarray]):
    """Continuous-action WallMaze (see the module docstring for the layout).

    Observation: the position ``(x, y)``, float32, shape (2,), in ``[0, size]^2``.
    Action: a velocity ``v``, float32, shape (2,), in ``[-1, 1]^2``; the move is
    ``max_step * v / max(1, |v|)`` (out-of-box actions are clipped to the box first).
    Reward ``step_reward`` (-1) per step; terminated when a move ends in the goal disk.

    Parameters
    ----------
    layout : MazeLayout, optional
        Geometry and constants (default: the documented zig-zag).
    render_mode : {None, "rgb_array"}
        ``"rgb_array"``: :meth:`render` returns a top view, uint8, shape
        (:data:`RENDER_SIZE`, :data:`RENDER_SIZE`, 3): walls black, goal green, agent red.

    Notes
    -----
    Reset draws the start uniformly over the free arena: outside the goal disk and at least
    :attr:`MazeLayout.clearance` from every wall and the boundary (rejection sampling).
    ``reset(options={"start": (x, y)})`` starts from a given position instead. The
    position is kept in float64; ``info["position"]`` holds it after every step.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 20}  # noqa: RUF012

    def __init__(self, layout: MazeLayout | None = None, render_mode: str | None = None) -> None:
        super().__init__()
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.layout = layout or MazeLayout()
        self.render_mode = render_mode
        s = self.layout.size
        self.observation_space = spaces.Box(0.0, s, shape=(2,), dtype=np.float32)
        self.action_space: spaces.Space[Any] = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self._walls = self.layout.segments()
        self.position = np.array([s / 2, s / 8], dtype=np.float64)

    # -- gymnasium API ---------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start a new episode; returns ``(obs, info)``, ``obs`` of shape (2,)."""
        super().reset(seed=seed)
        if options is not None and "start" in options:
            start = np.asarray(options["start"], dtype=np.float64).reshape(2)
            if distance_to_walls(start, self._walls) < self.layout.margin or not (
                np.all(start > 0) and np.all(start < self.layout.size)
            ):
                raise ValueError(f"start {start} is outside the arena or on a wall")
            self.position = start
        else:
            self.position = self._sample_start()
        return self._obs(), {"position": self.position.copy()}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Move by ``action``; returns the gymnasium 5-tuple (never truncates by itself)."""
        delta = self.displacements(np.reshape(action, (1, *(self.action_space.shape or ()))))[0]
        start = self.position
        self.position = self.layout.move(start, delta)
        terminated = bool(self.layout.in_goal(self.position))
        info = {"position": self.position.copy(), "previous_position": start.copy()}
        return self._obs(), float(self.layout.step_reward), terminated, False, info

    def render(self) -> np.ndarray | None:
        """Top view as an RGB image (``render_mode="rgb_array"``), else ``None``."""
        if self.render_mode != "rgb_array":
            return None
        n = RENDER_SIZE
        lay = self.layout
        # Pixel centres in arena units, image row 0 at the top (y = size).
        u = (np.arange(n) + 0.5) / n * lay.size
        x, y = np.meshgrid(u, u[::-1])
        img = np.full((n, n, 3), 255, dtype=np.uint8)
        img[lay.in_goal(np.stack([x, y], axis=-1))] = (0, 160, 0)
        px = lay.size / n
        for x0, y0, x1, y1 in self._walls:
            t = np.linspace(0.0, 1.0, 4 * n)
            cols = np.clip(((x0 + t * (x1 - x0)) / px).astype(int), 0, n - 1)
            rows = np.clip(n - 1 - ((y0 + t * (y1 - y0)) / px).astype(int), 0, n - 1)
            img[rows, cols] = 0
        agent = np.hypot(x - self.position[0], y - self.position[1]) <= max(2 * px, 0.02)
        img[agent] = (220, 0, 0)
        return img

    # -- helpers ---------------------------------------------------------------------------
    def displacements(self, actions: np.ndarray) -> np.ndarray:
        """The moves a batch of actions commands.

        Parameters
        ----------
        actions : ndarray, shape (N, 2)

        Returns
        -------
        ndarray, shape (N, 2)
        """
        v = np.asarray(actions, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 2:
            raise ValueError(f"actions must have shape (N, 2), got {v.shape}")
        v = np.clip(v, -1.0, 1.0)
        norm = np.hypot(v[:, 0], v[:, 1])
        return self.layout.max_step * v / np.maximum(1.0, norm)[:, None]

    def transitions(
        self, positions: np.ndarray, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`step` for a batch of agents, without the environment's own state: what a
        Monte Carlo estimate of a policy's value restarts from any position.

        Parameters
        ----------
        positions : ndarray, shape (N, 2)
        actions : ndarray, shape (N, 2) (continuous) or (N,) (discrete)

        Returns
        -------
        next_positions : ndarray, shape (N, 2)
        terminated : ndarray of bool, shape (N,)
        """
        delta = self.displacements(actions)
        if len(delta) != len(positions):
            raise ValueError(
                f"transitions needs one action per position, got {len(delta)} actions for "
                f"{len(positions)} positions"
            )
        end = self.layout.moves(positions, delta)
        return end, self.layout.in_goal(end)

    def observe(self, positions: np.ndarray) -> np.ndarray:
        """The observations of positions ``(..., 2)``: float32, clipped to the arena."""
        obs = np.asarray(positions, dtype=np.float64).astype(np.float32)
        return np.clip(obs, np.float32(0.0), np.float32(self.layout.size))

    def _obs(self) -> np.ndarray:
        return self.observe(self.position)

    def _sample_start(self) -> np.ndarray:
        lay = self.layout
        clearance = lay.clearance
        for _ in range(10_000):
            p = self.np_random.uniform(clearance, lay.size - clearance, size=2)
            if lay.in_goal(p) or distance_to_walls(p, self._walls) < clearance:
                continue
            return p
        raise RuntimeError("could not sample a free start position; check the layout")


class WallMazeDiscrete(WallMaze):
    """Discrete-action WallMaze: action ``k`` in ``{0, ..., 7}`` moves ``max_step`` towards
    angle ``k * pi / 4`` (0 = +x, 2 = +y, counter-clockwise). Everything else as
    :class:`WallMaze`."""

    #: Unit displacement of each action, shape (8, 2).
    DIRECTIONS = np.stack(
        [np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1
    )

    def __init__(self, layout: MazeLayout | None = None, render_mode: str | None = None) -> None:
        super().__init__(layout, render_mode)
        self.action_space = spaces.Discrete(8)

    def displacements(self, actions: np.ndarray) -> np.ndarray:
        """The moves of a batch of actions ``(N,)`` in ``0..7``, shape (N, 2)."""
        k = np.asarray(actions)
        if k.ndim != 1:
            raise ValueError(f"actions must have shape (N,), got {k.shape}")
        k = k.astype(np.int64)
        if np.any((k < 0) | (k >= 8)):
            raise ValueError(f"actions must be in 0..7, got {k[(k < 0) | (k >= 8)][0]}")
        return self.layout.max_step * self.DIRECTIONS[k]


def distance_to_walls(p: np.ndarray, walls: np.ndarray) -> float:
    """Euclidean distance from ``p : (2,)`` to the nearest segment of ``walls : (W, 4)``."""
    return float(distances_to_walls(np.reshape(p, (1, 2)), walls)[0])


def distances_to_walls(p: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """:func:`distance_to_walls` for points ``p : (N, 2)``, shape (N,)."""
    a = walls[:, 0:2]
    ab = walls[:, 2:4] - a
    pa = np.asarray(p, dtype=np.float64)[:, None, :] - a  # (N, W, 2)
    t = np.clip(np.einsum("nwi,wi->nw", pa, ab) / np.einsum("wi,wi->w", ab, ab), 0.0, 1.0)
    gap = np.asarray(p, dtype=np.float64)[:, None, :] - (a + t[..., None] * ab)
    return np.min(np.hypot(gap[..., 0], gap[..., 1]), axis=1)


#: The layout of ``sb3_geogp/WallMazeCorner-v0``: the default walls, speed and starts, moves
#: that slide along walls, and a goal disk of radius 0.12 at ``(0.1, 0.9)``, which reaches
#: over both sides of the top-left corner (a move sliding into the corner ends in it). The mean
#: optimal return over 2000 starts is -12.6, close to the default layout's, so the threshold
#: stays :data:`REWARD_THRESHOLD`.
CORNER_LAYOUT = MazeLayout(slide=True, goal=(0.1, 0.9), goal_radius=0.12)

#: The layout of ``sb3_geogp/WallMazeDoor-v0``: one wall across the middle (``y = 0.5``) with a
#: door 0.2 wide in its centre, the default speed and starts, moves that slide along walls, and
#: the default goal disk moved above the door, to ``(0.5, 0.85)``. Below the wall the value
#: still jumps across it (a start under the wall's middle is a detour through the door away
#: from a start just above it); pushing towards the goal slides into the door, so there is no
#: dead end. Mean optimal return over 2000 starts -8.15; the threshold stays
#: :data:`REWARD_THRESHOLD`.
DOOR_LAYOUT = MazeLayout(
    walls=((0.0, 0.5, 0.4, 0.5), (0.6, 0.5, 1.0, 0.5)), slide=True, goal=(0.5, 0.85)
)


def register_wall_maze() -> None:
    """Register ``sb3_geogp/WallMaze-v0``, ``sb3_geogp/WallMazeDiscrete-v0``,
    ``sb3_geogp/WallMazeCorner-v0`` and ``sb3_geogp/WallMazeDoor-v0`` (idempotent)."""
    for env_id, entry, kwargs in (
        (WALL_MAZE_ID, "sb3_geogp.envs.wall_maze:WallMaze", {}),
        (WALL_MAZE_DISCRETE_ID, "sb3_geogp.envs.wall_maze:WallMazeDiscrete", {}),
        (WALL_MAZE_CORNER_ID, "sb3_geogp.envs.wall_maze:WallMaze", {"layout": CORNER_LAYOUT}),
        (WALL_MAZE_DOOR_ID, "sb3_geogp.envs.wall_maze:WallMaze", {"layout": DOOR_LAYOUT}),
    ):
        if env_id not in registry:
            register(
                id=env_id,
                entry_point=entry,
                max_episode_steps=MAX_EPISODE_STEPS,
                reward_threshold=REWARD_THRESHOLD,
                kwargs=kwargs,
            )
