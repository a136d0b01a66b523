#!/usr/bin/env bash
# PLAN.md's runs: both arms of examples/critic_fit.py on seeds 0-9. Run from the repository root.
set -euo pipefail
OUT=results/window_fit
ADAPT=$(python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import default_adaptation; import json; d = default_adaptation(PPO).as_dict(); d['window'] = 16384; d['interval'] = 1024; print(json.dumps(d))")
echo "window arm: adapt=$ADAPT"
COMMON=(--envs CartPole-v1 Acrobot-v1 Pendulum-v1 --critics laplacian --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2)
python examples/critic_fit.py "${COMMON[@]}" --out "$OUT/default"
python examples/critic_fit.py "${COMMON[@]}" --gp-option "adapt=$ADAPT" --out "$OUT/window16384"
# PLAN.md's addendum: a window of one Acrobot or Pendulum rollout
ADAPT4096=$(python -c "import json, sys; d = json.loads(sys.argv[1]); d['window'] = 4096; print(json.dumps(d))" "$ADAPT")
python examples/critic_fit.py --envs Acrobot-v1 Pendulum-v1 --critics laplacian \
    --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2 --gp-option "adapt=$ADAPT4096" --out "$OUT/window4096"
# PLAN.md's addendum 2: the rebuild on the whole batch, the window the default's
WHOLE=$(python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import default_adaptation; import json; d = default_adaptation(PPO).as_dict(); d['whole_batch'] = True; print(json.dumps(d))")
python examples/critic_fit.py --envs Acrobot-v1 Pendulum-v1 --critics laplacian \
    --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2 --gp-option "adapt=$WHOLE" --out "$OUT/whole_batch"
