#!/usr/bin/env bash
# The addendum's runs (PLAN.md): the default GP critic with the zoo's entries normalising
# rewards only, seeds 0-19, the five cells. OUT is this folder (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
HERE=$(cd "$(dirname "$0")" && pwd)
sb3-geogp compare --algos a2c --envs Pendulum-v1 MountainCarContinuous-v0 Acrobot-v1 \
    --critics rbf --gp-normalize --hyperparams "a2c=$HERE/reward_only/a2c.yml" --seeds 20 \
    --workers 2 --no-progress --no-plots --out "$OUT/reward_only/a2c"
sb3-geogp compare --algos ppo --envs MountainCarContinuous-v0 Acrobot-v1 --critics laplacian \
    --gp-normalize --hyperparams "ppo=$HERE/reward_only/ppo.yml" --seeds 20 --workers 2 \
    --no-progress --no-plots --out "$OUT/reward_only/ppo"
echo "all runs done $(date -u)"
