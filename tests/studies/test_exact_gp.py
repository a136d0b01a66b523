"""The exact-GP reference against closed-form GP regression computed here by brute force."""

from __future__ import annotations

import numpy as np
import pytest

from sb3_geogp.studies.exact_gp import exact_gp
from tests.test_sparse_gp import matern, rbf

#: Matérn smoothness of each profile name but the RBF's.
NU = {"laplacian": 0.5, "matern32": 1.5, "matern52": 2.5}


def _gram(a: np.ndarray, b: np.ndarray, lengthscale: np.ndarray, kernel: str) -> np.ndarray:
    """Unit-variance correlation of every row of ``a`` with every row of ``b``."""
    if kernel == "rbf":
        return rbf(a, b, lengthscale)
    return matern(a, b, lengthscale, 1.0, NU[kernel])


def _standardised(y: np.ndarray) -> np.ndarray:
    return (y - y.mean()) / y.std()


def _log_evidence(
    x: np.ndarray, y: np.ndarray, hyper: tuple[np.ndarray, float, float], kernel: str
) -> float:
    """log N(z | 0, sigma_f^2 K + sigma_n^2 I) of the standardised targets ``z``."""
    lengthscale, signal, noise = hyper
    cov = signal * _gram(x, x, lengthscale, kernel) + noise * np.eye(len(y))
    z = _standardised(y)
    _, logdet = np.linalg.slogdet(cov)
    quad = z @ np.linalg.solve(cov, z)
    return float(-0.5 * (quad + logdet + len(y) * np.log(2 * np.pi)))


def _draw(n: int, lengthscale: np.ndarray, noise: float, seed: int) -> tuple[np.ndarray, ...]:
    """``n`` points of a zero-mean Laplacian GP with unit signal variance, plus noise."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, size=(n, len(lengthscale)))
    f = np.linalg.cholesky(_gram(x, x, lengthscale, "laplacian") + 1e-10 * np.eye(n))
    return x, 3.0 + 2.0 * (f @ rng.normal(size=n) + np.sqrt(noise) * rng.normal(size=n))


@pytest.mark.parametrize("kernel", ["laplacian", "matern32", "matern52", "rbf"])
def test_given_hyperparameters_give_the_closed_form_posterior_mean(kernel: str) -> None:
    x, y = _draw(60, np.array([0.5, 2.0]), 0.05, seed=1)
    hyper = (np.array([0.4, 1.5]), 1.3, 0.07)
    fit = exact_gp(x, y, kernel, fixed=hyper)
    new = np.random.default_rng(2).uniform(-1, 1, size=(25, 2))
    # m + s K_* (K + sigma_n^2 / sigma_f^2 I)^-1 (y - m) / s, with m and s the targets' mean and std
    gram = hyper[1] * _gram(x, x, hyper[0], kernel) + hyper[2] * np.eye(len(y))
    weights = np.linalg.solve(gram, _standardised(y))
    expected = y.mean() + y.std() * (hyper[1] * _gram(new, x, hyper[0], kernel)) @ weights
    np.testing.assert_allclose(fit.predict(new), expected, rtol=1e-9, atol=1e-9)
    assert fit.log_marginal_likelihood == pytest.approx(_log_evidence(x, y, hyper, kernel))
    np.testing.assert_array_equal(fit.lengthscale, hyper[0])


def test_fitted_hyperparameters_maximise_the_exact_evidence() -> None:
    """On draws from a known GP the fit's evidence, recomputed here, is what it reports, and is
    no lower than the evidence at the hyperparameters that generated the data."""
    truth = (np.array([0.3, 1.2]), 1.0, 0.05)
    x, y = _draw(200, truth[0], truth[2], seed=3)
    fit = exact_gp(x, y, "laplacian", fit_points=200)
    found = (fit.lengthscale, fit.signal_var, fit.noise_var)
    assert fit.log_marginal_likelihood == pytest.approx(_log_evidence(x, y, found, "laplacian"))
    # the truth's signal variance in standardised units: the draws' std is not 2 exactly
    scale = (2.0 / y.std()) ** 2
    at_truth = _log_evidence(x, y, (truth[0], scale * truth[1], scale * truth[2]), "laplacian")
    assert fit.log_marginal_likelihood >= at_truth
    # the shorter lengthscale is found shorter: the fit tells the two dimensions apart
    assert fit.lengthscale[0] < fit.lengthscale[1]


def test_fit_points_draw_a_subset_and_the_posterior_uses_all() -> None:
    x, y = _draw(120, np.array([0.5, 0.5]), 0.05, seed=4)
    sub = exact_gp(x, y, "laplacian", fit_points=40, seed=7)
    chosen = np.random.default_rng(7).choice(120, 40, replace=False)
    alone = exact_gp(x[chosen], y[chosen], "laplacian", fit_points=40, seed=7)
    # the same optimum, up to L-BFGS-B's tolerance (the starts differ: all points' spreads)
    np.testing.assert_allclose(sub.lengthscale, alone.lengthscale, rtol=1e-3)
    # conditioned on all 120 points, not on the 40: the posterior at a left-out point differs
    left_out = np.setdiff1d(np.arange(120), chosen)[:5]
    assert not np.allclose(sub.predict(x[left_out]), alone.predict(x[left_out]))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda x, y: (x, y[:-1]), "one target per input row"),
        (lambda x, y: (np.where(np.arange(x.size).reshape(x.shape) == 3, np.nan, x), y), "NaN"),
        (lambda x, y: (x, np.full_like(y, 2.0)), "constant"),
    ],
)
def test_bad_input_is_refused_with_the_fix(change, message: str) -> None:  # type: ignore[no-untyped-def]
    x, y = _draw(20, np.array([0.5]), 0.05, seed=5)
    with pytest.raises(ValueError, match=message):
        exact_gp(*change(x, y))
    with pytest.raises(ValueError, match="kernel must be one of"):
        exact_gp(x, y, "matern")
    with pytest.raises(ValueError, match="fit_points"):
        exact_gp(x, y, fit_points=1)
    with pytest.raises(ValueError, match="must be positive"):
        exact_gp(x, y, fixed=(np.array([0.5]), 1.0, 0.0))
    with pytest.raises(ValueError, match="must be positive"):
        exact_gp(x, y, fixed=(np.array([-0.5]), 1.0, 0.1))
