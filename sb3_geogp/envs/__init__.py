"""Gymnasium environments of sb3_geogp; importing this package registers them.

* ``sb3_geogp/PaperPendulum-v0``: :class:`PaperPendulum`, the paper's pendulum task
  (150-step episodes).
* ``sb3_geogp/WallMaze-v0`` / ``sb3_geogp/WallMazeDiscrete-v0``: :class:`WallMaze`, 2-D
  navigation through walls, continuous or 8-direction actions;
  ``sb3_geogp/WallMazeCorner-v0``: continuous, moves slide along walls, goal in the corner;
  ``sb3_geogp/WallMazeDoor-v0``: continuous, sliding, one wall with a door.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from sb3_geogp.envs.pendulum import (
    PaperPendulum,
    PendulumParams,
    dynamics_step,
    energy,
    reward,
    wrap_angle,
)
from sb3_geogp.envs.wall_maze import (
    WALL_MAZE_CORNER_ID,
    WALL_MAZE_DISCRETE_ID,
    WALL_MAZE_DOOR_ID,
    WALL_MAZE_ID,
    MazeLayout,
    WallMaze,
    WallMazeDiscrete,
    register_wall_maze,
)

PAPER_PENDULUM_ID = "sb3_geogp/PaperPendulum-v0"

if PAPER_PENDULUM_ID not in registry:
    register(
        id=PAPER_PENDULUM_ID,
        entry_point="sb3_geogp.envs.pendulum:PaperPendulum",
        max_episode_steps=PendulumParams().episode_length,
    )

register_wall_maze()

__all__ = [
    "PAPER_PENDULUM_ID",
    "WALL_MAZE_CORNER_ID",
    "WALL_MAZE_DISCRETE_ID",
    "WALL_MAZE_DOOR_ID",
    "WALL_MAZE_ID",
    "MazeLayout",
    "PaperPendulum",
    "PendulumParams",
    "WallMaze",
    "WallMazeDiscrete",
    "dynamics_step",
    "energy",
    "register_wall_maze",
    "reward",
    "wrap_angle",
]
