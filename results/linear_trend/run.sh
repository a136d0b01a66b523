#!/usr/bin/env bash
# The registered runs of PLAN.md (session 86): the reproduction check, then the linear trend
# on HalfCheetah-v5 (seeds 1148-1162) and Hopper-v5 (1143-1152).
# OUT=... writes elsewhere (a frozen worktree's runs).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$HERE}
common() {
    sb3-geogp compare --algos ppo --hyperparams "ppo=$HERE/../heldout2/ppo.yml" \
        --timesteps 50000 --workers 2 --no-progress --no-plots \
        --mlp-normalize --gp-actor-normalize --critics laplacian "$@"
}
common --envs HalfCheetah-v5 --seeds 1 --first-seed 1148 --out "$OUT/reproduce"
common --envs HalfCheetah-v5 --seeds 15 --first-seed 1148 --gp-option trend=linear \
    --out "$OUT/linear"
common --envs Hopper-v5 --seeds 10 --first-seed 1143 --gp-option trend=linear \
    --out "$OUT/linear"
echo "runs done $(date -u)"
