"""Compare critics inside SB3 training: {PPO, A2C} x {MLP, RBF-GP, geodesic-GP} x envs x seeds.

Each run writes ``<out>/runs/<run id>.json`` atomically, so an interrupted sweep resumes where
it stopped (rerun the same command) and never redoes finished runs. Afterwards the figures
and the summary table go to ``<out>/report/``.

Examples
--------
Smoke test (5 % budgets, 2 seeds, all environments)::

    python examples/compare_critics.py --quick --out results/compare_smoke

The published comparison (see docs/results.md)::

    python examples/compare_critics.py --out results/compare --workers 2 --seeds 5

Only some cells, on a Ray cluster (``pip install 'ray[default]'``)::

    python examples/compare_critics.py --envs sb3_geogp/WallMaze-v0 --algos ppo --ray

Your own environment (``my_pkg.envs`` registers ``MyEnv-v0``) with rl-baselines3-zoo
hyperparameters from ``ppo.yml``, your threshold and budget (see docs/usage.md)::

    python examples/compare_critics.py --envs my_pkg.envs:MyEnv-v0 --hyperparams ppo=ppo.yml \
        --threshold 200 --timesteps 50000 --seeds 5 --out results/my_env

The same options as ``sb3-geogp compare``; ``--help`` lists them.
"""

from __future__ import annotations

import sys

from sb3_geogp.cli import main

if __name__ == "__main__":
    sys.exit(main(["compare", *sys.argv[1:]]))
