#!/usr/bin/env bash
# PLAN.md's screen, env by env, both arms on fresh PPO seeds 703-712. Run from the repository root.
set -euo pipefail
OUT=results/window_screen
ADAPT=$(python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import default_adaptation; import json; d = default_adaptation(PPO).as_dict(); d['window'] = 16384; d['interval'] = 1024; print(json.dumps(d))")
echo "window arm: adapt=$ADAPT"
for ENV in Acrobot-v1 CartPole-v1 Pendulum-v1 sb3_geogp/PaperPendulum-v0 \
    MountainCarContinuous-v0 sb3_geogp/WallMaze-v0 sb3_geogp/WallMazeDiscrete-v0; do
    COMMON=(--algos ppo --critics laplacian --envs "$ENV" --seeds 10 --first-seed 703 --workers 2 --no-plots --no-progress)
    sb3-geogp compare "${COMMON[@]}" --out "$OUT/default"
    sb3-geogp compare "${COMMON[@]}" --gp-option "adapt=$ADAPT" --out "$OUT/window16384"
done
# every run is on disk by now: this call only reads them and writes the report against the default arm
sb3-geogp compare --algos ppo --critics laplacian --seeds 10 --first-seed 703 --no-progress \
    --gp-option "adapt=$ADAPT" --out "$OUT/window16384" --baseline "$OUT/default"
