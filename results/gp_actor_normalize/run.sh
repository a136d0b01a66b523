#!/usr/bin/env bash
# The runs of PREREGISTRATION.md, in its order. Run from a worktree of the registered commit
# with sb3_geogp importable; OUT is this folder, MLP_OUT session 61's control folder (defaults:
# next to this script).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$HERE}
MLP_OUT=${MLP_OUT:-$HERE/../mlp_vecnormalize}
A2C_SEEDS=("0 20" "30 10" "70 10" "570 10")
PPO_SEEDS=("0 20" "150 20" "570 10")
compare() {  # algo, critic, folder, first seed, number of seeds, then envs and flags
    local algo=$1 critic=$2 out=$3 first=$4 n=$5
    shift 5
    sb3-geogp compare --algos "$algo" --critics "$critic" --seeds "$n" --first-seed "$first" \
        --workers 2 --no-progress --no-plots --out "$out" --envs "$@"
}
for s in "${A2C_SEEDS[@]}"; do
    compare a2c mlp "$MLP_OUT/a2c" $s sb3_geogp/PaperPendulum-v0 --mlp-normalize
done
for s in "${A2C_SEEDS[@]}"; do
    compare a2c rbf "$OUT/a2c" $s Pendulum-v1 MountainCarContinuous-v0 Acrobot-v1 \
        sb3_geogp/PaperPendulum-v0 --gp-actor-normalize
done
for env in Acrobot-v1 MountainCarContinuous-v0; do
    for s in "${PPO_SEEDS[@]}"; do
        compare ppo laplacian "$OUT/ppo" $s "$env" --gp-actor-normalize
    done
done
echo "all runs done $(date -u)"
