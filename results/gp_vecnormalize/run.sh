#!/usr/bin/env bash
# The runs of PLAN.md: the default GP critic in the zoo's VecNormalize, seeds 0-19, in the
# five cells whose zoo entry normalises. OUT is this folder (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
sb3-geogp compare --algos a2c --envs Pendulum-v1 MountainCarContinuous-v0 Acrobot-v1 \
    --critics rbf --gp-normalize --seeds 20 --workers 2 --no-progress --no-plots --out "$OUT/a2c"
sb3-geogp compare --algos ppo --envs MountainCarContinuous-v0 Acrobot-v1 --critics laplacian \
    --gp-normalize --seeds 20 --workers 2 --no-progress --no-plots --out "$OUT/ppo"
echo "all runs done $(date -u)"
