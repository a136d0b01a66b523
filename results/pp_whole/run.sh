#!/usr/bin/env bash
# PREREGISTRATION.md's runs, from the repository root with the package's venv on PATH.
set -euo pipefail
OUT=${OUT:-results/pp_whole}
COMMON=(--algos ppo --envs sb3_geogp/PaperPendulum-v0 --seeds 100 --first-seed 783 --workers 2
        --no-progress --no-plots)
OLD=$(python -c "
import dataclasses, json
from sb3_geogp.policies import DEFAULT_ADAPTATION
print(json.dumps({**dataclasses.asdict(DEFAULT_ADAPTATION), 'whole_batch': False}))")
sb3-geogp compare "${COMMON[@]}" --critics laplacian --out "$OUT/whole"
sb3-geogp compare "${COMMON[@]}" --critics laplacian --gp-option "adapt=$OLD" --out "$OUT/old"
sb3-geogp compare "${COMMON[@]}" --critics mlp --out "$OUT/mlp"
echo "all runs done $(date -u)"
