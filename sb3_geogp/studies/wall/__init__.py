"""Geodesic vs Euclidean kernels on a two-room value function that jumps across a wall.

* :mod:`~sb3_geogp.studies.wall.rooms`: the domain, its exact value and goal-directed walks;
* :mod:`~sb3_geogp.studies.wall.comparison`: models, metrics and the sweep over basis sizes;
* :mod:`~sb3_geogp.studies.wall.oracle`: attachments that never cross a wall (the oracle);
* :mod:`~sb3_geogp.studies.wall.plots`: value maps and MSE curves
  (``examples/wall_experiment.py``, docs/wall_experiment.md).
"""

from __future__ import annotations
