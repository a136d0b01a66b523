"""Does A2C CartPole-v1's resident memory grow late in a long run with SB3's MLP critic too?
(session 80; the control for session 79's long GP run)

Session 79's 1,000,000-step A2C CartPole-v1 run with the default GP critic
(``results/long_training_0_39/a2c_cartpole_1m``: 4 envs, seed 0, one torch thread) gained
resident memory after 300,000 steps, and ``memtrace.py`` found it in no Python object and no
tensor of the GP critic. This trains the same run with SB3's ``MlpPolicy`` instead (nothing
else changed), reads the resident memory every 20 rollouts as that run did, and prints both
runs' growth: a least-squares slope over the steps after 300,000, and the lowest reading of
the last tenth against the lowest of the tenth after 300,000::

    python results/memory_control/mlp_memory.py > results/memory_control/mlp_memory.txt
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import A2C
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "examples"))
from long_training_run import resident_mib  # noqa: E402

GP_RUN = ROOT / "results" / "long_training_0_39" / "a2c_cartpole_1m"
STEPS = 1_000_000
EVERY = 20  # rollouts, as the GP run's record
FROM = 300_000


def rss_reading(steps: int) -> tuple[float, ...]:
    """Steps and resident MiB."""
    return steps, resident_mib()


class Memory(BaseCallback):
    """``reading(steps)`` every ``EVERY`` rollouts (by default the steps and resident memory)."""

    def __init__(self, reading: Callable[[int], tuple[float, ...]] = rss_reading) -> None:
        super().__init__()
        self.reading = reading
        self.rows: list[tuple[float, ...]] = []
        self._rollouts = 0

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        if self._rollouts % EVERY == 0:
            self.rows.append(self.reading(self.num_timesteps))
        self._rollouts += 1


def long_run_readings(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """Steps and resident MiB of the rollouts where ``examples/long_training_run.py`` (its
    ``long_training_run.json`` in ``folder``) read the memory."""
    rows = json.loads((folder / "long_training_run.json").read_text())["per_rollout"]
    read = [(t, m) for t, m in zip(rows["timesteps"], rows["resident_mib"], strict=True)
            if m is not None]  # fmt: skip
    steps, mib = (np.array(c, dtype=float) for c in zip(*read, strict=True))
    return steps, mib


def growth(steps: np.ndarray, mib: np.ndarray) -> str:
    """Slope per 100,000 steps after ``FROM``, and lowest reading, tenth after ``FROM`` against
    the last tenth."""
    late = steps >= FROM
    s, m = steps[late], mib[late]
    slope = np.polyfit(s, m, 1)[0] * 100_000
    tenth = STEPS // 10
    first = m[s < FROM + tenth].min()
    last = m[s >= STEPS - tenth].min()
    return (
        f"{slope:+.2f} MiB per 100,000 steps; lowest {first:.1f} MiB in "
        f"[{FROM:,}, {FROM + tenth:,}), {last:.1f} MiB in the last tenth ({last - first:+.1f})"
    )


def main() -> None:
    torch.set_num_threads(1)
    env = make_vec_env("CartPole-v1", n_envs=4, seed=0)
    model = A2C("MlpPolicy", env, seed=0)
    memory = Memory()
    model.learn(STEPS, callback=memory)
    steps, mib = (np.array(c, dtype=float) for c in zip(*memory.rows, strict=True))
    gp_steps, gp_mib = long_run_readings(GP_RUN)
    print(f"A2C CartPole-v1, 4 envs, seed 0, {STEPS:,} steps, resident memory every {EVERY} "
          "rollouts\n")  # fmt: skip
    print(f"- SB3's MLP critic (this run): {mib[0]:.1f} MiB at the start; "
          + growth(steps, mib))  # fmt: skip
    print(f"- default GP critic (session 79's run): {gp_mib[0]:.1f} MiB at the start; "
          + growth(gp_steps, gp_mib))  # fmt: skip


if __name__ == "__main__":
    main()
