"""Environments that only the tests know, registered when gymnasium imports this module.

``sb3-geogp compare --envs tests.comparison.toy_env:ToyEnv-v0`` makes gymnasium import it in
the command's process and in every worker, as a user's ``my_pkg.envs:MyEnv-v0`` would be.
"""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import numpy as np

#: Text of the warning that ``ToyEnvWarns-v0`` raises when it is made.
WARNING = "ToyEnvWarns: the same warning in every run"


class ToyEnv(gym.Env[np.ndarray, np.int64]):
    """A point on a line, pushed left or right; reward: minus its distance from 0.5."""

    observation_space = gym.spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, warn: bool = False) -> None:
        if warn:
            warnings.warn(WARNING, UserWarning, stacklevel=2)
        self.x = 0.0

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.x = float(self.np_random.uniform(-1.0, 1.0))
        return np.array([self.x], dtype=np.float32), {}

    def step(self, action: np.int64) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self.x = float(np.clip(self.x + (0.1 if action == 1 else -0.1), -1.0, 1.0))
        return np.array([self.x], dtype=np.float32), -abs(self.x - 0.5), False, False, {}


gym.register("ToyEnv-v0", entry_point=ToyEnv, max_episode_steps=20)
gym.register(
    "ToyEnvWarns-v0",
    entry_point=ToyEnv,
    max_episode_steps=20,
    reward_threshold=-2.0,
    kwargs=dict(warn=True),
)
gym.register("ToyEnvEndless-v0", entry_point=ToyEnv)
