"""How much of their observation bounds the comparison's tasks fill once the GP critic has been
fed 10,000 observations: the margin of the loose-bounds warning (``sb3_geogp.defaults.
BoundsCoverage``, warning under 5 %), session 55::

    python results/loose_bounds/coverage.py > results/loose_bounds/coverage.md

Each of the 14 cells of the comparison (zoo hyperparameters, the drop-in's default critic),
seeds 0-2, trained until the GP has been fed 10,000 observations; per bounded dimension the
range of those observations over its bounds' width (the warning's share), its minimum over the
dimensions, and whether the warning was raised.
"""

from __future__ import annotations

import warnings
from typing import Any

import torch
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env

import sb3_geogp.envs  # noqa: F401  (registers the package's environments)
from sb3_geogp import GPActorCriticPolicy, GPCriticWarning, GPValueCallback
from sb3_geogp.comparison.hyperparams import ENVS, algo_kwargs, hyperparams
from sb3_geogp.defaults import COVERAGE_POINTS, BoundsCoverage
from sb3_geogp.toolbox.tables import markdown_table

ALGOS: dict[str, Any] = {"ppo": PPO, "a2c": A2C}
SEEDS = (0, 1, 2)


class UntilChecked(BaseCallback):
    """Stops training once the bounds check has run (one ``learn`` call, so the Monte Carlo
    targets are fed as in any run)."""

    def __init__(self, coverage: BoundsCoverage) -> None:
        super().__init__()
        self.coverage = coverage

    def _on_step(self) -> bool:
        return not self.coverage.checked


def shares(algo: str, env_id: str, seed: int) -> tuple[list[float], bool, int]:
    """The bounded dimensions' shares once 10,000 observations were fed, whether the warning
    came, and the steps it took."""
    n_envs, kwargs, policy_kwargs = algo_kwargs(algo, hyperparams(algo, env_id).values)
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
    model = ALGOS[algo](GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
    coverage = model.policy.gp._coverage
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GPCriticWarning)
        model.learn(1_000_000, callback=[GPValueCallback(), UntilChecked(coverage)])
    assert coverage.checked, "stopped before the check"
    warned = any(issubclass(w.category, GPCriticWarning) and "bounds" in str(w.message)
                 for w in caught)  # fmt: skip
    # no lengthscale given: every bounded dimension took its lengthscale from the bounds
    bounded = coverage.from_bounds
    span = coverage.seen_high[bounded] - coverage.seen_low[bounded]
    share = span / (coverage.high[bounded] - coverage.low[bounded])
    return share.tolist(), warned, model.num_timesteps


def main() -> None:
    torch.set_num_threads(1)
    rows = []
    lowest = 1.0
    for algo in ALGOS:
        for env_id in ENVS:
            per_seed = [shares(algo, env_id, seed) for seed in SEEDS]
            low = min(min(s) for s, _, _ in per_seed)
            lowest = min(lowest, low)
            rows.append([
                algo, f"`{env_id}`", str(max(steps for _, _, steps in per_seed)),
                " / ".join(", ".join(f"{x:.2f}" for x in s) for s, _, _ in per_seed),
                f"{low:.2f}", str(sum(w for _, w, _ in per_seed)),
            ])  # fmt: skip
    header = ["algo", "env", "steps (at most)", "share of each bounded dimension, seeds 0 / 1 / 2",
              "lowest", "warned (runs)"]  # fmt: skip
    print(f"## Share of the observation bounds filled after {COVERAGE_POINTS:,} observations fed\n")
    print(markdown_table(header, rows))
    print(f"\nlowest share over all cells, seeds and dimensions: {lowest:.2f}")


if __name__ == "__main__":
    main()
