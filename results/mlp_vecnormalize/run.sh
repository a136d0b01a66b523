#!/usr/bin/env bash
# The runs of PREREGISTRATION.md, in its order: SB3's MLP critic in the zoo's VecNormalize,
# on the seeds of issue 13's 50-seed table, in the five cells whose zoo entry normalises.
# Run from a worktree of the registered commit with sb3_geogp importable; OUT is this folder
# (default: next to this script). Seeds 0-19 of every cell first, then the rest.
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
ppo() {  # first seed, number of seeds
    sb3-geogp compare --algos ppo --envs MountainCarContinuous-v0 Acrobot-v1 --critics mlp \
        --mlp-normalize --seeds "$2" --first-seed "$1" --workers 2 --no-progress --no-plots \
        --out "$OUT/ppo"
}
a2c() {
    sb3-geogp compare --algos a2c --envs Pendulum-v1 MountainCarContinuous-v0 Acrobot-v1 \
        --critics mlp --mlp-normalize --seeds "$2" --first-seed "$1" --workers 2 --no-progress \
        --no-plots --out "$OUT/a2c"
}
a2c 0 20
ppo 0 20
a2c 30 10
a2c 70 10
a2c 570 10
ppo 150 20
ppo 570 10
echo "all runs done $(date -u)"
