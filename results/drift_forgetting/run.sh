#!/bin/bash
# PREREGISTRATION.md's runs, in order; a finished run is not run again (re-run to resume).
set -euo pipefail
cd "$(dirname "$0")/../.."
sb3-geogp compare --algos ppo --critics laplacian --seeds 20 --first-seed 913 --workers 2 \
    --no-progress --out results/drift_forgetting/reg_default
sb3-geogp compare --algos ppo --critics laplacian --gp-option drift_forgetting=12.6 --seeds 20 \
    --first-seed 913 --workers 2 --no-progress --baseline results/drift_forgetting/reg_default \
    --out results/drift_forgetting/reg_drift
