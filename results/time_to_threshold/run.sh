#!/usr/bin/env bash
# Every run of PLAN.md in order (resumable: a finished run is skipped). Run from the repository
# root with nothing else running:
#   OUT=results/time_to_threshold bash results/time_to_threshold/run.sh         # the six cells
#   OUT=results/time_to_threshold bash results/time_to_threshold/run.sh more    # the addendum's
set -euo pipefail
OUT=${OUT:-results/time_to_threshold}
if [[ "${1:-}" == more ]]; then
  cells=("ppo laplacian sb3_geogp/WallMaze-v0" "ppo laplacian sb3_geogp/WallMazeDiscrete-v0"
         "a2c rbf MountainCarContinuous-v0" "a2c rbf Pendulum-v1"
         "a2c rbf sb3_geogp/PaperPendulum-v0" "a2c rbf sb3_geogp/WallMaze-v0"
         "a2c rbf sb3_geogp/WallMazeDiscrete-v0")
else
  cells=("ppo laplacian CartPole-v1" "ppo laplacian Pendulum-v1"
         "ppo laplacian sb3_geogp/PaperPendulum-v0" "ppo laplacian Acrobot-v1"
         "a2c rbf CartPole-v1" "a2c rbf Acrobot-v1")
fi
for seed in 570 571 572 573 574 575 576 577 578 579; do
  for cell in "${cells[@]}"; do
    read -r algo gp env <<<"$cell"
    critics="$gp mlp"
    if (( seed % 2 )); then critics="mlp $gp"; fi
    # shellcheck disable=SC2086
    sb3-geogp compare --algos "$algo" --critics $critics --envs "$env" --seeds 1 \
        --first-seed "$seed" --workers 1 --no-progress --no-plots --out "$OUT/$algo"
  done
done
