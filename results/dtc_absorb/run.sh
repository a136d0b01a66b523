#!/usr/bin/env bash
# Every run of results/dtc_absorb, from a scratch clone with the switch applied (the package
# itself has no such switch). Run from the repository root; OUT defaults to /tmp/dtc.
set -euo pipefail
OUT=${OUT:-/tmp/dtc}
CLONE=$(mktemp -d)
git clone -q . "$CLONE"
git -C "$CLONE" apply "$PWD/results/dtc_absorb/switch.patch"
SEEDS="643 644 645 646 647 648 649 650 651 652"
cd "$CLONE"
PYTHONPATH="$CLONE" python examples/critic_fit.py --critics laplacian --seeds $SEEDS --out "$OUT/default"
GP_DTC_ABSORB=1 PYTHONPATH="$CLONE" python examples/critic_fit.py --critics laplacian --seeds $SEEDS --out "$OUT/switch"
# Added after reading the critic-fit runs (the fixed-policy pendulum, the published command;
# not planned):
ADAPT='{"max_gap": 16, "settle": false, "score_points": 256, "fold_points": 256, "fit_floor": 0.8, "summary": "snapshot"}'
FPC="--kernels laplacian --trend level --prior-sd 0.1 --forgetting 0.1 --forgetting-points 4096"
PYTHONPATH="$CLONE" python examples/fixed_policy_check.py $FPC --adapt "$ADAPT" --out "$OUT/fixed_policy_default"
GP_DTC_ABSORB=1 PYTHONPATH="$CLONE" python examples/fixed_policy_check.py $FPC --adapt "$ADAPT" --out "$OUT/fixed_policy_switch"
# Added after reading the first ten seeds (Acrobot-v1 only; not planned either):
SEEDS="653 654 655 656 657 658 659 660 661 662"
PYTHONPATH="$CLONE" python examples/critic_fit.py --envs Acrobot-v1 --critics laplacian --seeds $SEEDS --out "$OUT/extension_default"
GP_DTC_ABSORB=1 PYTHONPATH="$CLONE" python examples/critic_fit.py --envs Acrobot-v1 --critics laplacian --seeds $SEEDS --out "$OUT/extension_switch"
