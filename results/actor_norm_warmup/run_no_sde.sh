#!/usr/bin/env bash
# ADDENDUM.md's runs: PaperPendulum-v0 without gSDE, without and with the option, and the check
# that the hyperparameter file reproduces the built-in entry. OUT: this folder by default.
set -euo pipefail
F=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$F}
run() {  # out folder, file, first seed, number of seeds, then any further option
    local out=$1 file=$2 first=$3 n=$4
    shift 4
    sb3-geogp compare --algos a2c --critics rbf --envs sb3_geogp/PaperPendulum-v0 \
        --seeds "$n" --first-seed "$first" --hyperparams "a2c=$F/$file" --workers 2 \
        --no-progress --no-plots --out "$OUT/$out" "$@"
}
run sde_check sde_a2c.yml 154 1
run no_sde_default no_sde_a2c.yml 154 20
run no_sde_actor no_sde_a2c.yml 154 20 --gp-actor-normalize
echo "all runs done $(date -u)"
