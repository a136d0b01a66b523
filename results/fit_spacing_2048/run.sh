#!/usr/bin/env bash
# PREREGISTRATION.md's runs, in its order; finished runs are not run again (re-run to resume).
# Run from a worktree of the registration's commit, in its root, with sb3_geogp importable;
# OUT is this folder by default.
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
source "$(dirname "$0")/../fit_spacing/sweeps.sh"
A=$(spaced_adapt 2048)
echo "2048 arm: adapt=$A"
fit() {  # folder, gp options
    python examples/critic_fit.py --envs CartPole-v1 Acrobot-v1 --critics laplacian \
        --seeds $(seq 1003 1022) --workers 2 "${@:2}" --out "$OUT/$1"
}
fit fit_default
fit fit_2048 --gp-option "adapt=$A"
table_sweep "$A" CartPole-v1 Acrobot-v1 sb3_geogp/WallMazeDiscrete-v0 sb3_geogp/WallMaze-v0 \
    MountainCarContinuous-v0 Pendulum-v1 sb3_geogp/PaperPendulum-v0
echo "all runs done $(date -u)"
