#!/usr/bin/env bash
# Why the table's stored PPO MountainCarContinuous-v0 runs (0.24.1's code, results/ppo_horizon200)
# are not what 0.34.1 and later give (session 68): the same commit re-run on this machine, and
# the first evaluation under MKL's code paths. Run from the repository root with the package's
# venv on PATH; OUT is this folder by default (session 69, on an AMD EPYC machine).
set -euo pipefail
OUT=${OUT:-results/cpu_model}
OLD=7ec785b11351777241d34beea36e5297de14a630   # the commit recorded by the stored seed-0 run
WT=$(mktemp -d)/old
git worktree add --detach "$WT" "$OLD"
# 1. the stored run's commit and spec (0.24.1: Monte Carlo targets cut after 200 steps) here
PYTHONPATH="$WT" python -m sb3_geogp.cli compare --algos ppo --critics laplacian \
    --envs MountainCarContinuous-v0 --seeds 1 --first-seed 0 --workers 1 \
    --target monte_carlo --horizon 200 --no-progress --no-plots --out "$OUT/old_commit"
git worktree remove --force "$WT"
# 2. today's code, 1,000 steps (the evaluations at 0 and 1,000 steps), under MKL's code paths
for V in unset COMPATIBLE AVX2 AVX512; do
  if [ "$V" = unset ]; then E=(); else E=(MKL_CBWR="$V"); fi
  env "${E[@]}" sb3-geogp compare --algos ppo --critics laplacian --envs MountainCarContinuous-v0 \
      --seeds 1 --first-seed 0 --workers 1 --timesteps 1000 --no-progress --no-plots \
      --out "$OUT/mkl_$V"
done
