#!/usr/bin/env bash
# Exploratory, after PLAN.md's registered runs (session 85): lengthscale_rule="distance" on issue
# 13's seven PPO cells, seeds 0-9, paired by seed with the stored default runs (read.py --table;
# those runs reproduce bit for bit at this commit: Pendulum-v1, CartPole-v1, Acrobot-v1 seed 0).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$HERE}
sb3-geogp compare --algos ppo --critics laplacian --seeds 10 --first-seed 0 --workers 2 \
    --no-progress --no-plots --gp-option lengthscale_rule=distance --out "$OUT/table_screen" \
    --envs Pendulum-v1 CartPole-v1 Acrobot-v1 sb3_geogp/PaperPendulum-v0 \
    MountainCarContinuous-v0 sb3_geogp/WallMaze-v0 sb3_geogp/WallMazeDiscrete-v0
echo "table screen done $(date -u)"
