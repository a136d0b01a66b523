#!/usr/bin/env bash
# PLAN.md's runs: CartPole-v1's critic-fit score with fit spacings 2,048 and 3,072 (seeds 0-9),
# then the training benchmark (run it on a quiet machine). From the repository root.
set -euo pipefail
OUT=${OUT:-$(cd "$(dirname "$0")" && pwd)}
source "$(dirname "$0")/../fit_spacing/sweeps.sh"
for s in 2048 3072; do
    python examples/critic_fit.py --envs CartPole-v1 --critics laplacian --seeds $(seq 0 9) \
        --workers 2 --gp-option "adapt=$(spaced_adapt $s)" --out "$OUT/s$s"
done
if [ "${1:-}" = benchmark ]; then
    unspaced=laplacian+adapt+gap16+nosettle+score256+fold256+floor80+snapshot+prior10+whole
    python examples/benchmark_training.py --workloads "PPO CartPole-v1" --seeds 0 1 2 \
        --critics mlp $unspaced $unspaced+spacing2048 $unspaced+spacing3072 laplacian+adapt \
        --out "$OUT/training.json"
fi
