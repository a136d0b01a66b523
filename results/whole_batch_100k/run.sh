#!/usr/bin/env bash
# PLAN.md's runs. Run from the repository root.
set -euo pipefail
OUT=results/whole_batch_100k
A=$(python -c "from sb3_geogp.policies import DEFAULT_ADAPTATION; import json, dataclasses; print(json.dumps(dataclasses.replace(DEFAULT_ADAPTATION, whole_batch=False).as_dict()))")
COMMON=(--envs Acrobot-v1 --critics laplacian --seeds 0 1 2 3 4 5 6 7 8 9 --scale 3.3333333333 --workers 2)
python examples/critic_fit.py "${COMMON[@]}" --out "$OUT/default035"
python examples/critic_fit.py "${COMMON[@]}" --gp-option "adapt=$A" --out "$OUT/default034"
