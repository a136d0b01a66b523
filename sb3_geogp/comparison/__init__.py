"""Compare critics inside ordinary SB3 training: SB3's MLP critic vs GP critics.

The harness behind ``sb3-geogp compare``. A sweep is the product ``{ppo, a2c} x critics x
environments x seeds``, the critics ``{mlp, rbf, geodesic}`` by default (the published
sweep's) or any of ``{mlp, rbf, geodesic, laplacian, matern}``; each run trains one model
exactly as a user would and writes one JSON result file, atomically, so an interrupted sweep
resumes where it stopped.
One concept per module:

* :mod:`~sb3_geogp.comparison.hyperparams`: algorithms, critics, environments, budgets,
  thresholds and rl-baselines3-zoo's hyperparameters;
* :mod:`~sb3_geogp.comparison.specs`: :class:`RunSpec` (one run) and :class:`SweepConfig`;
* :mod:`~sb3_geogp.comparison.evaluation`: evaluation episodes and Monte Carlo critic accuracy;
* :mod:`~sb3_geogp.comparison.measurement`: the callbacks that measure inside ``learn``;
* :mod:`~sb3_geogp.comparison.run`: one run and its result file;
* :mod:`~sb3_geogp.comparison.shadow`: critics that learn beside a run from the same batches;
* :mod:`~sb3_geogp.comparison.sweep`: all runs of a sweep, resumable, in processes or on Ray;
* :mod:`~sb3_geogp.comparison.command`: the command line;
* :mod:`~sb3_geogp.comparison.results`: aggregation over seeds and verdicts;
* :mod:`~sb3_geogp.comparison.report`: tables and figures of a sweep.
"""

from __future__ import annotations
