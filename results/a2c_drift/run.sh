#!/bin/bash
# PLAN.md's runs, in order; a finished run is not run again (re-run to resume).
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-results/a2c_drift}
sb3-geogp compare --algos a2c --critics rbf --seeds 10 --first-seed 186 --workers 2 \
    --no-progress --out "$OUT/default"
sb3-geogp compare --algos a2c --critics rbf --gp-option drift_forgetting=0.85 --seeds 10 \
    --first-seed 186 --workers 2 --no-progress --baseline "$OUT/default" --out "$OUT/drift"
