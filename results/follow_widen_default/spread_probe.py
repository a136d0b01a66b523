"""How the spread of the GP critic's inputs moves during PPO training (session 83,
descriptive): at every refit of the default critic with ``follow_spread`` off (0.39-0.42's
default), each input whose lengthscale the first batch chose, the window's standard deviation
over that start (the first batch's standard deviation)::

    python results/follow_widen_default/spread_probe.py > results/follow_widen_default/spread.md

Runs: PPO CartPole-v1 with issue 13's table protocol (the zoo's entry, 30,000 steps), seeds 0
and 1; PPO InvertedPendulum-v5 as the held-out study trains it (``results/heldout_noise``'s
default GP arm, 50,000 steps), seed 1023. Wraps ``SparseOnlineGP._refit`` to read, changes
nothing.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path
from typing import Any

import torch as th

from sb3_geogp import GPValueCallback, defaults
from sb3_geogp.comparison.hyperparams import GP_KWARGS, hyperparams, threshold
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.specs import RunSpec
from sb3_geogp.policies import DEFAULT_ADAPTATION
from sb3_geogp.sparse_gp import SparseOnlineGP
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
HELDOUT = load_script(HERE.parent / "heldout_noise" / "run.py", "heldout_noise_run")
#: 0.39-0.42's PPO default: no input follows the spread.
STILL = {"adapt": dataclasses.replace(DEFAULT_ADAPTATION, follow_spread=False).as_dict()}
RUNS = (("CartPole-v1", 0), ("CartPole-v1", 1), ("InvertedPendulum-v5", 1023))


def ratios(env_id: str, seed: int) -> tuple[list[bool], list[list[float]]]:
    """Which inputs the first batch chose, and at each refit their window spread / start."""
    rows: list[list[float]] = []
    refit = SparseOnlineGP._refit

    def reading(gp: SparseOnlineGP, *args: Any) -> None:
        chosen = gp.ls_from_data
        rows.append((defaults.default_lengthscale(args[1]) / gp.ls_start)[chosen].tolist())
        refit(gp, *args)

    SparseOnlineGP._refit = reading  # type: ignore[method-assign]
    try:
        model, steps = build(env_id, seed)
        model.learn(steps, callback=[GPValueCallback()])
    finally:
        SparseOnlineGP._refit = refit  # type: ignore[method-assign]
    return model.policy.gp.ls_from_data.tolist(), rows


def build(env_id: str, seed: int) -> tuple[Any, int]:
    """The run's model and its steps."""
    if env_id == "CartPole-v1":
        entry = hyperparams("ppo", env_id)
        options = tuple(sorted({**GP_KWARGS, **STILL}.items()))  # as `sb3-geogp compare`'s
        spec = RunSpec("ppo", "laplacian", env_id, seed, 30_000, gp_kwargs=options,
                       hyperparams=entry.values, hyperparams_source=entry.source,
                       threshold=threshold(env_id, None))  # fmt: skip
        return build_model(spec), spec.total_timesteps
    arm = dataclasses.replace(HELDOUT.ARMS["gp_actor_normalized"], gp_kwargs=STILL)
    model, _ = HELDOUT.build(arm, seed)
    return model, HELDOUT.STEPS


def main() -> None:
    warnings.filterwarnings("ignore", category=UserWarning)
    th.set_num_threads(1)
    print("# The window's spread over the first batch's, at each refit (session 83)\n")
    print("The default critic with `follow_spread` off; one row per refit, one column per")
    print("input whose lengthscale the first batch chose (observation index).\n")
    for env_id, seed in RUNS:
        chosen, rows = ratios(env_id, seed)
        inputs = [i for i, c in enumerate(chosen) if c]
        print(f"## {env_id}, seed {seed}\n")
        print("| refit | " + " | ".join(f"input {i}" for i in inputs) + " |")
        print("|---:|" + "---:|" * len(inputs))
        for k, row in enumerate(rows):
            print(f"| {k} | " + " | ".join(f"{v:.2f}" for v in row) + " |")
        print()


if __name__ == "__main__":
    main()
