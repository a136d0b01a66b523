#!/usr/bin/env bash
# Every run of results/fitc_rebuild (session 60, exploratory: not planned before its runs).
# The "switch" arm runs the examples through fitc_rebuild.py, which gives each rebuild the
# on-line update's FITC-like noise (the package itself has no such option). Run from the
# repository root; OUT defaults to /tmp/fitc. About 25 min on 2 cores, one run after another.
set -euo pipefail
OUT=${OUT:-/tmp/fitc}
SWITCH="python results/fitc_rebuild/fitc_rebuild.py"
SEEDS=$(seq -s ' ' 0 19)
python examples/critic_fit.py --critics laplacian --seeds $SEEDS --out "$OUT/default"
$SWITCH examples/critic_fit.py --critics laplacian --seeds $SEEDS --out "$OUT/switch"
# The fixed-policy pendulum, the published command (docs/fixed_policy_check_prior); its
# default arm reproduces that table exactly.
ADAPT='{"max_gap": 16, "settle": false, "score_points": 256, "fold_points": 256, "fit_floor": 0.8, "summary": "snapshot"}'
FPC="--kernels laplacian --trend level --prior-sd 0.1 --forgetting 0.1 --forgetting-points 4096"
python examples/fixed_policy_check.py $FPC --adapt "$ADAPT" --out "$OUT/fixed_policy_default"
$SWITCH examples/fixed_policy_check.py $FPC --adapt "$ADAPT" --out "$OUT/fixed_policy_switch"
