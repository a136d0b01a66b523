#!/usr/bin/env bash
# The runs of ADDENDUM.md: the default GP critic, without the actor's normalisation, in the six
# cells and on the seeds of PREREGISTRATION.md. Run from a worktree of the addendum's commit;
# OUT is this folder's default/ (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)/default}
compare() {  # algo, critic, first seed, number of seeds, then envs
    local algo=$1 critic=$2 first=$3 n=$4
    shift 4
    sb3-geogp compare --algos "$algo" --critics "$critic" --seeds "$n" --first-seed "$first" \
        --workers 2 --no-progress --no-plots --out "$OUT/$algo" --envs "$@"
}
for s in "0 20" "30 10" "70 10" "570 10"; do
    compare a2c rbf $s Pendulum-v1 MountainCarContinuous-v0 Acrobot-v1 sb3_geogp/PaperPendulum-v0
done
for s in "0 20" "150 20" "570 10"; do
    compare ppo laplacian $s Acrobot-v1 MountainCarContinuous-v0
done
echo "all runs done $(date -u)"
