#!/usr/bin/env bash
# The registered runs of PLAN.md (session 85); `run.sh no_prior` and
# `run.sh no_prior_more` those of its addenda 1 and 2.
# OUT=... writes elsewhere (a frozen worktree's runs).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$HERE}
common() {
    sb3-geogp compare --algos ppo --hyperparams "ppo=$HERE/../heldout2/ppo.yml" --seeds 10 \
        --first-seed 1143 --timesteps 50000 --workers 2 --no-progress --no-plots \
        --mlp-normalize --gp-actor-normalize "$@"
}
if [ "${1:-}" = no_prior ]; then  # PLAN.md's addendum 1
    common --envs HalfCheetah-v5 --critics laplacian --gp-option adapt.prior_sd=None \
        --out "$OUT/no_prior"
    exit
fi
if [ "${1:-}" = no_prior_more ]; then  # PLAN.md's addendum 2: seeds 1153-1162, both arms
    more=(--envs HalfCheetah-v5 --critics laplacian --first-seed 1153)
    common "${more[@]}" --out "$OUT/spread_more"
    common "${more[@]}" --gp-option adapt.prior_sd=None --out "$OUT/no_prior_more"
    exit
fi
common --envs HalfCheetah-v5 Hopper-v5 --critics mlp laplacian --out "$OUT/spread"
common --envs HalfCheetah-v5 Hopper-v5 --critics laplacian --gp-option lengthscale_rule=distance \
    --out "$OUT/distance"
echo "runs done $(date -u)"
