"""Per-rollout measurements: the pooled explained variance against SB3's formula."""

from __future__ import annotations

import numpy as np
import pytest
from stable_baselines3.common.utils import explained_variance

from sb3_geogp.comparison.measurement import moments, pooled_explained_variance


def test_pooled_explained_variance_is_sb3s_formula_on_the_concatenated_rollouts() -> None:
    """The moments summed over rollouts give SB3's ``explained_variance`` of all their points at
    once (brute force on the concatenation), NaN where the returns do not vary."""
    rng = np.random.default_rng(0)
    rollouts = [(rng.normal(m, s, n), rng.normal(0, 1, n)) for m, s, n in
                ((0.0, 1.0, 64), (5.0, 0.01, 32), (-2.0, 3.0, 128))]  # fmt: skip
    returns = [r for r, _ in rollouts]
    values = [r + noise * 0.5 for r, noise in rollouts]
    rows = [moments(r, r - v) for r, v in zip(returns, values, strict=True)]
    expected = explained_variance(np.concatenate(values), np.concatenate(returns))
    assert pooled_explained_variance(rows) == pytest.approx(expected, rel=1e-12)
    assert np.isnan(pooled_explained_variance([moments(np.full(8, 3.0), np.zeros(8))]))
