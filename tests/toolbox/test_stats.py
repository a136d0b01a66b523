"""Statistics over seeds against hand-computed values."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import stats as sps

from sb3_geogp.toolbox.stats import (
    bootstrap_ci,
    difference_ci,
    explained_variance,
    iqm,
    mean_ci,
    moments,
    permutation_pvalue,
    pooled_explained_variance,
    steps_to_threshold,
)


def test_mean_ci_hand_computed_with_student_t() -> None:
    x = np.array([[1.0, 2.0, 4.0, 7.0], [3.0, 3.0, 3.0, 3.0]])
    # Row 0: mean 3.5, s^2 = (6.25 + 2.25 + 0.25 + 12.25) / 3 = 7, half = t_{0.975, 3} s / 2.
    for policy in ("propagate", "omit"):
        mean, half = mean_ci(x, nan_policy=policy)  # type: ignore[arg-type]
        np.testing.assert_allclose(mean, [3.5, 3.0])
        np.testing.assert_allclose(half, [sps.t.ppf(0.975, 3) * np.sqrt(7.0) / 2, 0.0])
    _, half90 = mean_ci(x, level=0.9, nan_policy="omit")
    assert half90[0] == pytest.approx(sps.t.ppf(0.95, 3) * np.sqrt(7.0) / 2)


def test_mean_ci_nan_policies() -> None:
    x = np.array([[1.0, 3.0, np.nan, 5.0], [2.0, 4.0, 6.0, 8.0], [np.nan, 1.0, np.nan, np.nan]])
    mean, half = mean_ci(x, nan_policy="propagate")
    assert np.isnan(mean[0]) and np.isnan(half[0]) and np.isnan(mean[2]) and np.isnan(half[2])
    # Row 1: mean 5, s^2 = (9 + 1 + 1 + 9) / 3 = 20 / 3.
    assert mean[1] == pytest.approx(5.0)
    assert half[1] == pytest.approx(sps.t.ppf(0.975, 3) * np.sqrt(20 / 3) / 2)
    mean, half = mean_ci(x, nan_policy="omit")
    # Row 0 without its NaN: (1, 3, 5), mean 3, s^2 = 4, n = 3 (2 degrees of freedom).
    assert mean[0] == pytest.approx(3.0)
    assert half[0] == pytest.approx(sps.t.ppf(0.975, 2) * 2.0 / np.sqrt(3))
    assert mean[1] == pytest.approx(5.0) and half[1] == pytest.approx(
        sps.t.ppf(0.975, 3) * np.sqrt(20 / 3) / 2
    )
    assert mean[2] == 1.0 and np.isnan(half[2])  # one sample: no interval
    with pytest.raises(ValueError, match="nan_policy"):
        mean_ci(x, nan_policy="raise")  # type: ignore[arg-type]


def test_mean_ci_ignores_failed_fits() -> None:
    mean, half = mean_ci(np.array([[1.0, 3.0, np.nan], [np.nan, np.nan, 2.0]]), nan_policy="omit")
    assert mean[0] == 2.0 and np.isfinite(half[0])
    assert mean[1] == 2.0 and np.isnan(half[1])


def test_iqm_hand_computed() -> None:
    # n = 8: drop floor(0.25 * 8) = 2 at each end -> mean(3, 4, 5, 6) = 4.5.
    assert iqm(np.array([8, 1, 7, 2, 6, 3, 5, 4.0])) == pytest.approx(4.5)
    # n = 5: drop floor(1.25) = 1 at each end -> mean(2, 3, 100) = 35 (rliable, no
    # fractional weighting of the boundary runs).
    assert iqm(np.array([1.0, 2.0, 3.0, 100.0, 1000.0])) == pytest.approx(35.0)
    # n = 4: drop 1 at each end -> mean(2, 3) = 2.5; an outlier does not move it.
    assert iqm(np.array([1.0, 2.0, 3.0, 1e9])) == pytest.approx(2.5)
    # Per checkpoint along axis 0.
    curves = np.array([[0.0, 10.0], [1.0, 20.0], [2.0, 30.0], [3.0, 40.0]])
    np.testing.assert_allclose(iqm(curves), [1.5, 25.0])


def test_iqm_is_rliables_definition() -> None:
    x = np.random.default_rng(1).normal(size=(7, 3))
    np.testing.assert_allclose(iqm(x), sps.trim_mean(x, proportiontocut=0.25, axis=0))


def test_bootstrap_two_runs_hand_computed() -> None:
    # Resampling two runs: the mean is a (prob 1/4), (a + b) / 2 (1/2) or b (1/4), so the
    # 2.5 % and 97.5 % percentiles are a and b.
    est, low, high = bootstrap_ci(np.array([2.0, 6.0]))
    assert est == pytest.approx(4.0)
    assert (low, high) == (pytest.approx(2.0), pytest.approx(6.0))


def test_bootstrap_constant_and_single_run() -> None:
    est, low, high = bootstrap_ci(np.full(5, 3.0))
    assert (est, low, high) == (3.0, 3.0, 3.0)
    est, low, high = bootstrap_ci(np.array([7.0]))
    assert (est, low, high) == (7.0, 7.0, 7.0)


def test_bootstrap_matches_normal_theory_and_scipy() -> None:
    x = np.random.default_rng(0).normal(10.0, 2.0, size=400)
    est, low, high = bootstrap_ci(x, n_resamples=20_000)
    half = 1.96 * x.std(ddof=0) / np.sqrt(len(x))
    assert est == pytest.approx(x.mean())
    assert low == pytest.approx(x.mean() - half, abs=0.02)
    assert high == pytest.approx(x.mean() + half, abs=0.02)
    ref = sps.bootstrap((x,), np.mean, method="percentile", n_resamples=20_000, random_state=0)
    assert low == pytest.approx(ref.confidence_interval.low, abs=0.02)
    assert high == pytest.approx(ref.confidence_interval.high, abs=0.02)


def test_bootstrap_is_seeded_and_vectorised_over_curves() -> None:
    rng = np.random.default_rng(3)
    curves = rng.normal(size=(5, 4))
    a = bootstrap_ci(curves, stat="iqm", seed=7)
    b = bootstrap_ci(curves, stat="iqm", seed=7)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    est, low, high = a
    assert est.shape == low.shape == high.shape == (4,)
    assert np.all(low <= high)
    # Column by column equals the 1-d computation (same resampled rows for every column).
    for j in range(4):
        e, lo, hi = bootstrap_ci(curves[:, j], stat="iqm", seed=7)
        assert (e, lo, hi) == (pytest.approx(est[j]), pytest.approx(low[j]), pytest.approx(high[j]))


def test_bootstrap_rejects_bad_input() -> None:
    with pytest.raises(ValueError):
        bootstrap_ci(np.array([]))
    with pytest.raises(ValueError):
        bootstrap_ci(np.ones(3), level=1.0)
    with pytest.raises(ValueError):
        bootstrap_ci(np.ones(3), stat="mode")  # type: ignore[arg-type]


def test_difference_ci_hand_computed() -> None:
    # Constant groups: the difference is exact.
    est, low, high = difference_ci(np.full(4, 5.0), np.full(3, 2.0))
    assert (est, low, high) == (3.0, 3.0, 3.0)
    # Two runs minus a constant: the interval of the two-run mean, shifted.
    est, low, high = difference_ci(np.array([2.0, 6.0]), np.full(5, 1.0))
    assert est == pytest.approx(3.0)
    assert (low, high) == (pytest.approx(1.0), pytest.approx(5.0))


def test_steps_to_threshold_hand_computed() -> None:
    t = np.array([0, 1000, 2000, 3000])
    assert steps_to_threshold(t, np.array([-500, -300, -150, -100]), -200.0) == 2000
    assert steps_to_threshold(t, np.array([-500, -200, -250, -100]), -200.0) == 1000  # >=
    assert steps_to_threshold(t, np.array([-500, -400, -300, -250]), -200.0) == np.inf
    rows = np.array([[0, 5, 9, 9], [9, 9, 9, 9], [0, 0, 0, 0]])
    np.testing.assert_array_equal(steps_to_threshold(t, rows, 9), [2000, 0, np.inf])
    with pytest.raises(ValueError):
        steps_to_threshold(t, np.zeros(3), 0.0)


def test_pooled_explained_variance_is_sb3s_formula_on_the_concatenated_rollouts() -> None:
    """The moments summed over rollouts give SB3's ``explained_variance`` of all their points at
    once (brute force on the concatenation), NaN where the returns do not vary."""
    sb3_explained_variance = pytest.importorskip(
        "stable_baselines3.common.utils"
    ).explained_variance
    rng = np.random.default_rng(0)
    rollouts = [(rng.normal(m, s, n), rng.normal(0, 1, n)) for m, s, n in
                ((0.0, 1.0, 64), (5.0, 0.01, 32), (-2.0, 3.0, 128))]  # fmt: skip
    returns = [r for r, _ in rollouts]
    values = [r + noise * 0.5 for r, noise in rollouts]
    rows = [moments(r, r - v) for r, v in zip(returns, values, strict=True)]
    expected = sb3_explained_variance(np.concatenate(values), np.concatenate(returns))
    assert pooled_explained_variance(rows) == pytest.approx(expected, rel=1e-12)
    for r, v in zip(returns, values, strict=True):  # one rollout: SB3's formula too
        assert explained_variance(r, v) == pytest.approx(sb3_explained_variance(v, r), rel=1e-12)
    assert np.isnan(explained_variance(np.full(8, 3.0), np.zeros(8)))
    assert np.isnan(pooled_explained_variance([moments(np.full(8, 3.0), np.zeros(8))]))


def test_permutation_pvalue_is_the_share_of_all_splits_as_extreme() -> None:
    """Against every split of the pooled runs (35 for 3 + 4): the two-sided p-value is the
    share of splits whose |difference of means| reaches the observed one; runs all equal give 1."""
    a, b = np.array([1.0, 2.5, 4.0]), np.array([0.0, 0.5, -1.0, 2.0])
    pooled = np.concatenate([a, b])
    observed = abs(a.mean() - b.mean())
    extreme = [
        abs(pooled[list(idx)].mean() - np.delete(pooled, list(idx)).mean()) >= observed - 1e-12
        for idx in itertools.combinations(range(7), 3)
    ]
    assert permutation_pvalue(a, b) == pytest.approx(np.mean(extreme), rel=1e-12)
    assert permutation_pvalue(np.full(5, -99.9), np.full(5, -99.9)) == 1.0
    with pytest.raises(ValueError, match="at least one run"):
        permutation_pvalue(np.array([]), b)
