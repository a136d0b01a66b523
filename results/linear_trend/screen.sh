#!/usr/bin/env bash
# The exploratory screen of PLAN.md (session 86, from 43542658): two arms on HalfCheetah-v5,
# seeds 1143-1147. OUT=... writes elsewhere (a frozen worktree's runs).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$HERE}
common=(--algos ppo --hyperparams "ppo=$HERE/../heldout2/ppo.yml" --seeds 5 --first-seed 1143
    --timesteps 50000 --workers 2 --no-progress --no-plots --mlp-normalize --gp-actor-normalize
    --envs HalfCheetah-v5 --critics laplacian)
sb3-geogp compare "${common[@]}" --target returns --out "$OUT/screen/returns"
sb3-geogp compare "${common[@]}" --gp-option trend=linear --out "$OUT/screen/linear"
