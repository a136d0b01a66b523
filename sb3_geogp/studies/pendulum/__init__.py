"""Reproduction of the paper's pendulum experiment (its Figure 3), with controls.

* :mod:`~sb3_geogp.studies.pendulum.task`: the fixed policy on the paper's pendulum, episodes;
* :mod:`~sb3_geogp.studies.pendulum.ground_truth`: Monte Carlo value and the TD baseline;
* :mod:`~sb3_geogp.studies.pendulum.mlp_baseline`: SB3's default critic network as a regressor;
* :mod:`~sb3_geogp.studies.pendulum.reproduction`: models, settings and the runner;
* :mod:`~sb3_geogp.studies.pendulum.plots` and :mod:`~sb3_geogp.studies.pendulum.report`:
  figures 1-4 and the tables (``examples/reproduce_paper.py``, docs/reproduction.md).
"""

from __future__ import annotations
