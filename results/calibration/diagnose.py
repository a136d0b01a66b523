"""Why A2C's RBF critic is overconfident on the fixed-policy pendulum: diagnostics on streams 0
and 1, not a planned reading (docs/results.md, "The GP critic's error bars")::

    python results/calibration/diagnose.py > results/calibration/diagnose.md

For each drop-in critic at 200 basis vectors, and for A2C's with a novelty tolerance of 1e-4
and 1e-5 instead of its default (about 0.06, the RBF kernel's novelty at a quarter of a
lengthscale): basis vectors kept, fitted lengthscales (angle, velocity), RMSE and ``z_rms``
against the Monte Carlo value on the grid.
"""

from __future__ import annotations

from pathlib import Path

import torch
from stable_baselines3 import A2C, PPO

from sb3_geogp.studies.pendulum.batch_check import feed_stream, stream
from sb3_geogp.studies.pendulum.ground_truth import mc_value
from sb3_geogp.studies.pendulum.task import Task
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.tables import markdown_table

CALIBRATION = load_script(Path(__file__).with_name("calibration.py"), "calibration")
STREAMS = (0, 1)
#: Critic -> (algorithm, extra gp_kwargs).
CRITICS = {
    "ppo drop-in": (PPO, {}),
    "a2c drop-in": (A2C, {}),
    "a2c drop-in, novelty_tol 1e-4": (A2C, {"novelty_tol": 1e-4}),
    "a2c drop-in, novelty_tol 1e-5": (A2C, {"novelty_tol": 1e-5}),
}


def main() -> None:
    torch.set_num_threads(1)
    task, config = Task(), CALIBRATION.check_config()
    truth = mc_value(task, config.grid_n, config.mc_rollouts)
    states, _, _ = task.grid(truth.n)
    rows = []
    for name, (algo, extra) in CRITICS.items():
        for seed in STREAMS:
            gp = CALIBRATION.drop_in_critic(algo, task, 200, extra)
            feed_stream(gp, stream(task, config, seed), config.episodes_per_batch)
            mean, var = gp.predict(states)
            assert var is not None
            s = CALIBRATION.scores(mean.numpy(), var.numpy(), truth.value, truth.stderr)
            lengthscale = ", ".join(f"{x:.2f}" for x in gp.lengthscale.tolist())
            rows.append(
                [name, str(seed), str(gp.n_basis), lengthscale]
                + [f"{s[k]:.2f}" for k in ("rmse", "z_rms")]
                + [f"{s['coverage']['0.95']:.3f}"]
            )
    header = ["critic", "stream", "basis vectors", "lengthscales", "RMSE", "z_rms", "95 %"]
    print(markdown_table(header, rows, align="llrlrrr"))


if __name__ == "__main__":
    main()
