#!/usr/bin/env bash
# PLAN.md's arm, from the repository root with the package's venv on PATH.
set -euo pipefail
OUT=${OUT:-results/mean_screen}
python examples/critic_fit.py --envs Pendulum-v1 CartPole-v1 Acrobot-v1 --critics laplacian \
    --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2 --gp-option prior_mean=linear --out "$OUT/linear"
