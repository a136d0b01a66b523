"""Exploratory (session 55, not adopted): A2C's GP update in a background thread, joined before
the GP is next read, against the plain callback; A2C CartPole-v1, zoo hyperparameters, A2C's
default critic, 30,000 steps, one torch thread, the two callbacks interleaved per seed::

    python docs/benchmarks/a2c_thread/overlap.py > docs/benchmarks/a2c_thread/overlap.txt

The thread starts at each rollout's end with the GP update and is joined by the first
``predict_values`` after it (SB3 reads the critic at time-limit truncations and for the last
observation of every rollout) or at the training's end. Each line gives the wall clock, two
values of the trained critic and three sums of actor parameters: equal lines are the same run.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import A2C
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.callbacks import env_major, per_env
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams


class ThreadedCallback(GPValueCallback):
    """``GPValueCallback`` (SB3's returns as targets, A2C's default) whose GP update runs in a
    thread while SB3 trains the actor and collects the next rollout."""

    def _init_callback(self) -> None:
        super()._init_callback()
        self._thread: threading.Thread | None = None
        self._stats: dict[str, float] = {}
        policy = self._policy
        predict_values = policy.predict_values

        def joined_first(obs: th.Tensor) -> th.Tensor:
            self._join()
            return predict_values(obs)

        policy.predict_values = joined_first  # type: ignore[method-assign,assignment]

    def _join(self) -> None:
        if self._thread is None:
            return
        self._thread.join()
        self._thread = None
        # the update marked the rollout fed; the rollout collected since is not
        self._policy._awaiting_feed = True
        for key, value in self._stats.items():
            self.logger.record(f"gp/{key}", value)

    def _on_rollout_end(self) -> None:
        self._join()
        super()._on_rollout_end()

    def _feed_held(self, policy: Any) -> dict[str, float]:
        held, self._held = self._held, []
        obs, returns, starts, values = (np.concatenate(a) for a in zip(*held, strict=True))
        self._fed[1] += len(returns)

        def update() -> None:
            self._stats = policy.update_critic(*per_env(obs, returns, starts), env_major(values))

        policy._awaiting_feed = False
        self._thread = threading.Thread(target=update)
        self._thread.start()
        return {}

    def _on_training_end(self) -> None:
        self._join()
        super()._on_training_end()


def run(callback: type[GPValueCallback], seed: int) -> str:
    n_envs, kwargs, policy_kwargs = algo_kwargs("a2c", hyperparams("a2c", "CartPole-v1").values)
    env = make_vec_env("CartPole-v1", n_envs=n_envs, seed=seed)
    policy_kwargs = {**policy_kwargs, "gp_kwargs": dict(kernel="rbf", max_basis=256, adapt=True)}
    model = A2C(GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
    start = time.perf_counter()
    model.learn(30_000, callback=callback())
    wall = time.perf_counter() - start
    obs = th.as_tensor(np.random.default_rng(0).normal(size=(2, 4)), dtype=th.float32)
    values = model.policy.predict_values(obs).flatten().tolist()
    sums = [float(p.detach().sum()) for p in list(model.policy.parameters())[:3]]
    return f"{callback.__name__:17s} seed {seed}  {wall:5.2f} s  values {values}  sums {sums}"


def main() -> None:
    th.set_num_threads(1)
    for seed in (0, 1):
        for callback in (GPValueCallback, ThreadedCallback):
            print(run(callback, seed), flush=True)


if __name__ == "__main__":
    main()
