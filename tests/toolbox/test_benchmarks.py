"""The benchmarks' clock on a GP's methods."""

from __future__ import annotations

import numpy as np

from sb3_geogp import RBFKernel, SparseOnlineGP
from sb3_geogp.adaptation import Adaptation
from sb3_geogp.toolbox.benchmarks import GPClock


def test_clock_times_adaptation_inside_the_updates_and_nothing_without_it() -> None:
    rng = np.random.default_rng(0)
    batches = [(rng.uniform(size=(100, 2)), rng.normal(size=100)) for _ in range(4)]
    seconds = {}
    for adapt in (None, Adaptation(window=200, interval=100, steps=2)):
        gp = SparseOnlineGP(2, RBFKernel(lengthscale=0.3), max_basis=20, adapt=adapt)
        clock = GPClock(gp)
        for x, y in batches:
            gp.update(x, y)
        gp.predict(batches[0][0])
        seconds[adapt is not None] = dict(clock.seconds)
        assert int(gp.n_batches) == 4  # the wrapped methods still do their work
    assert seconds[False]["adaptation"] == 0.0
    # The adaptation's steps run inside update: they cannot take longer than the updates.
    assert 0.0 < seconds[True]["adaptation"] < seconds[True]["update"]
    assert all(s["predict"] > 0.0 for s in seconds.values())
