"""``PLAN.md``: exact GPs with independent and with Monte Carlo GPTD noise on the batches the
drop-in PPO default's GP critic is fed on Acrobot-v1, recorded by
``results/actor_features/run.py`` into ``STREAMS`` (one call per core)::

    python results/return_noise/run.py --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/return_noise/a
    python results/return_noise/run.py --seeds 1 3 5 7 9 --streams STREAMS \\
        --out results/return_noise/b
    python results/return_noise/read.py --plot results/return_noise/read.png \\
        > results/return_noise/read.md
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np
import torch as th

from sb3_geogp.studies.return_noise import episode_steps, fit_exact_gp, trajectory_noise
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RECORDING = load_script(HERE.parent / "actor_features" / "run.py", "recording")
SCHEDULE = RECORDING.SCHEDULE
ENV = RECORDING.ENV
#: The recorded runs' discount (rl-baselines3-zoo's Acrobot-v1 entry).
GAMMA = 0.99
#: Most points each GP is fitted and conditioned on (``PLAN.md``).
MAX_POINTS = 1024
NOISES = ("independent", "gptd")


def thinned(starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every k-th step of every episode, ``k`` the smallest leaving at most
    :data:`MAX_POINTS` points: their indices and their GPTD noise correlation."""
    episode, step, length = episode_steps(starts)
    k = max(1, -(-len(step) // MAX_POINTS))
    while np.count_nonzero(step % k == 0) > MAX_POINTS:
        k += 1
    keep = np.flatnonzero(step % k == 0)
    return keep, trajectory_noise(episode[keep], step[keep], length[keep], GAMMA)


def replay(batches: list[Any], noise: str) -> dict[str, Any]:
    """The exact GP with ``noise`` on the newest batch, scored as ``adaptation_schedule.py``
    scores; its fitted noise and signal variances per prediction."""
    kept: list[Any] = []
    fitted: list[dict[str, float]] = []

    def predict(x: th.Tensor) -> th.Tensor:
        inputs, targets, starts = kept[-1]
        keep, shape = thinned(starts)
        fit = fit_exact_gp(inputs[keep], targets[keep], shape if noise == "gptd" else None)
        fitted.append(dict(noise_var=fit.noise_var, signal_var=fit.signal_var, points=len(keep)))
        return th.as_tensor(fit.predict(x.double().numpy()))

    def learn(x: th.Tensor, y: th.Tensor, starts: th.Tensor | None) -> None:
        assert starts is not None, "the Monte Carlo feed flags episode starts"
        kept[:] = [(x.double().numpy(), y.double().numpy(), starts.numpy())]

    return dict(fitted=fitted, **SCHEDULE._scored(batches, predict, learn))


def main() -> None:
    replays = {noise: functools.partial(replay, noise=noise) for noise in NOISES}
    RECORDING.run_replays(__doc__, replays, {"gamma": GAMMA, "max_points": MAX_POINTS})


if __name__ == "__main__":
    main()
