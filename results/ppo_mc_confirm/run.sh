#!/usr/bin/env bash
# The confirmation's runs, in the order PREREGISTRATION.md fixes (run from the repository root;
# a rerun resumes: `sb3-geogp compare` skips the runs already in its --out folder).
set -euo pipefail
out=results/ppo_mc_confirm
arm() {  # arm FOLDER FIRST_SEED N_SEEDS "ENVS" CRITIC_OPTIONS...
  local folder=$1 first=$2 n=$3 envs=$4; shift 4
  # shellcheck disable=SC2086  # envs is a list of ids
  sb3-geogp compare --algos ppo "$@" --envs $envs --seeds "$n" --first-seed "$first" \
    --workers 2 --no-progress --out "$out/$folder"
}
for block in "ac 240 20 Acrobot-v1 CartPole-v1" "mcc 240 10 MountainCarContinuous-v0" \
             "mcc 250 10 MountainCarContinuous-v0"; do
  read -r tag first n envs <<<"$block"
  arm "C_${tag}_s$first" "$first" "$n" "$envs" --critics laplacian --target monte_carlo
  arm "A_${tag}_s$first" "$first" "$n" "$envs" --critics laplacian --target returns
  arm "mlp_${tag}_s$first" "$first" "$n" "$envs" --critics mlp
done
