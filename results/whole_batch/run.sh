#!/usr/bin/env bash
# The runs of PREREGISTRATION.md, in its order. Run from a worktree of the registered commit
# with sb3_geogp importable; OUT is this folder (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
A=$(python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import default_adaptation; import json; d = default_adaptation(PPO).as_dict(); d['whole_batch'] = True; print(json.dumps(d))")
echo "whole arm: adapt=$A"
declare -A OPT=([default]="" [whole]="adapt=$A")
for arm in default whole; do
  extra=(); [ -n "${OPT[$arm]}" ] && extra=(--gp-option "${OPT[$arm]}")
  python examples/critic_fit.py --envs Acrobot-v1 Pendulum-v1 --critics laplacian \
      --seeds $(seq 713 742) --workers 2 "${extra[@]}" --out "$OUT/fit_$arm"
done
sb3-geogp compare --algos ppo --critics laplacian --envs MountainCarContinuous-v0 \
    sb3_geogp/WallMaze-v0 sb3_geogp/WallMazeDiscrete-v0 --seeds 1 --first-seed 0 --workers 2 \
    --no-progress --no-plots --gp-option "adapt=$A" --out "$OUT/check"
for F in 0 10 150 160 570; do
  sb3-geogp compare --algos ppo --critics laplacian --envs CartPole-v1 Acrobot-v1 Pendulum-v1 \
      sb3_geogp/PaperPendulum-v0 --seeds 10 --first-seed $F --workers 2 --no-progress \
      --no-plots --gp-option "adapt=$A" --out "$OUT/table_s$F"
done
echo "all runs done $(date -u)"
