#!/usr/bin/env bash
# The runs of PLAN.md: `run.sh mujoco` (the three PPO cells, the primary protocol), then
# `run.sh lunar` (A2C LunarLander-v3), and `run.sh table` (addendum 2, exploratory). Run from
# a worktree of the commit PLAN.md names for each, with sb3_geogp importable and gymnasium's
# mujoco and box2d extras.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$HERE}
MUJOCO=(InvertedPendulum-v5 InvertedDoublePendulum-v5 Reacher-v5)
compare() {  # algo, first seed, folder, then envs and flags
    local algo=$1 first=$2 out=$3
    shift 3
    sb3-geogp compare --algos "$algo" --hyperparams "$algo=$HERE/$algo.yml" --seeds 10 \
        --first-seed "$first" --timesteps 50000 --workers 2 --no-progress --no-plots \
        --out "$out" --envs "$@"
}
case ${1:?"run.sh mujoco|lunar|table"} in
    mujoco)
        # (the table's rule for these cells, a second sweep into $OUT/table_rule, was dropped
        # for time: PLAN.md's addendum)
        compare ppo 1023 "$OUT/normalized" "${MUJOCO[@]}" --critics mlp laplacian \
            --mlp-normalize --gp-actor-normalize ;;
    lunar)
        compare a2c 216 "$OUT/table_rule" LunarLander-v3 --critics mlp rbf ;;
    table)  # PLAN.md's addendum 2: exploratory, after the registered reading
        compare ppo 1023 "$OUT/table_rule" InvertedPendulum-v5 InvertedDoublePendulum-v5 \
            --critics mlp laplacian ;;
esac
echo "$1 runs done $(date -u)"
