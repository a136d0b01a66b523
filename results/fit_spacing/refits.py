"""How often PPO CartPole-v1's GP critic refits, with and without the fit spacing (session 78,
descriptive): per run (zoo hyperparameters, 30,000 steps, seeds 0-9, the registered test's
critic-fit seeds), the blocks closed, the refits (each change of the GP's ``refit_seen``) and
the blocks whose out-of-sample fit fell below the floor (``gp/block_fit`` < 0.8), for 0.38's
default (no spacing) and 0.39's (4,096)::

    python results/fit_spacing/refits.py > results/fit_spacing/refits.md
"""

from __future__ import annotations

import dataclasses
import statistics
from typing import Any

from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams
from sb3_geogp.policies import DEFAULT_ADAPTATION

ARMS = {
    "0.38 (no spacing)": dataclasses.replace(DEFAULT_ADAPTATION, fit_spacing=None),
    "0.39 (4,096)": DEFAULT_ADAPTATION,
}
SEEDS = range(10)
STEPS = 30_000
FLOOR = DEFAULT_ADAPTATION.fit_floor


class RefitCounter(BaseCallback):
    """After the feed of each rollout: whether a block closed, whether the GP refitted, and
    the closed block's fit."""

    def __init__(self) -> None:
        super().__init__()
        self.blocks = self.refits = self.below = 0
        self._seen = self._closed = 0  # the GP's counters before its first feed

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        gp = self.model.policy.gp
        blocks, seen = int(gp.n_blocks), int(gp.refit_seen)
        if blocks > self._closed:
            self.blocks += blocks - self._closed
            fit = gp.last_stats.get("block_fit")
            self.below += fit is not None and fit < FLOOR
        self.refits += seen != self._seen
        self._closed, self._seen = blocks, seen


def run(adapt: Any, seed: int) -> RefitCounter:
    n_envs, kwargs, policy_kwargs = algo_kwargs("ppo", hyperparams("ppo", "CartPole-v1").values)
    env = make_vec_env("CartPole-v1", n_envs=n_envs, seed=seed)
    policy_kwargs = {**policy_kwargs, "gp_kwargs": {"adapt": adapt}}
    model = PPO(GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
    counter = RefitCounter()
    model.learn(STEPS, callback=CallbackList([GPValueCallback(), counter]))
    return counter


def main() -> None:
    print("| PPO CartPole-v1, seeds 0-9 | blocks closed | refits | blocks below the floor |")
    print("|---|---:|---:|---:|")
    for name, adapt in ARMS.items():
        counts = [run(adapt, seed) for seed in SEEDS]
        cells = [
            statistics.mean(getattr(c, k) for c in counts) for k in ("blocks", "refits", "below")
        ]
        ranges = [(min(getattr(c, k) for c in counts), max(getattr(c, k) for c in counts))
                  for k in ("blocks", "refits", "below")]  # fmt: skip
        texts = [f"{m:.1f} ({lo}-{hi})" for m, (lo, hi) in zip(cells, ranges, strict=True)]
        print(f"| {name} | " + " | ".join(texts) + " |")
    print("\n(mean over seeds, range in brackets)")


if __name__ == "__main__":
    main()
