"""Why some of 0.25's 100,000-step Acrobot runs never swing up (session 45, exploratory).

Re-runs the seeds whose 0.25 runs stay at -500 at every checkpoint while 0.24's reach the
threshold (265 and 276 of ``../budget100k_0_25``, 345 of the test here), under both arms (0.25: Monte Carlo returns cut after
200 steps; 0.24: uncut), exactly as the sweep ran them, with a recorder that changes nothing:
per rollout, the training episodes that ended and those that reached the goal (fewer than 500
steps), and the spread (standard deviation over the rollout) of the critic's values and of the
advantages PPO normalises.

    python results/acrobot100k_cut/trace.py > results/acrobot100k_cut/trace.md
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from sb3_geogp.comparison.run import run_one
from sb3_geogp.comparison.specs import SweepConfig
from sb3_geogp.comparison.report import pyplot

HERE = Path(__file__).resolve().parent
SEEDS = (265, 276, 345)
STYLES = dict(zip(SEEDS, ("-", "--", ":"), strict=True))
ARMS = {"0.25": None, "0.24": "monte_carlo"}
COLOURS = {"0.25": "tab:purple", "0.24": "tab:green"}


class Trace(BaseCallback):
    """Per rollout: training episodes ended and reaching the goal, spread of values and
    advantages."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, float]] = []
        self._lengths: list[int] = []

    def _on_step(self) -> bool:
        self._lengths += [
            info["episode"]["l"] for info in self.locals["infos"] if "episode" in info
        ]
        return True

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer
        self.rows.append(
            dict(
                steps=self.num_timesteps,
                episodes=len(self._lengths),
                goals=sum(n < 500 for n in self._lengths),
                value_sd=float(buffer.values.std()),
                advantage_sd=float(buffer.advantages.std()),
            )
        )
        self._lengths = []


def trace(seed: int, target: str | None) -> tuple[float, list[dict[str, float]]]:
    """Final return and per-rollout rows of one arm's run on ``seed``."""
    config = SweepConfig(
        algos=("ppo",), critics=("laplacian",), envs=("Acrobot-v1",), seeds=(seed,),
        timesteps=100_000, target=target,  # type: ignore[arg-type]
    )  # fmt: skip
    recorder = Trace()
    with tempfile.TemporaryDirectory() as out:
        result = run_one(config.specs()[0], out, recorders=[recorder])
    return result["final_return"], recorder.rows


def first(rows: list[dict[str, float]], test: Any) -> str:
    hit = [r["steps"] for r in rows if test(r)]
    return f"{hit[0]:,}" if hit else "never"


def frozen_from(rows: list[dict[str, float]]) -> str:
    """The first rollout from which every advantage is the same (spread 0) to the end."""
    moving = [i for i, r in enumerate(rows) if r["advantage_sd"] > 0]
    after = moving[-1] + 1 if moving else 0
    return f"{rows[after]['steps']:,}" if after < len(rows) else "never"


def main() -> None:
    traces = {(arm, s): trace(s, t) for arm, t in ARMS.items() for s in SEEDS}
    (HERE / "trace.json").write_text(json.dumps({f"{a} s{s}": v for (a, s), v in traces.items()}))
    print("| arm | seed | final return | first rollout with a goal | goals in training | "
          "advantages all equal from | advantage spread, rollouts 2-4 |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|---|")
    for (arm, seed), (final, rows) in traces.items():
        early = ", ".join(f"{r['advantage_sd']:.3g}" for r in rows[1:4])
        print(f"| {arm} | {seed} | {final:.1f} | {first(rows, lambda r: r['goals'] > 0)} | "
              f"{sum(r['goals'] for r in rows)} | {frozen_from(rows)} | "
              f"{early} |")  # fmt: skip
    plot(traces, HERE / "trace.png")


def plot(traces: dict[tuple[str, int], tuple[float, list[dict[str, float]]]], path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for (arm, seed), (_, rows) in traces.items():
        steps = np.array([r["steps"] for r in rows])
        style = dict(color=COLOURS[arm], ls=STYLES[seed], label=f"{arm}, seed {seed}")
        axes[0].plot(steps, [max(r["advantage_sd"], 1e-8) for r in rows], **style)
        axes[1].plot(steps, np.cumsum([r["goals"] for r in rows]), **style)
    axes[0].set(yscale="log", ylabel="advantage sd in the rollout (0 at 1e-8)")
    axes[1].set(ylabel="training episodes at the goal, total")
    for ax in axes:
        ax.set(xlabel="timesteps")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle("PPO Acrobot-v1, default GP critic: 0.25 (cut after 200 steps) and 0.24 (uncut)",
                 fontsize=10)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
