#!/usr/bin/env bash
# The table's PPO MountainCarContinuous-v0 cell re-run with 0.35.0's default GP critic on the
# table's 50 seeds (its stored runs, 0.25's, are not what 0.34.1's default gives: session 68,
# results/whole_batch). Run from the repository root; OUT is this folder by default.
set -euo pipefail
OUT=${OUT:-results/mcc_refresh}
for F in 0 10 150 160 570; do
  sb3-geogp compare --algos ppo --critics laplacian --envs MountainCarContinuous-v0 \
      --seeds 10 --first-seed $F --workers 2 --no-progress --no-plots --out "$OUT/s$F"
done
echo "all runs done $(date -u)"
