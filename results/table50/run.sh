#!/usr/bin/env bash
# The runs of PREREGISTRATION.md, in its order. Run from a worktree of the registered commit
# with sb3_geogp importable; OUT is this folder (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
sb3-geogp compare --algos ppo --critics laplacian mlp --seeds 10 --first-seed 570 \
    --workers 2 --no-progress --no-plots --out "$OUT/ppo_s570"
sb3-geogp compare --algos a2c --critics rbf mlp --seeds 10 --first-seed 570 \
    --workers 2 --no-progress --no-plots --out "$OUT/a2c_s570"
echo "all runs done $(date -u)"
