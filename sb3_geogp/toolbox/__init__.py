"""What the comparison harness and the studies share; nothing here imports stable-baselines3.

* :mod:`~sb3_geogp.toolbox.stats`: statistics over seeds (bootstrap, IQM, ``mean_ci``);
* :mod:`~sb3_geogp.toolbox.tables`: text and markdown tables;
* :mod:`~sb3_geogp.toolbox.provenance`: git commit, engine hash and versions of a result;
* :mod:`~sb3_geogp.toolbox.shepard`: the Shepard-interpolation control (a prediction rule);
* :mod:`~sb3_geogp.toolbox.streams`: pendulum transitions and on-line passes over episodes;
* :mod:`~sb3_geogp.toolbox.benchmarks`: GP variants and thread limits of the engine benchmarks;
* :mod:`~sb3_geogp.toolbox.scripts`: an example or results script imported by path;
* :mod:`~sb3_geogp.toolbox.pools`: worker processes for sweeps, which Ctrl-C stops at once.
"""

from __future__ import annotations
