#!/usr/bin/env bash
# PLAN.md's arms, from the repository root with the package's venv on PATH.
set -euo pipefail
OUT=${OUT:-results/fit_screen}
ARGS=(--envs Pendulum-v1 Acrobot-v1 --critics laplacian --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2)
adapt() {  # the PPO default's adaptation as JSON, with the fields of $1 (JSON) replaced
  python - "$1" <<'PY'
import dataclasses, json, sys
from sb3_geogp.policies import DEFAULT_ADAPTATION
print(json.dumps({**dataclasses.asdict(DEFAULT_ADAPTATION), **json.loads(sys.argv[1])}))
PY
}
run() {  # arm name, changed fields (JSON), extra GP options
  python examples/critic_fit.py "${ARGS[@]}" --gp-option "adapt=$(adapt "$2")" "${@:3}" \
      --out "$OUT/$1"
}
run control '{}'
run slow_forget '{"forgetting": [1.0, 0.97, 0.9, 0.7]}'
run noise_floor '{"noise_bounds": [0.01, 1.0]}'
run prior_03 '{"prior_sd": 0.3}'
run steps_20 '{"steps": 20}'
run fit_2048 '{"fit_points": 2048}'
run basis_512 '{}' --gp-option max_basis=512
run steps_2 '{"steps": 2}'   # PLAN.md's addendum
# addendum 2: SB3's returns as the targets, the default adaptation, on the goal's three envs
python examples/critic_fit.py --envs Pendulum-v1 Acrobot-v1 CartPole-v1 --critics laplacian \
    --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2 --target returns --out "$OUT/returns"
