#!/bin/bash
# PREREGISTRATION.md's runs, in order; a finished run is not run again (re-run to resume).
set -euo pipefail
cd "$(dirname "$0")/../.."
ADAPT=$(python -c 'import json; from sb3_geogp.policies import DEFAULT_ADAPTATION as A
print(json.dumps({**A.as_dict(), "forgetting": [0.5]}))')
echo "forget05: adapt=$ADAPT"
sb3-geogp compare --algos ppo --critics laplacian --seeds 20 --first-seed 893 --workers 2 \
    --out results/forgetting_ppo/reg_default
sb3-geogp compare --algos ppo --critics laplacian --gp-option "adapt=$ADAPT" --seeds 20 \
    --first-seed 893 --workers 2 --baseline results/forgetting_ppo/reg_default \
    --out results/forgetting_ppo/reg_forget05
