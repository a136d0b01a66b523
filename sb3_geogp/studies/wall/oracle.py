"""Attachments that know the wall: the oracle that asks what the geodesic kernel could do.

The geodesic kernel attaches a point to its Euclidean-nearest basis vectors, so a point beside
the wall can be explained by the other room (docs/wall_experiment.md measured this carrying
83-91 % of the default geodesic GP's error near the wall). The oracle forbids an attachment
whose straight segment passes through the wall
(:meth:`~sb3_geogp.studies.wall.rooms.TwoRooms.crosses_wall`): every nearest-basis-vector
choice (a training point's Shepard neighbours and novelty leaf, the parent of a walk's first
basis vector, a prediction's neighbours) then stays on its own side or sees through the door.
A learner cannot have it; it bounds what a wall-aware attachment could give.
Any geometry with a ``crosses_wall`` test serves (:class:`Obstacles`): the two rooms, or a
WallMaze layout (:meth:`~sb3_geogp.envs.wall_maze.MazeLayout.crosses_wall`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
import torch
from torch import Tensor

from sb3_geogp.kernels import GeodesicKernel


class Obstacles(Protocol):
    """A geometry that says which straight segments pass through its walls."""

    def crosses_wall(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Whether the segments ``a -> b`` (``(..., 2)`` each, broadcast) meet a wall."""
        ...


def blocked_pairs(rooms: Obstacles, x: Tensor, b: Tensor) -> Tensor:
    """Whether the straight segment from each point to each basis vector crosses a wall.

    Parameters
    ----------
    rooms : Obstacles
        :class:`~sb3_geogp.studies.wall.rooms.TwoRooms` or a
        :class:`~sb3_geogp.envs.wall_maze.MazeLayout`.
    x : Tensor, shape (n, 2)
        Points, in state units.
    b : Tensor, shape (m, 2)
        Basis vectors, in state units.

    Returns
    -------
    Tensor of bool, shape (n, m)
        On ``x``'s device.
    """
    a = x.detach().cpu().double().numpy()[:, None, :]
    z = b.detach().cpu().double().numpy()[None, :, :]
    return torch.as_tensor(rooms.crosses_wall(a, z), device=x.device)


class WallAwareGeodesicKernel(GeodesicKernel):
    """:class:`~sb3_geogp.GeodesicKernel` whose attachments never cross the walls of ``rooms``.

    Identical to the geodesic kernel except :meth:`blocked`: a pair is blocked where
    :func:`blocked_pairs` says so (the kernel's inputs are scaled, so they are taken back to
    state units by the lengthscale first).

    Parameters
    ----------
    lengthscale : float, sequence of float or None
    rooms : Obstacles
        The geometry whose walls attachments may not cross.
    **options
        Further :class:`~sb3_geogp.GeodesicKernel` options.
    """

    def __init__(
        self, lengthscale: float | Sequence[float] | None, rooms: Obstacles, **options: Any
    ) -> None:
        super().__init__(lengthscale, **options)
        self.rooms = rooms

    def blocked(self, x: Tensor, z: Tensor) -> Tensor | None:  # a subclass may know no walls
        return blocked_pairs(self.rooms, x * self.lengthscale, z * self.lengthscale)
