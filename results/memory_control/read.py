"""The resident memory of the two 1,000,000-step A2C CartPole-v1 runs of
``examples/long_training_run.py`` (default GP critic, 4 envs, seed 0), read as
``mlp_memory.py`` reads its own run (session 80)::

    python results/memory_control/read.py > results/memory_control/read.md

- session 79's, whose per-rollout record was a list of dicts
  (``results/long_training_0_39/a2c_cartpole_1m``);
- session 80's, the record preallocated (``long_run_preallocated``, made by
  ``python examples/long_training_run.py --algo a2c --env CartPole-v1 --timesteps 1000000
  --no-progress --out results/memory_control/long_run_preallocated``).
"""

from __future__ import annotations

from pathlib import Path

from mlp_memory import growth, long_run_readings

HERE = Path(__file__).resolve().parent
RUNS = {
    "session 79 (a list of dicts)": HERE.parent / "long_training_0_39" / "a2c_cartpole_1m",
    "session 80 (preallocated)": HERE / "long_run_preallocated",
}


def main() -> None:
    print("| run's record | memory at the start | growth after 300,000 steps |")
    print("|---|---:|---|")
    for name, folder in RUNS.items():
        steps, mib = long_run_readings(folder)
        print(f"| {name} | {mib[0]:.1f} MiB | {growth(steps, mib)} |")


if __name__ == "__main__":
    main()
