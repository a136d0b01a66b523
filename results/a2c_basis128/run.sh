#!/usr/bin/env bash
# The runs of PREREGISTRATION.md, in its order. Run from a worktree of the registered commit
# with sb3_geogp importable; OUT is this folder (default: next to this script).
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
for F in 0 10 30 70; do
  sb3-geogp compare --algos a2c --critics rbf --gp-option max_basis=128 --seeds 10 \
      --first-seed $F --workers 2 --no-progress --no-plots --out "$OUT/basis128_s$F"
done
echo "all runs done $(date -u)"
