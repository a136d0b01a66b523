"""Pendulum-v1 with loose observation bounds: what the GP critic fits, and the lengthscales the
loose-bounds warning suggests (session 55, docs/usage.md "What the policy supports")::

    python results/loose_bounds/loose_bounds.py > results/loose_bounds/loose_bounds.txt

PPO (``n_steps=512``, ``gamma=0.9``, 4 environments, seed 0, 12,288 steps) with the default GP
critic, the environment declaring its observations in its true bounds, in +-8 and in +-100
(every dimension; nothing else changes), and in +-100 with the lengthscales the warning
suggests. Each line: the critic's out-of-sample explained variance per rollout
(``gp/explained_variance``), its basis vectors and lengthscales at the end, and whether the
warning was raised.
"""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPCriticWarning, GPValueCallback

#: Case -> (declared bound on every dimension, None: the true ones; lengthscales given).
CASES: dict[str, tuple[float | None, list[float] | None]] = {
    "true bounds": (None, None),
    "+-8": (8.0, None),
    "+-100": (100.0, None),
    "+-100, suggested lengthscales": (100.0, [0.577, 0.577, 4.619]),
}


class DeclaredBounds(gym.ObservationWrapper):
    """Pendulum-v1 declaring its observations in ``+-bound``; the observations are unchanged."""

    def __init__(self, env: gym.Env, bound: float) -> None:
        super().__init__(env)
        self.observation_space = spaces.Box(-bound, bound, shape=(3,), dtype=np.float32)

    def observation(self, observation: Any) -> Any:
        return observation


class ExplainedVariance(BaseCallback):
    """``gp/explained_variance`` of every rollout, as GPValueCallback (listed before) logs it."""

    def __init__(self) -> None:
        super().__init__()
        self.values: list[float] = []

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self.values.append(self.logger.name_to_value["gp/explained_variance"])


def run(bound: float | None, lengthscale: list[float] | None) -> str:
    wrapper = (
        {}
        if bound is None
        else dict(wrapper_class=DeclaredBounds, wrapper_kwargs=dict(bound=bound))
    )
    env = make_vec_env("Pendulum-v1", n_envs=4, seed=0, **wrapper)  # type: ignore[arg-type]
    gp_kwargs = {} if lengthscale is None else dict(kernel_kwargs=dict(lengthscale=lengthscale))
    model = PPO(
        GPActorCriticPolicy,
        env,
        n_steps=512,
        gamma=0.9,
        seed=0,
        policy_kwargs=dict(gp_kwargs=gp_kwargs),
    )
    recorder = ExplainedVariance()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GPCriticWarning)
        model.learn(12_288, callback=[GPValueCallback(), recorder])
    warned = any(issubclass(w.category, GPCriticWarning) for w in caught)
    assert isinstance(model.policy, GPActorCriticPolicy)
    gp = model.policy.gp
    return (
        f"explained variance {np.round(recorder.values, 2).tolist()}; {gp.n_basis} basis vectors; "
        f"lengthscales {np.round(gp.kernel.lengthscale.numpy(), 3).tolist()}; warned: {warned}"
    )


def main() -> None:
    torch.set_num_threads(1)
    for name, case in CASES.items():
        print(f"{name}: {run(*case)}", flush=True)


if __name__ == "__main__":
    main()
