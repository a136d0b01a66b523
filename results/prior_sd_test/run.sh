#!/usr/bin/env bash
# The runs of PREREGISTRATION.md, in its order. Run from a worktree of the registered commit
# with sb3_geogp importable; OUT is this folder (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
A=$(python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import default_adaptation; import json; d = default_adaptation(PPO).as_dict(); d['prior_sd'] = 0.3; print(json.dumps(d))")
declare -A OPT=([default]="" [prior30]="adapt=$A")
for arm in default prior30; do
  extra=(); [ -n "${OPT[$arm]}" ] && extra=(--gp-option "${OPT[$arm]}")
  python examples/critic_fit.py --envs Acrobot-v1 --critics laplacian --seeds $(seq 510 529) \
      --scale 3.3333333333 --workers 2 "${extra[@]}" --out "$OUT/fit_$arm"
done
for arm in default prior30; do
  extra=(); [ -n "${OPT[$arm]}" ] && extra=(--gp-option "${OPT[$arm]}")
  sb3-geogp compare --algos ppo --critics laplacian --envs CartPole-v1 Acrobot-v1 \
      --timesteps 100000 --seeds 40 --first-seed 530 --workers 2 --no-progress --no-plots \
      "${extra[@]}" --out "$OUT/long_$arm"
done
for F in 0 10 150 160; do
  sb3-geogp compare --algos ppo --critics laplacian --seeds 10 --first-seed $F --workers 2 \
      --no-progress --no-plots --gp-option "adapt=$A" --out "$OUT/table_s$F"
done
echo "all runs done $(date -u)"
