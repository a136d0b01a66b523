"""sb3_geogp.trends: each kind of trend's step, against numpy's least squares and closed forms.

The GP's use of them (what it feeds its GP, its predictions, its saved state) is tested in
tests/test_sparse_gp.py.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sb3_geogp import trends


def ridge(A: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The trend's ridge line by numpy: ``1e-3 n`` added to ``A^T A``'s diagonal."""
    return np.linalg.solve(A.T @ A + 1e-3 * len(y) * np.eye(A.shape[1]), A.T @ y)


def batch(n: int = 200, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, size=(n, 2))
    return x, 3.0 + 2.0 * x[:, 0] - x[:, 1] + 0.1 * rng.normal(size=n)


def moved(
    kind: str, coef: np.ndarray, x: np.ndarray, y: np.ndarray, error: np.ndarray | None
) -> np.ndarray:
    w = torch.tensor(coef)
    trends.move(
        kind, w, torch.tensor(x), torch.tensor(y), None if error is None else torch.tensor(error)
    )
    return w.numpy()


def test_linear_and_constant_trends_are_refitted_to_each_batch() -> None:
    """``"linear"`` takes the batch's ridge line whatever it held; ``"constant"`` its intercept
    alone, ``sum(y) / (1.001 n)`` (the ridge on the column of ones), with the slopes at 0."""
    x, y = batch()
    A = np.column_stack([x, np.ones(len(y))])
    old = np.array([5.0, -5.0, 5.0])
    np.testing.assert_allclose(moved("linear", old, x, y, None), ridge(A, y), rtol=1e-12)
    constant = moved("constant", old, x, y, None)
    np.testing.assert_allclose(constant, [0, 0, y.sum() / (1.001 * len(y))], rtol=1e-12)
    np.testing.assert_allclose(trends.value(torch.tensor(constant), torch.tensor(x)), constant[-1])


@pytest.mark.parametrize("kind", trends.LEVELS)
def test_levels_stay_without_errors_and_move_by_them(kind: str) -> None:
    """Without the model's errors (no basis yet) a level stays where it is. Errors of mean 0.5
    with little spread move the level by their mean, the rising level by what that exceeds
    two standard errors by; the sloped level's halves predict each other's errors no better
    than their means (a shift), so it moves as the level."""
    x, _ = batch()
    old = np.array([0.2, -0.3, 1.0])
    np.testing.assert_array_equal(moved(kind, old, x, x[:, 0], None), old)
    error = 0.5 + 1e-3 * np.random.default_rng(1).normal(size=len(x))
    step = error.mean()
    if kind == "rising_level":
        step -= 2.0 * error.std(ddof=1) / np.sqrt(len(error))
    expected = old + np.array([0, 0, step])
    np.testing.assert_allclose(moved(kind, old, x, x[:, 0], error), expected, rtol=1e-12)


def test_sloped_level_takes_the_ridge_line_of_errors_that_are_a_line() -> None:
    """Errors that are a line plus little noise: each half's line predicts the other half, so
    the whole ridge line of the errors is the step."""
    x, error = batch(seed=2)
    A = np.column_stack([x, np.ones(len(error))])
    step = trends.error_step(torch.tensor(A), torch.tensor(error)).numpy()
    np.testing.assert_allclose(step, ridge(A, error), rtol=1e-12)


def test_sloped_level_of_one_point_is_its_error() -> None:
    A = torch.tensor([[0.3, 0.7, 1.0]], dtype=torch.float64)
    np.testing.assert_array_equal(
        trends.error_step(A, torch.tensor([0.4], dtype=torch.float64)).numpy(), [0, 0, 0.4]
    )


@pytest.mark.parametrize(("mean", "step"), [(-1.0, 0.0), (0.5, 0.0), (3.0, 2.0)])
def test_rise_is_the_excess_of_the_mean_over_two_standard_errors(mean: float, step: float) -> None:
    """Errors made with sample standard deviation 5 over 100 points (standard error 0.5): a
    mean of -1 or 0.5 does not rise, one of 3 rises by 3 - 2 * 0.5."""
    noise = np.random.default_rng(3).normal(size=100)
    noise = (noise - noise.mean()) / noise.std(ddof=1)
    assert float(trends.rise(torch.tensor(mean + 5.0 * noise))) == pytest.approx(step, abs=1e-12)
    assert float(trends.rise(torch.tensor([2.5]))) == 2.5  # one point: no standard error


def test_no_trend_stays_at_zero() -> None:
    x, y = batch()
    np.testing.assert_array_equal(moved("none", np.zeros(3), x, y, y), np.zeros(3))


@pytest.mark.parametrize("flipped", [False, True])
def test_sloped_level_needs_a_line_that_carries_over_both_ways(flipped: bool) -> None:
    """One half's errors are a line in ``x_1`` that the other half's (all at ``x_1 = 10``,
    with no ``x_1`` effect) does not follow: the latter's line predicts the former better than
    its mean does, the former's line misses the latter by about 20 where its mean misses by
    about 1. A line that carries over one way only is noise: the step is the errors' mean
    alone (either half first)."""
    rng = np.random.default_rng(4)
    x0 = rng.uniform(0, 1, size=200)
    x1 = np.concatenate([np.full(100, 10.0), rng.uniform(0, 1, size=100)])
    error = 3.0 * x0 + np.concatenate([np.zeros(100), 2.0 * x1[100:]])
    order = np.r_[100:200, 0:100] if flipped else np.arange(200)
    x0, x1, error = x0[order], x1[order], error[order]
    A = np.column_stack([x0, x1, np.ones(200)])
    first, second = slice(None, 100), slice(100, None)
    for fit, held, carries in ((first, second, not flipped), (second, first, flipped)):
        line_sse = ((error[held] - A[held] @ ridge(A[fit], error[fit])) ** 2).sum()
        assert (line_sse < ((error[held] - error[fit].mean()) ** 2).sum()) == carries
    step = trends.error_step(torch.tensor(A), torch.tensor(error)).numpy()
    np.testing.assert_allclose(step, [0, 0, error.mean()], rtol=1e-12)
