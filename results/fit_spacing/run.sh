#!/usr/bin/env bash
# PLAN.md's screen, in its order, or with `registered` PREREGISTRATION.md's runs; a finished run
# is not run again (re-run to resume). Run from a worktree of the plan's (or the registration's)
# commit, in its root, with sb3_geogp importable; OUT is this folder by default.
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
source "$(dirname "$0")/sweeps.sh"
A=$(spaced_adapt 4096)
echo "spaced arm: adapt=$A"
run() {  # cell, seeds, first seed
    local name=${1#sb3_geogp/}
    sb3-geogp compare --algos ppo --critics laplacian --envs "$1" --seeds "$2" --first-seed "$3" \
        --workers 2 --no-progress --out "$OUT/default_$name"
    sb3-geogp compare --algos ppo --critics laplacian --envs "$1" --seeds "$2" --first-seed "$3" \
        --gp-option "adapt=$A" --workers 2 --no-progress --baseline "$OUT/default_$name" \
        --out "$OUT/spaced_$name"
}
registered() {  # PREREGISTRATION.md's runs, in its order
    table_sweep "$A" CartPole-v1 Acrobot-v1 Pendulum-v1 sb3_geogp/PaperPendulum-v0 \
        sb3_geogp/WallMazeDiscrete-v0 sb3_geogp/WallMaze-v0 MountainCarContinuous-v0
    python examples/critic_fit.py --envs CartPole-v1 Acrobot-v1 --critics laplacian \
        --seeds $(seq 0 9) --workers 2 --out "$OUT/fit_default"
    python examples/critic_fit.py --envs CartPole-v1 Acrobot-v1 --critics laplacian \
        --seeds $(seq 0 9) --workers 2 --gp-option "adapt=$A" --out "$OUT/fit_spaced"
}
if [ "${1:-}" = extend ]; then  # PLAN.md's addendum
    run Acrobot-v1 10 983
    run Pendulum-v1 10 983
    run sb3_geogp/PaperPendulum-v0 10 983
    echo "all runs done $(date -u)"
    exit 0
fi
if [ "${1:-}" = registered ]; then
    registered
    echo "all runs done $(date -u)"
    exit 0
fi
run CartPole-v1 20 983
run MountainCarContinuous-v0 10 983
run sb3_geogp/WallMaze-v0 10 983
run sb3_geogp/WallMazeDiscrete-v0 10 983
# The cells whose blocks are whole 4,096-point rollouts: the same runs bit for bit (one seed).
sb3-geogp compare --algos ppo --critics laplacian --envs Pendulum-v1 Acrobot-v1 --seeds 1 \
    --first-seed 983 --workers 2 --no-progress --no-plots --out "$OUT/check_default"
sb3-geogp compare --algos ppo --critics laplacian --envs Pendulum-v1 Acrobot-v1 --seeds 1 \
    --first-seed 983 --workers 2 --no-progress --no-plots --gp-option "adapt=$A" \
    --out "$OUT/check_spaced"
echo "all runs done $(date -u)"
