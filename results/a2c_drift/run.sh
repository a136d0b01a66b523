#!/bin/bash
# PLAN.md's screen (`run.sh`) or PREREGISTRATION.md's registered test (`run.sh registered`,
# which run_registered.sh runs), in order; a finished run is not run again (re-run to resume).
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-results/a2c_drift}
arms() {  # seeds, first seed, prefix of the two arms' folders
    sb3-geogp compare --algos a2c --critics rbf --seeds "$1" --first-seed "$2" --workers 2 \
        --no-progress --out "$OUT/${3}default"
    sb3-geogp compare --algos a2c --critics rbf --gp-option drift_forgetting=0.85 --seeds "$1" \
        --first-seed "$2" --workers 2 --no-progress --baseline "$OUT/${3}default" \
        --out "$OUT/${3}drift"
}
if [ "${1:-screen}" = registered ]; then arms 20 196 reg_; else arms 10 186 ""; fi
