#!/usr/bin/env bash
# The runs of PREREGISTRATION.md, in its order (the deciding cells first). Run from a worktree
# of the registered commit with sb3_geogp importable; OUT is this folder (default: next to this
# script). A finished run is not run again: re-run to resume.
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
for env in CartPole-v1 Pendulum-v1 Acrobot-v1 sb3_geogp/PaperPendulum-v0 \
    sb3_geogp/WallMazeDiscrete-v0 sb3_geogp/WallMaze-v0 MountainCarContinuous-v0; do
  for block in 0:20 150:20 570:10; do
    sb3-geogp compare --algos ppo --critics laplacian --envs "$env" \
        --gp-option drift_forgetting=12.6 --seeds "${block#*:}" --first-seed "${block%%:*}" \
        --workers 2 --no-progress --no-plots --out "$OUT/${env#sb3_geogp/}_s${block%%:*}"
  done
done
echo "all runs done $(date -u)"
