"""Research studies built on the engine, one subpackage per study (not part of the product API).

* :mod:`~sb3_geogp.studies.pendulum`: the reproduction of the paper's pendulum experiment;
* :mod:`~sb3_geogp.studies.wall`: geodesic vs Euclidean kernels on a two-room value function;
* :mod:`~sb3_geogp.studies.action_gap`: whether a critic orders CartPole's two actions as the
  true action values do (Monte Carlo gaps);
* :mod:`~sb3_geogp.studies.advantage_error`: how far a critic's GAE advantages on the paper's
  pendulum are from those of the policy's true value function (Monte Carlo);
* :mod:`~sb3_geogp.studies.value_ceiling`: what the policy's own value function (Monte Carlo)
  scores by issue 13's critic-fit measure on CartPole and Acrobot rollouts, and how far a
  critic's values are from it;
* :mod:`~sb3_geogp.studies.exact_gp`: an exact GP with maximum-likelihood hyperparameters, the
  reference for what the GP critic's model allows on data it was fed, without its basis.

They share :mod:`sb3_geogp.toolbox` with the critic comparison (:mod:`sb3_geogp.comparison`).
"""

from __future__ import annotations
