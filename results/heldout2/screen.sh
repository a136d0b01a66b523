#!/usr/bin/env bash
# Exploratory screen after PLAN.md's registered reading (session 84): why PPO's default GP
# critic trails SB3's MLP critic on HalfCheetah-v5. One change per arm, the study's protocol,
# its first five seeds (1133-1137), paired with the study's own runs of those seeds.
# `screen.sh ARM...` runs the named arms into screen/<arm>; `python screen_read.py` reads them.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$HERE}
python_default_adapt() {  # PPO's default adaptation as JSON, with one key replaced
    python -c "
import json, sys
from stable_baselines3 import PPO
from sb3_geogp.policies import default_adaptation
print(json.dumps({**default_adaptation(PPO).as_dict(), sys.argv[1]: json.loads(sys.argv[2])}))" "$1" "$2"
}
NORMALIZE=(--mlp-normalize --gp-actor-normalize)  # the study's protocol
screen() {  # arm, critics (space-separated), then compare's extra flags
    local arm=$1 critics=$2
    shift 2
    # shellcheck disable=SC2086
    sb3-geogp compare --algos ppo --hyperparams "ppo=$HERE/ppo.yml" --seeds 5 --first-seed 1133 \
        --timesteps 50000 --workers 2 --no-progress --no-plots --out "$OUT/screen/$arm" \
        --envs HalfCheetah-v5 --critics $critics "$@"
}
for arm in "$@"; do
    case $arm in
        sb3_returns) screen "$arm" laplacian "${NORMALIZE[@]}" --target returns ;;
        no_prior) screen "$arm" laplacian "${NORMALIZE[@]}" --gp-option "adapt=$(python_default_adapt prior_sd null)" ;;
        rbf) screen "$arm" rbf "${NORMALIZE[@]}" ;;
        basis512) screen "$arm" laplacian "${NORMALIZE[@]}" --gp-option max_basis=512 ;;
        # Both critics without VecNormalize (the table's rule), as the first study's addendum 2:
        table_rule) screen "$arm" "mlp laplacian" ;;
        *) echo "unknown arm $arm" >&2; exit 2 ;;
    esac
done
echo "screen done $(date -u)"
