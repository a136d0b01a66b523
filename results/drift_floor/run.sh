#!/bin/bash
# PLAN.md's runs, in order; a finished run is not run again (re-run to resume).
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-results/drift_floor}
run() {  # cell, seeds, first seed
    sb3-geogp compare --algos ppo --critics laplacian --envs "$1" --seeds "$2" --first-seed "$3" \
        --workers 2 --no-progress --out "$OUT/default_$1"
    sb3-geogp compare --algos ppo --critics laplacian --envs "$1" --seeds "$2" --first-seed "$3" \
        --gp-option drift_floor=0.5 --workers 2 --no-progress --baseline "$OUT/default_$1" \
        --out "$OUT/floor_$1"
}
run CartPole-v1 50 933
run Pendulum-v1 20 933
run MountainCarContinuous-v0 10 933
