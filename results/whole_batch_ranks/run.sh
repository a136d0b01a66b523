#!/usr/bin/env bash
# The runs of PREREGISTRATION.md. Run from a worktree of the registered commit with sb3_geogp
# importable; OUT is this folder (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
A=$(python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import default_adaptation; import json; d = default_adaptation(PPO).as_dict(); d['whole_batch'] = True; print(json.dumps(d))")
echo "whole arm: adapt=$A"
declare -A OPT=([default]="" [whole]="adapt=$A")
for arm in default whole; do
  extra=(); [ -n "${OPT[$arm]}" ] && extra=(--gp-option "${OPT[$arm]}")
  python examples/critic_fit.py --envs Acrobot-v1 CartPole-v1 Pendulum-v1 --critics laplacian \
      --seeds $(seq 743 782) --workers 2 "${extra[@]}" --out "$OUT/fit_$arm"
done
echo "all runs done $(date -u)"
