#!/bin/bash
# PREREGISTRATION.md's runs, in order; a finished run is not run again (re-run to resume).
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-results/a2c_drift}
sb3-geogp compare --algos a2c --critics rbf --seeds 20 --first-seed 196 --workers 2 \
    --no-progress --out "$OUT/reg_default"
sb3-geogp compare --algos a2c --critics rbf --gp-option drift_forgetting=0.85 --seeds 20 \
    --first-seed 196 --workers 2 --no-progress --baseline "$OUT/reg_default" \
    --out "$OUT/reg_drift"
