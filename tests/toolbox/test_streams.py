"""On-line passes over recorded episodes: batches of whole episodes, in order."""

from __future__ import annotations

import numpy as np
import pytest

from sb3_geogp import RBFKernel, SparseOnlineGP
from sb3_geogp.toolbox.streams import episode_batches, fit_online


def test_episode_batches_cover_the_rows_in_whole_episodes() -> None:
    starts = np.zeros(10, dtype=bool)
    starts[[0, 3, 4, 8]] = True  # episodes of 3, 1, 4 and 2 rows
    assert list(episode_batches(starts, 2)) == [slice(0, 4), slice(4, 10)]
    assert list(episode_batches(starts, 3)) == [slice(0, 8), slice(8, 10)]
    assert list(episode_batches(starts, None)) == [slice(0, 10)]
    assert list(episode_batches(np.zeros(0, dtype=bool), 2)) == []
    with pytest.raises(ValueError, match="positive"):
        list(episode_batches(starts, 0))


def test_fit_online_is_updates_batch_after_batch() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(size=(60, 2))
    y = np.sin(4 * x[:, 0])
    starts = np.zeros(60, dtype=bool)
    starts[::10] = True
    gp = fit_online(RBFKernel([0.3, 0.3]), x, y, starts, 20, 0.01, None, episodes_per_batch=2)
    ref = SparseOnlineGP(2, RBFKernel([0.3, 0.3]), max_basis=20, noise_var=0.01)
    for a in range(0, 60, 20):
        ref.update(x[a : a + 20], y[a : a + 20], episode_starts=starts[a : a + 20])
    np.testing.assert_array_equal(gp.predict(x)[0].numpy(), ref.predict(x)[0].numpy())
    assert gp.n_basis == ref.n_basis
