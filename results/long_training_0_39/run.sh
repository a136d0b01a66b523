#!/usr/bin/env bash
# Session 79's long training runs with 0.39's defaults, one after the other, nothing else
# running (from a worktree of f7307afa); summary.txt is their printed summaries.
set -euo pipefail
OUT=${OUT:-results/long_training_0_39}
python examples/long_training_run.py --algo ppo --env Pendulum-v1 --timesteps 1000000 --no-progress --out "$OUT/ppo_pendulum_1m"
python examples/long_training_run.py --algo a2c --env CartPole-v1 --timesteps 1000000 --no-progress --out "$OUT/a2c_cartpole_1m"
python examples/long_training_run.py --algo ppo --env CartPole-v1 --timesteps 500000 --no-progress --out "$OUT/ppo_cartpole_500k"
python examples/long_training_run.py --algo ppo --env Acrobot-v1 --timesteps 500000 --no-progress --out "$OUT/ppo_acrobot_500k"
python results/long_training_0_39/memtrace.py 250000 100000 > "$OUT/memtrace.txt"
