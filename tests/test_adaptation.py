"""sb3_geogp.adaptation: settings, the sparse posterior, and the GP adapting to its stream."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable

import numpy as np
import pytest
import torch
from scipy.optimize import minimize
from scipy.stats import norm

from sb3_geogp import GeodesicKernel, MaternKernel, RBFKernel, SparseOnlineGP
from sb3_geogp.adaptation import (
    WEIGHT_FLOOR,
    Adaptation,
    Summary,
    age_weights,
    forget_likelihood,
    gaussian_nll,
    jittered_cholesky,
    lagged_forgetting_scores,
    linear_moments,
    nlpd,
    posterior_cholesky,
    sparse_posterior,
    thinned,
    whitened_prior,
)
from tests.test_sparse_gp import assert_same_state, matern, nystrom_posterior, rbf, snapshot


# -- settings -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "bad",
    [
        dict(lengthscale_range=(2.0, 1.0)),
        dict(noise_bounds=(0.0, 1.0)),
        dict(variance_bounds=(1.0, float("inf"))),
        dict(noise_bounds=(1e-3,)),
        dict(forgetting=()),
        dict(forgetting=(1.0, 1.2)),
        dict(window=0),
        dict(interval=2.5),
        dict(steps=-1),
        dict(lr=float("nan")),
        dict(prior_sd=0.0),
        dict(prior_sd=float("inf")),
        dict(max_gap=0),
        dict(max_gap=None),
        dict(score_points=0),
        dict(fold_points=1.5),
        dict(settle=1),
        dict(whole_batch="yes"),
        dict(follow_spread=1),
        dict(follow_spread="narrow"),
        dict(drift_tol=1.0),
        dict(drift_tol=float("nan")),
        dict(fit_floor=1.0),
        dict(fit_floor=float("-inf")),
        dict(fit_spacing=0),
        dict(fit_spacing=2.5),
        dict(summary="snapshots"),
        dict(forgetting_score="lag"),
    ],
)
def test_bad_settings_raise_naming_the_setting(bad: dict) -> None:
    name = next(iter(bad))
    with pytest.raises(ValueError, match=f"Adaptation.{name}"):
        Adaptation(**bad)


def test_bad_adapt_argument_leaves_nothing_built() -> None:
    with pytest.raises(ValueError, match="adapt must be"):
        SparseOnlineGP(2, "rbf", adapt="yes")  # type: ignore[arg-type]


def test_adapt_as_a_dict_is_the_adaptation_of_those_settings() -> None:
    """The form a command line or a YAML file can give (``--gp-option 'adapt={...}'``)."""
    gp = SparseOnlineGP(2, "rbf", adapt={"prior_sd": 0.1, "steps": 3})
    assert gp.adaptation == Adaptation(prior_sd=0.1, steps=3)
    with pytest.raises(ValueError, match=r"unknown settings \['prior'\]"):
        SparseOnlineGP(2, "rbf", adapt={"prior": 0.1})
    with pytest.raises(ValueError, match=r"Adaptation\.prior_sd"):
        SparseOnlineGP(2, "rbf", adapt={"prior_sd": -1.0})


@pytest.mark.parametrize("settle", [True, False])
@pytest.mark.parametrize("max_gap", [1, 2, 6, 8])
def test_refits_on_powers_of_two_then_every_max_gap_blocks(max_gap: int, settle: bool) -> None:
    """With ``settle=False`` only the first block and the multiples of ``max_gap`` refit."""
    powers = {2**k for k in range(8) if 2**k < max_gap} if settle else {1}
    multiples = set(range(max_gap, 101, max_gap))
    refits = {b for b in range(1, 101) if Adaptation(max_gap=max_gap, settle=settle).refits(b)}
    assert refits == powers | multiples
    # The longest wait between refits is max_gap blocks.
    assert max(np.diff(sorted(refits | {0}))) <= max_gap


@pytest.mark.parametrize(
    ("n", "cap"), [(10, None), (10, 10), (10, 20), (10, 3), (4096, 512), (7, 2)]
)
def test_thinned_runs_cover_every_point_once(n: int, cap: int | None) -> None:
    index, count = thinned(n, cap)
    assert int(count.sum()) == n and len(index) <= (cap or n)
    # Each representative lies inside its own run, and the runs tile 0..n-1 in order.
    ends = count.cumsum(0)
    starts = ends - count
    assert bool(((starts <= index) & (index < ends)).all())
    stride = 1 if cap is None or cap >= n else -(-n // cap)
    assert set(count[:-1].tolist()) <= {stride} and 1 <= int(count[-1]) <= stride
    if cap is None or cap >= n:
        assert index.tolist() == list(range(n)) and count.tolist() == [1] * n


# -- numerics -----------------------------------------------------------------------------------
def test_jittered_cholesky_repairs_a_singular_matrix() -> None:
    v = torch.randn(6, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    A = v @ v.T  # rank 2
    L, jitter = jittered_cholesky(A, 1.0)
    assert jitter > 0
    torch.testing.assert_close(L @ L.T, A + jitter * torch.eye(6, dtype=A.dtype))
    L, jitter = jittered_cholesky(A + torch.eye(6, dtype=A.dtype), 1.0)
    assert jitter == 0.0


def test_jittered_cholesky_takes_the_first_jitter_of_its_ladder_that_works() -> None:
    """The jitters tried are 0, then 1e-6 scale growing 10x: the one returned factorises and
    the step below it does not (checked directly); a matrix no jitter repairs raises."""
    eye = torch.eye(5, dtype=torch.float64)
    A = torch.diag(torch.tensor([1.0, 1.0, 1.0, 1.0, -3e-3], dtype=torch.float64))
    scale = 2.0
    _, jitter = jittered_cholesky(A, scale)
    steps = math.log10(jitter / (1e-6 * scale))
    assert abs(steps - round(steps)) < 1e-9
    assert int(torch.linalg.cholesky_ex(A + jitter * eye).info) == 0
    assert int(torch.linalg.cholesky_ex(A + jitter / 10 * eye).info) != 0
    with pytest.raises(FloatingPointError, match="not positive definite"):
        jittered_cholesky(A - 1e6 * eye, 1.0)


@pytest.mark.parametrize("n", [40, 12])  # more than twice the 9 inducing points, and fewer
def test_sparse_posterior_is_the_nystrom_gp_with_per_point_noise(n: int) -> None:
    rng = np.random.default_rng(0)
    x, z, probe = rng.uniform(size=(n, 2)), rng.uniform(size=(9, 2)), rng.uniform(size=(7, 2))
    y, noise = rng.normal(size=n), rng.uniform(0.05, 2.0, size=n)
    Kzz, Kxz, Kpz = rbf(z, z, 0.4), rbf(x, z, 0.4), rbf(probe, z, 0.4)
    t = torch.as_tensor
    alpha, P = sparse_posterior(t(Kzz), t(Kxz), t(y), t(noise), 1.0)
    mean = Kpz @ alpha.numpy()
    Q = np.linalg.inv(Kzz)
    var = 1.0 - np.sum(Kpz @ Q * Kpz, axis=1) + np.sum(Kpz @ P.numpy() * Kpz, axis=1)
    # Reference with per-point noise: whiten the data, then the scalar-noise reference applies.
    white = 1 / np.sqrt(noise)
    ref_mean, ref_var = nystrom_posterior(Kzz, Kxz * white[:, None], Kpz, 1.0, y * white, 1.0)
    np.testing.assert_allclose(mean, ref_mean, atol=1e-10)
    np.testing.assert_allclose(var, ref_var, atol=1e-10)
    torch.testing.assert_close(P, P.T, rtol=0, atol=0)
    assert float(torch.linalg.eigvalsh(P).min()) > 0


@pytest.mark.parametrize(
    ("n", "given_inverse"), [(40, False), (18, False), (12, False), (12, True)]
)
def test_summary_of_data_is_its_projected_likelihood(n: int, given_inverse: bool) -> None:
    """``Summary.of_data`` against the formulas with explicit inverses, on each of its paths
    (9 inducing points: 12 points with ``K_zz^-1`` given through ``K_zz^-1 K_zx``; otherwise
    through the whitened sums, by each of the two ways :class:`Projection` forms them)."""
    rng = np.random.default_rng(1)
    x, z = rng.uniform(size=(n, 2)), rng.uniform(size=(9, 2))
    y, noise = rng.normal(size=n), rng.uniform(0.05, 2.0, size=n)
    Kzz, Kxz = rbf(z, z, 0.4) + 1e-6 * np.eye(9), rbf(x, z, 0.4)
    t = torch.as_tensor
    inverse = t(np.linalg.inv(Kzz)) if given_inverse else None
    summary = Summary.of_data(t(Kzz), t(Kxz), t(x), t(y), t(noise), 1.0, inverse)
    B = np.linalg.solve(Kzz, Kxz.T)  # K_zz^-1 K_zx
    scale = np.abs(B).max() ** 2 / noise.min()
    np.testing.assert_allclose(summary.precision, B / noise @ B.T, atol=1e-9 * scale)
    np.testing.assert_allclose(summary.shift, B @ (y / noise), atol=1e-9 * scale * n)
    np.testing.assert_allclose(summary.unit_shift, B @ (1 / noise), atol=1e-9 * scale * n)
    np.testing.assert_allclose(summary.input_shift, B @ (x / noise[:, None]), atol=1e-9 * scale * n)


def test_summary_of_a_posterior_is_the_likelihood_it_was_built_from() -> None:
    """The sparse posterior of data times a summary implies, relative to its prior, the
    summary plus the data's :meth:`Summary.of_data`; its unit and input shifts are those of
    pseudo-observations at the inducing inputs, which are the data's own when the data lie
    there (each row of ``K_zz^-1 K_zx`` is then a unit vector)."""
    rng = np.random.default_rng(2)
    z = rng.uniform(size=(9, 2))
    Kzz = rbf(z, z, 0.4) + 1e-6 * np.eye(9)
    t = torch.as_tensor

    def data(x: np.ndarray) -> tuple[torch.Tensor, ...]:
        y, noise = rng.normal(size=len(x)), rng.uniform(0.05, 2.0, size=len(x))
        return t(rbf(x, z, 0.4)), t(x), t(y), t(noise)

    Kxz, x, y, noise = data(rng.uniform(size=(30, 2)))
    earlier = Summary.of_data(t(Kzz), *data(rng.uniform(size=(12, 2))), 1.0)
    alpha, P = sparse_posterior(t(Kzz), Kxz, y, noise, 1.0, earlier)
    implied = Summary.of_posterior(alpha, posterior_cholesky(P), t(np.linalg.inv(Kzz)), t(z))
    both = Summary.of_data(t(Kzz), Kxz, x, y, noise, 1.0)
    scale = float(implied.precision.abs().max())
    for got, want in zip(
        implied[:2], (earlier.precision + both.precision, earlier.shift + both.shift), strict=True
    ):
        torch.testing.assert_close(got, want, rtol=0, atol=1e-8 * scale)
    ones = torch.ones(9, dtype=torch.float64)
    torch.testing.assert_close(implied.unit_shift, implied.precision @ ones, rtol=1e-12, atol=0)
    torch.testing.assert_close(implied.input_shift, implied.precision @ t(z), rtol=1e-12, atol=0)
    at_z = rng.integers(9, size=20)
    _, x, y, noise = data(z[at_z])
    Kxz = t(Kzz[at_z])  # with the nugget: rows of K_zz itself
    alpha, P = sparse_posterior(t(Kzz), Kxz, y, noise, 1.0)
    implied = Summary.of_posterior(alpha, posterior_cholesky(P), t(np.linalg.inv(Kzz)), t(z))
    direct = Summary.of_data(t(Kzz), Kxz, x, y, noise, 1.0)
    for got, want in zip(implied, direct, strict=True):
        torch.testing.assert_close(got, want, rtol=0, atol=1e-8 * float(want.abs().max()))


@pytest.mark.parametrize("lam", [1.0, 0.7, 0.1])
def test_forgetting_the_likelihood_scales_what_the_posterior_implies(lam: float) -> None:
    """``forget_likelihood`` leaves a posterior whose implied likelihood
    (:meth:`Summary.of_posterior`) is ``lam`` times the original's, precision and shift."""
    rng = np.random.default_rng(3)
    z = rng.uniform(size=(9, 2))
    Kzz = rbf(z, z, 0.4) + 1e-6 * np.eye(9)
    t = torch.as_tensor
    x = rng.uniform(size=(30, 2))
    noise = t(rng.uniform(0.05, 0.5, size=30))
    alpha, P = sparse_posterior(t(Kzz), t(rbf(x, z, 0.4)), t(rng.normal(size=30)), noise, 1.0)
    Q = t(np.linalg.inv(Kzz))
    L = posterior_cholesky(P)
    before = Summary.of_posterior(alpha, L, Q, t(z))
    alpha_new, P_new = forget_likelihood(alpha, L, Q, lam)
    after = Summary.of_posterior(alpha_new, posterior_cholesky(P_new), Q, t(z))
    for got, want in zip(after[:2], before[:2], strict=True):
        torch.testing.assert_close(got, lam * want, rtol=0, atol=1e-8 * float(want.abs().max()))
    torch.testing.assert_close(P_new, P_new.T, rtol=0, atol=0)


def test_lagged_scores_are_those_of_each_candidates_posterior_solved_directly() -> None:
    """Each candidate's score is the weighted negative log density of the batch under the
    posterior of the prior, the previous batch and ``lambda`` times the older data, solved
    for each ``lambda`` by brute force (an (m, m) inverse per candidate from the data's
    :meth:`Summary.of_data`); ``lambda = 1`` is the current posterior's own prediction."""
    rng = np.random.default_rng(4)
    z = rng.uniform(size=(8, 1))
    Kzz = rbf(z, z, 0.3) + 1e-3 * np.eye(8)  # well conditioned: P is formed from Q
    Q = np.linalg.inv(Kzz)
    t = torch.as_tensor

    def data(n: int, shift: float) -> tuple[np.ndarray, ...]:
        x = rng.uniform(size=(n, 1))
        return rbf(x, z, 0.3), np.sin(4 * x[:, 0]) + shift + 0.1 * rng.normal(size=n), x

    def likelihood(rows: np.ndarray, y: np.ndarray, x: np.ndarray, noise: np.ndarray) -> Summary:
        return Summary.of_data(t(Kzz), t(rows), t(x), t(y), t(noise), 1.0)

    (rows_o, y_o, x_o), (rows_b, y_b, x_b) = data(40, 0.0), data(20, 1.0)
    noise_b = rng.uniform(0.005, 0.02, size=20)
    older, previous = (
        likelihood(rows_o, y_o, x_o, np.full(40, 0.01)),
        likelihood(rows_b, y_b, x_b, noise_b),
    )
    cov = np.linalg.inv(Q + older.precision.numpy() + previous.precision.numpy())
    alpha = Q @ cov @ (older.shift.numpy() + previous.shift.numpy())
    P = Q @ cov @ Q  # the current posterior in Csato-Opper form
    x = rng.uniform(size=(15, 1))
    yn = np.sin(4 * x[:, 0]) + 1.5
    rows = rbf(x, z, 0.3)
    H = rows @ Q
    gamma = 1.0 - np.sum(H * rows, axis=1)
    count = rng.integers(1, 4, size=15).astype(float)
    candidates = np.array([1.0, 0.5, 0.1])
    L = posterior_cholesky(t(P))
    got = lagged_forgetting_scores(
        L,
        whitened_prior(L, t(Kzz)),
        t(alpha),
        (t(rows_b), t(y_b), t(noise_b)),
        (t(rows), t(gamma), t(yn), t(count)),
        0.01,
        t(candidates),
    )
    want = []
    for lam in candidates:
        cov = np.linalg.inv(Q + previous.precision.numpy() + lam * older.precision.numpy())
        mu = cov @ (previous.shift.numpy() + lam * older.shift.numpy())
        var = gamma + np.sum((H @ cov) * H, axis=1) + 0.01
        want.append(count @ (0.5 * (np.log(2 * np.pi * var) + (yn - H @ mu) ** 2 / var)))
    np.testing.assert_allclose(got.numpy(), want, rtol=1e-8)
    assert got.argmin() > 0  # the batch moved on: forgetting the older data predicts it best


# -- the adapting GP ----------------------------------------------------------------------------
#: ``cov(a, b, lengthscale, variance)`` of a GP the tests draw from.
Covariance = Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]


def matern52(a: np.ndarray, b: np.ndarray, ls: np.ndarray, variance: float = 1.0) -> np.ndarray:
    return matern(a, b, ls, variance, 2.5)


def gp_draw(
    rng: np.random.Generator, x: np.ndarray, ls: np.ndarray, noise: float, cov: Covariance = rbf
) -> tuple[np.ndarray, np.ndarray]:
    """A draw of a zero-mean unit-variance GP (RBF by default) at ``x`` and its noisy
    observations."""
    K = cov(x, x, ls, 1.0) + 1e-9 * np.eye(len(x))
    f = np.linalg.cholesky(K) @ rng.normal(size=len(x))
    return f, f + np.sqrt(noise) * rng.normal(size=len(x))


def exact_ml_optimum(x: np.ndarray, y: np.ndarray, cov: Covariance = rbf) -> np.ndarray:
    """Lengthscales, signal and noise variance maximising the exact marginal likelihood."""

    def nlml(log_p: np.ndarray) -> float:
        ls, var, noise = np.exp(log_p[:-2]), np.exp(log_p[-2]), np.exp(log_p[-1])
        L = np.linalg.cholesky(cov(x, x, ls, var) + noise * np.eye(len(x)))
        a = np.linalg.solve(L, y)
        return 0.5 * a @ a + np.log(np.diag(L)).sum()

    starts = [np.log([0.3, 0.3, 1.0, 0.1]), np.log([0.1, 1.0, 0.5, 0.01])]
    best = min(
        (minimize(nlml, s, method="Nelder-Mead", options=dict(maxiter=4000)) for s in starts),
        key=lambda r: r.fun,
    )
    return np.exp(best.x)


@pytest.mark.parametrize(("kernel", "cov"), [("rbf", rbf), (MaternKernel(nu=2.5), matern52)])
def test_adaptation_recovers_the_marginal_likelihood_optimum(
    kernel: str | MaternKernel, cov: Covariance
) -> None:
    """Draws of a known GP; the reference is the exact-GP optimum on the retained window."""
    rng = np.random.default_rng(1)
    true_ls, true_noise = np.array([0.15, 0.6]), 0.04
    x = rng.uniform(size=(2400, 2))
    _, y = gp_draw(rng, x, true_ls, true_noise, cov)
    y = 3.0 + 2.0 * y  # the adaptation also learns the target mean and scale
    adapt = Adaptation(window=400, interval=200, steps=10, lr=0.1, forgetting=(1.0,))
    gp = SparseOnlineGP(2, kernel, max_basis=150, novelty_tol=1e-3, adapt=adapt)
    for i in range(0, len(x), 200):
        gp.update(x[i : i + 200], y[i : i + 200])
    wx, wy, _, _ = (t.numpy() for t in gp.window.data())
    ref = exact_ml_optimum(wx, (wy - wy.mean()), cov)
    scale2 = float(gp.y_scale) ** 2
    np.testing.assert_allclose(gp.lengthscale.numpy(), ref[:2], rtol=0.25)
    np.testing.assert_allclose(float(gp.noise_var) * scale2, ref[3], rtol=0.5)
    assert gp.last_stats["noise_var"] == float(gp.noise_var)
    assert np.isfinite(gp.last_stats["nlpd"])


def test_hyperprior_vanishes_when_wide_and_holds_the_start_when_narrow() -> None:
    """The hyperprior's two limits, on draws of a known GP: a prior of sd 1e8 gives the fit
    without one (1e-10); one of sd 1e-4 keeps the lengthscales and the signal variance
    within 5% of where they started, which the same data without it move by more than 40%."""
    rng = np.random.default_rng(1)
    x = rng.uniform(size=(1200, 2))
    _, y = gp_draw(rng, x, np.array([0.15, 0.6]), 0.04)

    def fit(prior_sd: float | None) -> SparseOnlineGP:
        adapt = Adaptation(
            window=400, interval=200, steps=10, lr=0.1, forgetting=(1.0,), prior_sd=prior_sd
        )
        gp = SparseOnlineGP(2, "rbf", max_basis=150, novelty_tol=1e-3, adapt=adapt)
        for i in range(0, len(x), 200):
            gp.update(x[i : i + 200], y[i : i + 200])
        return gp

    free, wide, narrow = fit(None), fit(1e8), fit(1e-4)
    for get in (lambda g: g.lengthscale, lambda g: g.kernel.variance, lambda g: g.noise_var):
        np.testing.assert_allclose(get(wide).numpy(), get(free).numpy(), rtol=1e-10)
    moved = np.abs(np.log((free.lengthscale / free.ls_start).numpy()))
    assert moved.max() > np.log(1.4)
    held = (narrow.lengthscale / narrow.ls_start).numpy()
    np.testing.assert_allclose(held, 1.0, rtol=0.05)
    assert abs(float(narrow.kernel.variance) - 1.0) < 0.05


def test_forgetting_is_chosen_from_the_newest_block() -> None:
    """A target that jumps each block is predicted best by forgetting; a fixed one is not."""
    rng = np.random.default_rng(2)
    adapt = Adaptation(window=600, interval=100, steps=0, forgetting=(1.0, 0.5, 0.1))
    chosen = {}
    for drift in (0.0, 3.0):
        gp = SparseOnlineGP(1, RBFKernel(lengthscale=0.3), max_basis=30, adapt=adapt)
        for block in range(6):
            x = rng.uniform(size=(100, 1))
            gp.update(x, np.sin(4 * x[:, 0]) + drift * block + 0.1 * rng.normal(size=100))
        chosen[drift] = gp.last_stats["forgetting"]
    assert chosen[0.0] == 1.0
    assert chosen[3.0] < 1.0


def test_forgetting_scores_count_each_sampled_point_for_its_run() -> None:
    """With ``score_points=8``, a 40-point batch is scored on its points 2, 7, ..., 37, each
    counted 5 times: the candidates' scores are the negative log densities of those points
    under the posterior forgotten by each candidate (brute force from the GP's predictions)."""
    rng = np.random.default_rng(6)
    candidates = (1.0, 0.5, 0.1)
    adapt = Adaptation(window=500, interval=400, steps=0, forgetting=candidates, score_points=8)
    gp = SparseOnlineGP(1, RBFKernel(lengthscale=0.3), max_basis=20, adapt=adapt)
    gp.update(rng.uniform(size=(60, 1)), rng.normal(size=60))
    x = rng.uniform(size=(40, 1))
    y = np.sin(3 * x[:, 0]) + 1.0
    mean, latent = (t.numpy() for t in gp.predict(x[2::5]))
    s, mu0, var, noise = (
        float(gp.y_scale),
        float(gp.y_mean),
        float(gp.kernel.variance),
        float(gp.noise_var),
    )
    mu, v, yn = (mean - mu0) / s, latent / s**2, (y[2::5] - mu0) / s
    expected = []
    for lam in candidates:
        total = (1 - lam) * var + lam * v + noise
        nll = 0.5 * (np.log(2 * np.pi * total) + (yn - np.sqrt(lam) * mu) ** 2 / total)
        expected.append(5 * nll.sum())
    before = gp.forgetting_scores.clone()
    gp.update(x, y)
    np.testing.assert_allclose((gp.forgetting_scores - before).numpy(), expected, rtol=1e-10)


def test_between_refits_only_the_forgetting_is_chosen() -> None:
    """``max_gap=4`` with a block per batch: targets, lengthscale, noise and posterior are
    refitted after batches 1, 2, 4 and 8 only; the forgetting is chosen after every batch
    (its scores start afresh)."""
    rng = np.random.default_rng(7)
    adapt = Adaptation(window=100, interval=50, steps=3, max_gap=4, forgetting=(1.0, 0.3))
    gp = SparseOnlineGP(1, RBFKernel(lengthscale=0.3), max_basis=20, adapt=adapt)
    changed = []
    for i in range(10):
        before = (gp.lengthscale.clone(), gp.y_mean.clone(), gp.noise_var.clone())
        x = rng.uniform(size=(50, 1))
        gp.update(x, (1 + i) * np.sin(4 * x[:, 0]) + 2.0 * i + 0.1 * rng.normal(size=50))
        after = (gp.lengthscale, gp.y_mean, gp.noise_var)
        changed.append(not all(torch.equal(a, b) for a, b in zip(before, after, strict=True)))
        assert int(gp.n_blocks) == i + 1 and not bool(gp.forgetting_scores.any())
    assert [i + 1 for i, c in enumerate(changed) if c] == [1, 2, 4, 8]
    assert gp.block_forgetting == 0.3  # the drift is seen by the choice made after every batch


def test_a_drifted_block_refits() -> None:
    """``drift_tol=2`` with scheduled refits only on block 1 (``max_gap`` beyond the stream),
    a block per batch: a block whose targets, in the units of the moment, have a mean square
    outside [1/2, 2] (here: the targets jump by 6 at batch 5) refits: target mean and scale
    become the weighted moments of the window, the hyperparameters move and the posterior is
    the exact sparse posterior of the window. The other blocks keep units and
    hyperparameters."""
    adapt = Adaptation(
        window=1000,
        interval=50,
        steps=3,
        max_gap=100,
        settle=False,
        drift_tol=2.0,
        forgetting=(0.5,),
    )
    rng = np.random.default_rng(11)
    batches = []
    for i in range(8):
        x = rng.uniform(size=(50, 1))
        jump = 6.0 if i >= 4 else 0.0
        batches.append((x, np.sin(4 * x[:, 0]) + jump + 0.1 * rng.normal(size=50)))
    gp = SparseOnlineGP(1, RBFKernel(lengthscale=0.3), max_basis=20, adapt=adapt)
    refitted, retargeted = [], []
    for i, (x, y) in enumerate(batches):
        hyper = (gp.lengthscale.clone(), gp.kernel.variance.clone(), gp.noise_var.clone())
        units = (float(gp.y_mean), float(gp.y_scale))
        gp.update(x, y)
        if i > 0:  # the first batch is not scored: the basis was empty
            drift = np.mean(((y - units[0]) / units[1]) ** 2)
            assert gp.last_stats["target_drift"] == pytest.approx(drift, rel=1e-12)
        after = (gp.lengthscale, gp.kernel.variance, gp.noise_var)
        refitted.append(not all(torch.equal(a, b) for a, b in zip(hyper, after, strict=True)))
        retargeted.append((float(gp.y_mean), float(gp.y_scale)) != units)
        if i + 1 == 5:
            wx, wy, batch, _ = (t.numpy() for t in gp.window.data())
            w = 0.5 ** (batch.max() - batch)
            mean = np.sum(w * wy) / np.sum(w)
            scale = np.sqrt(np.sum(w * (wy - mean) ** 2) / np.sum(w))
            assert float(gp.y_mean) == pytest.approx(mean, rel=1e-12)
            assert float(gp.y_scale) == pytest.approx(scale, rel=1e-12)
            assert_weighted_sparse_posterior(gp, wx, wy, w, rng)
    assert [i + 1 for i, c in enumerate(refitted) if c] == [1, 5]
    assert [i + 1 for i, c in enumerate(retargeted) if c] == [1, 5]


def assert_weighted_sparse_posterior(
    gp: SparseOnlineGP, x: np.ndarray, y: np.ndarray, w: np.ndarray, rng: np.random.Generator
) -> None:
    """``gp`` (RBF) predicts, to 1e-8, as the exact sparse posterior of ``(x, y)`` with noise
    ``sigma_n^2 / w`` and its own basis, hyperparameters and prior mean ``c + b^T x`` (the
    Nystrom GP, an (n, n) solve)."""
    c, b = float(gp.y_mean), gp.y_slope.numpy()
    yn = (y - c - x @ b) / float(gp.y_scale)
    ls, var, z = gp.lengthscale.numpy(), float(gp.kernel.variance), gp.basis_inputs.numpy()
    white = np.sqrt(w / float(gp.noise_var))
    Kzz = rbf(z, z, ls, var) + np.diag(gp.nugget[: gp.n_basis].numpy())
    probe = rng.uniform(size=(9, x.shape[1]))
    ref_mean, ref_var = nystrom_posterior(
        Kzz, rbf(x, z, ls, var) * white[:, None], rbf(probe, z, ls, var), var, yn * white, 1.0
    )
    mean, latent = gp.predict(probe)
    s = float(gp.y_scale)
    np.testing.assert_allclose(mean.numpy(), ref_mean * s + c + probe @ b, atol=1e-8 * s)
    np.testing.assert_allclose(latent.numpy(), ref_var * s**2, atol=1e-8 * s**2)


@pytest.mark.parametrize("prior_mean", ["constant", "linear"])
def test_rebuilt_posterior_is_the_sparse_posterior_of_the_weighted_window(prior_mean: str) -> None:
    rng = np.random.default_rng(3)
    # The window holds every point fed: the summary of dropped points stays empty.
    adapt = Adaptation(window=400, interval=100, steps=3, forgetting=(0.5,))
    gp = SparseOnlineGP(2, "rbf", max_basis=40, adapt=adapt, prior_mean=prior_mean)
    for _ in range(4):
        x = rng.uniform(size=(100, 2))
        gp.update(x, np.sin(3 * x[:, 0]) + x[:, 1] + 0.1 * rng.normal(size=100))
    x, y, block, decay = (t.numpy() for t in gp.window.data())
    w = 0.5 ** (block.max() - block)
    assert_weighted_sparse_posterior(gp, x, y, w, rng)
    assert not decay.any()
    if prior_mean == "linear":  # the weighted least-squares line of the window
        H = np.column_stack([np.ones(len(x)), x]) * np.sqrt(w)[:, None]
        coef = np.linalg.lstsq(H, y * np.sqrt(w), rcond=None)[0]
        np.testing.assert_allclose([float(gp.y_mean), *gp.y_slope.numpy()], coef, rtol=1e-9)


@pytest.mark.parametrize("drift_rate", [0.0, 3.0])
@pytest.mark.parametrize("summary", ["fold", "snapshot"])
@pytest.mark.parametrize(
    ("forgetting", "drift", "fit_noise", "fold", "prior_mean"),
    [
        (1.0, 0.0, False, None, "constant"),
        (0.7, 0.0, False, None, "constant"),
        (0.7, 0.5, False, None, "constant"),
        (0.7, 0.5, True, None, "constant"),
        (1.0, 0.0, False, 10, "constant"),
        (0.7, 0.5, True, 10, "constant"),
        (0.7, 0.5, False, None, "linear"),
        (0.7, 0.5, True, 10, "linear"),
    ],
)
def test_summary_keeps_what_the_dropped_points_said(
    forgetting: float,
    drift: float,
    fit_noise: bool,
    fold: int | None,
    prior_mean: str,
    summary: str,
    drift_rate: float,
) -> None:
    """With the kernel and the basis fixed, a 150-point window on a 1200-point stream, fed in
    50-point batches and adapting every 100 points, gives the exact sparse posterior of all
    1200 points, weighted ``forgetting ** age`` with ``age`` in batches, times ``exp(-r D)``
    with ``drift_forgetting=r`` and ``D`` the drift fed with the batches after; also when the target
    mean and scale, re-estimated each block, follow a drift, and when the noise is re-fitted
    each block (the summarised points then count with the final noise, as in the window),
    and when the prior mean is a line re-fitted each block to targets whose trend drifts.
    With ``fold_points=10`` each dropped batch of 50 counts as its points 2, 7, ..., 47 (the
    middles of runs of 5), each weighted 5 times.

    A snapshot summary holds the data as pseudo-observations at the basis inputs, which a
    change of target units moves as it moves the data only where the data lie there: its
    stream is drawn from the basis inputs. Every block refits, so each snapshot is of an exact
    posterior, and no point leaves the window before the next snapshot holds it: the folds'
    thinning never enters."""
    rng = np.random.default_rng(5)
    adapt = Adaptation(
        fold_points=fold,
        window=150,
        interval=100,
        steps=3 if fit_noise else 0,
        forgetting=(forgetting,),
        targets=drift > 0,
        lengthscale_range=(1.0, 1.0),
        variance_bounds=(1.0, 1.0),
        summary=summary,
    )
    gp = SparseOnlineGP(
        1,
        RBFKernel(lengthscale=0.2),
        max_basis=30,
        adapt=adapt,
        prior_mean=prior_mean,
        drift_forgetting=drift_rate,
    )
    grid = np.linspace(0.0, 1.0, 11)[:, None]  # half a lengthscale apart: later points project
    if summary == "snapshot":
        grid = grid[::2]  # a lengthscale apart: each point becomes a basis vector

    def draw(n: int) -> np.ndarray:
        on_grid = summary == "snapshot"
        return grid[rng.integers(len(grid), size=n)] if on_grid else rng.uniform(size=(n, 1))

    xs = [np.concatenate([grid, draw(50 - len(grid))])] + [draw(50) for _ in range(23)]
    ys = [
        (1 + drift * i) * np.sin(5 * x[:, 0])
        + drift * i * (1 + x[:, 0])
        + 0.1 * rng.normal(size=50)
        for i, x in enumerate(xs)
    ]
    drifts = 0.05 * (np.arange(len(xs)) % 3)  # the first one precedes nothing
    gp.update(xs[0], ys[0], drift=drifts[0])
    basis = gp.basis_inputs.clone()
    for x, y, d in zip(xs[1:], ys[1:], drifts[1:], strict=True):
        gp.update(x, y, drift=d)
    torch.testing.assert_close(gp.basis_inputs, basis, rtol=0, atol=0)  # the basis stayed
    if summary == "snapshot":
        np.testing.assert_array_equal(basis.numpy(), grid)
    assert int(gp.n_blocks) == 12 and gp.summary_prec.abs().sum() > 0
    assert (float(gp.noise_var) != 0.05) == fit_noise
    assert (float(gp.y_slope.abs().sum()) > 0) == (prior_mean == "linear")
    # The last snapshot opened the last block (batches 22 and 23).
    assert int(gp.summary_batch) == (22 if summary == "snapshot" else 0)
    x, y = np.concatenate(xs), np.concatenate(ys)
    age = np.repeat(np.arange(len(xs))[::-1], 50)
    drift_after = np.repeat(np.cumsum(drifts[::-1])[::-1] - drifts, 50)
    w = forgetting**age * np.exp(-drift_rate * drift_after)
    if fold is not None and summary == "fold":
        dropped = np.arange(len(x)) < len(x) - 150
        kept = ~dropped | (np.arange(len(x)) % 5 == 2)
        w = np.where(dropped, 5 * w, w)
        x, y, w = x[kept], y[kept], w[kept]
    assert_weighted_sparse_posterior(gp, x, y, w, rng)


def _age_stream(rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Ten 50-point batches on a 6-point grid (every grid point in the first)."""
    grid = np.linspace(0.0, 1.0, 6)[:, None]
    xs = [np.concatenate([grid, grid[rng.integers(6, size=44)]])]
    xs += [grid[rng.integers(6, size=50)] for _ in range(9)]
    ys = [np.sin(5 * x[:, 0]) + 0.3 * i + 0.1 * rng.normal(size=50) for i, x in enumerate(xs)]
    return grid, xs, ys


def _age_gp(score: str, **options: int) -> SparseOnlineGP:
    """A GP whose kernel and basis stay fixed on :func:`_age_stream` and that never refits
    after the first block, forgetting 0.7 from the second batch on (scored by ``score``)."""
    adapt = Adaptation(
        window=150,
        interval=50,
        steps=0,
        targets=False,
        forgetting=(0.7,),
        max_gap=1000,
        settle=False,
        forgetting_score=score,
    )
    kernel = RBFKernel(lengthscale=0.2)
    return SparseOnlineGP(1, kernel, max_basis=30, adapt=adapt, forgetting=0.7, **options)


@pytest.mark.parametrize("score", ["lagged", "shrink"])
def test_lagged_forgetting_weights_every_point_by_its_age(score: str) -> None:
    """With ``forgetting_score="lagged"`` forgetting multiplies the likelihood: with the
    kernel and the basis fixed and no refit after the first block, the on-line posterior of
    ten 50-point batches is the exact sparse posterior of all 500 points weighted
    ``0.7 ** age`` (age in batches), as a refit's rebuild weights them. The inputs lie on
    the basis, where the on-line update is exact. ``"shrink"`` forgetting is not that
    weighting (its posterior differs)."""
    rng = np.random.default_rng(8)
    gp = _age_gp(score)
    grid, xs, ys = _age_stream(rng)
    for x, y in zip(xs, ys, strict=True):
        gp.update(x, y)
    np.testing.assert_array_equal(gp.basis_inputs.numpy(), grid)
    x, y = np.concatenate(xs), np.concatenate(ys)
    w = 0.7 ** np.repeat(np.arange(10)[::-1], 50)
    if score == "lagged":
        assert_weighted_sparse_posterior(gp, x, y, w, rng)
    else:
        with pytest.raises(AssertionError):
            assert_weighted_sparse_posterior(gp, x, y, w, rng)


def test_forgetting_per_points_weights_every_point_by_its_age_in_points() -> None:
    """With ``forgetting_points=25`` and 50-point batches, forgetting 0.7 weighs a point
    ``0.7 ** (points that arrived after it / 25)``: on a fixed basis the on-line posterior is
    the exact sparse posterior of the 500 points with those weights (brute force), from the
    second batch on, before any evidence (the GP's own ``forgetting``)."""
    rng = np.random.default_rng(8)
    gp = _age_gp("lagged", forgetting_points=25)
    grid, xs, ys = _age_stream(rng)
    for x, y in zip(xs, ys, strict=True):
        gp.update(x, y)
    np.testing.assert_array_equal(gp.basis_inputs.numpy(), grid)
    w = 0.7 ** (np.repeat(np.arange(10)[::-1], 50) * 50 / 25)
    assert_weighted_sparse_posterior(gp, np.concatenate(xs), np.concatenate(ys), w, rng)


@pytest.mark.parametrize("score", ["lagged", "shrink"])
def test_forgetting_per_points_is_forgetting_per_batch_rescaled(score: str) -> None:
    """Batches of ``n`` points with candidates per ``N`` points choose and apply what
    candidates ``lambda ** (n / N)`` per batch do: the same posterior, scores, choice and
    rebuild weights (several candidates, refits on)."""
    rng = np.random.default_rng(3)
    candidates, n, N = (1.0, 0.8, 0.3), 40, 160
    settings = dict(window=120, interval=80, steps=2, max_gap=2, forgetting_score=score)
    per_points = SparseOnlineGP(
        2,
        "rbf",
        max_basis=40,
        forgetting=0.5,
        forgetting_points=N,
        adapt=Adaptation(forgetting=candidates, **settings),
    )
    per_batch = SparseOnlineGP(
        2,
        "rbf",
        max_basis=40,
        forgetting=0.5 ** (n / N),
        adapt=Adaptation(forgetting=tuple(c ** (n / N) for c in candidates), **settings),
    )
    chosen = set()
    for i in range(12):
        x = rng.uniform(size=(n, 2))
        y = np.sin(4 * x[:, 0]) + (0.5 * i if i % 4 else -0.5 * i) + 0.1 * rng.normal(size=n)
        for gp in (per_points, per_batch):
            gp.update(x, y)
        factor = float(per_points.block_forgetting) ** (n / N)
        assert factor == pytest.approx(float(per_batch.block_forgetting), rel=1e-12)
        chosen.add(round(factor, 12))
    assert len(chosen) > 1  # the evidence chose, not only the initial forgetting
    probe = torch.as_tensor(rng.uniform(size=(50, 2)))
    for a, b in zip(per_points.predict(probe), per_batch.predict(probe), strict=True):
        torch.testing.assert_close(a, b, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "100"])
def test_forgetting_points_must_be_a_positive_integer(bad: object) -> None:
    with pytest.raises(ValueError, match="forgetting_points must be"):
        SparseOnlineGP(2, "rbf", forgetting_points=bad)  # type: ignore[arg-type]


def test_a_state_saved_before_forgetting_points_loads() -> None:
    """0.12's states have no ``forgetting_points``: they load as per-batch forgetting, and a
    state may be loaded with another ``forgetting_points`` (it steers later updates only)."""
    rng = np.random.default_rng(0)
    gp = SparseOnlineGP(2, "rbf", max_basis=20, forgetting_points=64)
    gp.update(rng.uniform(size=(64, 2)), rng.normal(size=64))
    state = copy.deepcopy(gp.state_dict())
    del state["_extra_state"]["forgetting_points"]
    for points in (None, 64, 8):
        other = SparseOnlineGP(2, "rbf", max_basis=20, forgetting_points=points)
        other.load_state_dict(state)
        tensors = [
            {k: v for k, v in g.state_dict().items() if k != "_extra_state"} for g in (gp, other)
        ]
        assert_same_state(*tensors)


@pytest.mark.parametrize("kernel", ["rbf", "geodesic"])
def test_lagged_score_of_no_forgetting_is_the_batchs_predictive_density(kernel: str) -> None:
    """The lagged score of ``lambda = 1`` is the negative log density of the scored points
    (``score_points=10``: each standing for 4 of a 40-point batch) under the GP's own
    predictive distribution before the batch, in standardised units; a target that has
    jumped by 3 with each batch is predicted best by the strongest forgetting offered."""
    rng = np.random.default_rng(9)
    adapt = Adaptation(
        window=500,
        interval=1000,  # one open block: the scores add up
        steps=0,
        forgetting=(1.0, 0.5, 0.1),
        score_points=10,
        forgetting_score="lagged",
    )
    gp = SparseOnlineGP(1, kernel, max_basis=20, adapt=adapt)
    for i in range(4):
        x = rng.uniform(size=(40, 1))
        y = np.sin(4 * x[:, 0]) + 3.0 * i + 0.1 * rng.normal(size=40)
        mean, latent = (v.numpy() for v in gp.predict(x[1::4]))
        before = gp.forgetting_scores.clone()
        gp.update(x, y, np.arange(40) == 0)
    s, c = float(gp.y_scale), float(gp.y_mean)
    var = latent / s**2 + float(gp.noise_var)
    yn, mu = (y[1::4] - c) / s, (mean - c) / s
    nll = 0.5 * (np.log(2 * np.pi * var) + (yn - mu) ** 2 / var)
    scores = (gp.forgetting_scores - before).numpy()
    assert scores[0] == pytest.approx(4 * nll.sum(), rel=1e-7)
    assert scores.argmin() == 2


@pytest.mark.parametrize("whole", [False, True])
@pytest.mark.parametrize("fold", [None, 5])
def test_a_snapshot_folds_only_the_head_of_a_batch_larger_than_the_window(
    fold: int | None, whole: bool
) -> None:
    """Batches of 50 into a 30-point window, one block each (as PPO's rollouts of thousands
    into a window of 2,048): the 20 points of a batch that leave the window on arrival are
    folded (through ``fold_points``), the 30 it keeps are rebuilt exactly, and each block's
    snapshot passes both on, weighted ``0.7 ** age``: the posterior is the exact sparse
    posterior of every tail and of each head as folded (``fold_points=5``: points 1, 5, ...,
    17, the middles of runs of 4, each weighted 4 times). With ``whole_batch`` every block's
    rebuild takes its head as it takes its tail: the exact sparse posterior of every point,
    whatever ``fold_points``. Inputs off the basis, target units fixed, the basis fixed after
    the first batch."""
    rng = np.random.default_rng(7)
    adapt = Adaptation(
        window=30,
        interval=50,
        steps=0,
        forgetting=(0.7,),
        targets=False,
        fold_points=fold,
        summary="snapshot",
        whole_batch=whole,
    )
    gp = SparseOnlineGP(1, RBFKernel(lengthscale=0.2), max_basis=30, adapt=adapt, forgetting=0.7)
    grid = np.linspace(0.0, 1.0, 11)[:, None]
    xs = [np.concatenate([grid, rng.uniform(size=(39, 1))])]
    xs += [rng.uniform(size=(50, 1)) for _ in range(9)]
    ys = [np.sin(5 * x[:, 0]) + 0.1 * rng.normal(size=50) for x in xs]
    gp.update(xs[0], ys[0])
    basis = gp.basis_inputs.clone()
    for x, y in zip(xs[1:], ys[1:], strict=True):
        gp.update(x, y)
    torch.testing.assert_close(gp.basis_inputs, basis, rtol=0, atol=0)
    assert int(gp.n_blocks) == 10 and int(gp.summary_batch) == 9  # before the last batch
    x, y = np.concatenate(xs), np.concatenate(ys)
    w = 0.7 ** np.repeat(np.arange(10)[::-1], 50)
    position = np.tile(np.arange(50), 10)
    head = position < 20
    folded = fold is not None and not whole
    kept = ~head if folded else np.ones(len(x), dtype=bool)
    if folded:
        kept |= position % 4 == 1
        w = np.where(head, 4 * w, w)
    assert_weighted_sparse_posterior(gp, x[kept], y[kept], w[kept], rng)


@pytest.mark.parametrize("summary", ["fold", "snapshot"])
def test_whole_batch_changes_nothing_where_no_refit_meets_a_batch_beyond_the_window(
    summary: str,
) -> None:
    """``whole_batch`` acts only on a refit's rebuild: where the refitting first block fits in
    the window and the blocks of larger batches after it never refit, every state and
    prediction is the same bit for bit with it as without it."""
    rng = np.random.default_rng(11)
    xs = [rng.uniform(size=(n, 2)) for n in (40, 70, 90, 70)]
    ys = [np.sin(4 * x[:, 0]) + x[:, 1] + 0.1 * rng.normal(size=len(x)) for x in xs]
    gps = []
    for whole in (False, True):
        adapt = Adaptation(
            window=50, interval=40, steps=2, max_gap=1000, settle=False, fold_points=8,
            summary=summary, whole_batch=whole,
        )  # fmt: skip
        gp = SparseOnlineGP(2, "rbf", max_basis=25, adapt=adapt)
        for x, y in zip(xs, ys, strict=True):
            gp.update(x, y)
        gps.append(gp)
    assert int(gps[0].n_blocks) == 4 and float(gps[0].summary_prec.abs().sum()) > 0
    # the stored options differ in whole_batch alone
    states = [
        {k: v for k, v in snapshot(gp).items() if not k.endswith("_extra_state")} for gp in gps
    ]
    assert_same_state(*states)
    probe = rng.uniform(size=(7, 2))
    for a, b in zip(gps[0].predict(probe), gps[1].predict(probe), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)


@pytest.mark.parametrize("batch", [60, 15])  # one batch per block, and four
def test_snapshots_only_before_refits_predict_as_snapshots_before_every_block(
    batch: int,
) -> None:
    """The snapshot serves only a refit's rebuild: taking it only when a block that refits
    opens (known from the scores of a block of one batch) predicts bit for bit as taking it
    when every block opens, through rare, fit-floor and drift refits, forgetting, new target
    units and deletions at capacity; with one batch per block it is taken before the refits
    alone."""
    rng = np.random.default_rng(9)
    adapt = Adaptation(
        window=40, interval=60, steps=2, max_gap=4, settle=False, fit_floor=0.3,
        drift_tol=3.0, fold_points=7, summary="snapshot",
    )  # fmt: skip
    lazy, eager = (SparseOnlineGP(2, "laplacian", max_basis=12, adapt=adapt) for _ in range(2))

    def every_block(a: Adaptation, n: int) -> bool:
        return int(eager.block_new) == 0

    eager._snapshot_due = every_block  # type: ignore[method-assign]
    taken = {"lazy": 0, "eager": 0}
    for name, gp in (("lazy", lazy), ("eager", eager)):
        take = gp._snapshot

        def counted(take=take, name=name) -> None:
            taken[name] += 1
            take()

        gp._snapshot = counted  # type: ignore[method-assign]
    refits = 0
    probe = rng.uniform(size=(9, 2))
    for i in range(360 // batch):
        x = rng.uniform(size=(batch, 2))
        y = (1 + i // 4) * np.sin(4 * x[:, 0]) + x[:, 1] + 0.2 * rng.normal(size=batch)
        before = lazy.lengthscale.clone()
        for gp in (lazy, eager):
            gp.update(x, y)
        refits += not torch.equal(before, lazy.lengthscale)
        for a, b in zip(lazy.predict(probe), eager.predict(probe), strict=True):
            torch.testing.assert_close(a, b, rtol=0, atol=0)
    # Blocks 1 and 4 on the schedule, at least one for the fit floor or the drift.
    assert int(lazy.n_deleted) > 0 and refits >= 3 and int(lazy.n_blocks) == 6
    assert taken["eager"] == 5  # blocks 2-6 (the basis is empty when block 1 opens)
    assert taken["lazy"] == (refits - 1 if batch == 60 else 5)


@pytest.mark.parametrize(
    ("summary", "score"), [("fold", "shrink"), ("snapshot", "shrink"), ("snapshot", "lagged")]
)
@pytest.mark.parametrize("prior_mean", ["constant", "linear"])
def test_adaptation_state_round_trips_bit_for_bit(
    prior_mean: str, summary: str, score: str
) -> None:
    rng = np.random.default_rng(4)
    adapt = Adaptation(window=300, interval=150, steps=2, summary=summary, forgetting_score=score)
    batches = [(rng.uniform(size=(100, 2)), rng.normal(size=100)) for _ in range(6)]
    gp = SparseOnlineGP(2, "geodesic", max_basis=40, adapt=adapt, prior_mean=prior_mean)
    for x, y in batches[:3]:
        gp.update(x, y)
    copy = SparseOnlineGP(2, "geodesic", max_basis=40, adapt=adapt, prior_mean=prior_mean)
    copy.load_state_dict(gp.state_dict())
    assert_same_state(snapshot(gp), snapshot(copy))
    for x, y in batches[3:]:
        gp.update(x, y)
        copy.update(x, y)
    assert_same_state(snapshot(gp), snapshot(copy))
    assert gp.n_blocks == 3  # a block closes once 150 points have arrived: after 200, 400, 600


def test_a_state_saved_by_0_2_loads_with_the_ages_it_had() -> None:
    """0.2 stored the window's block indices and no summary; ages in blocks become ages in
    batches (one batch per block there), the summary starts empty, predictions are unchanged."""
    rng = np.random.default_rng(6)
    adapt = Adaptation(window=300, interval=200, steps=1)
    gp = SparseOnlineGP(2, "rbf", max_basis=30, adapt=adapt)
    for _ in range(5):
        gp.update(rng.uniform(size=(100, 2)), rng.normal(size=100))
    state = gp.state_dict()
    offset = state["n_batches"] - state["n_blocks"]
    assert int(offset) == 3
    old = {k: v for k, v in state.items() if not k.startswith("summary_") and k != "block_start"}
    old["window.block"] = old.pop("window.batch") - offset
    copy = SparseOnlineGP(2, "rbf", max_basis=30, adapt=adapt)
    copy.load_state_dict(old)
    probe = rng.uniform(size=(7, 2))
    for a, b in zip(gp.predict(probe), copy.predict(probe), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    torch.testing.assert_close(copy.window.batch, gp.window.batch, rtol=0, atol=0)
    assert float(copy.summary_prec.abs().sum()) == 0.0


@pytest.mark.parametrize("floor", [None, 0.5, 0.99])
def test_a_block_predicted_below_the_fit_floor_refits(floor: float | None) -> None:
    """``fit_floor`` with scheduled refits only on block 1, a block per two batches: the
    block's fit, logged as ``block_fit``, is the explained variance of the predictions the GP
    made of each of its batches before absorbing it (computed here from copies of the GP); a
    block below the floor refits (its hyperparameters move), the others keep them."""
    adapt = Adaptation(
        window=1000, interval=100, steps=3, max_gap=100, settle=False, fit_floor=floor
    )
    rng = np.random.default_rng(5)
    gp = SparseOnlineGP(1, RBFKernel(lengthscale=0.3), max_basis=20, adapt=adapt)
    truth, predicted, fits, refitted = [], [], [], []
    for i in range(8):
        x = rng.uniform(size=(50, 1))
        y = np.sin(4 * x[:, 0]) + 0.3 * rng.normal(size=50)
        hyper = gp.lengthscale.clone()
        if gp.n_basis > 0:  # an empty basis scores nothing
            truth.append(y)
            predicted.append(copy.deepcopy(gp).predict(x, return_var=False)[0].numpy())
        gp.update(x, y)
        if i % 2 == 1 and i > 1:  # blocks 2, 3, 4 close
            y_all, mean = np.concatenate(truth), np.concatenate(predicted)
            expected = 1 - np.var(y_all - mean) / np.var(y_all)
            assert gp.last_stats["block_fit"] == pytest.approx(expected, rel=1e-9)
            fits.append(expected)
            refitted.append(not torch.equal(hyper, gp.lengthscale))
        if i % 2 == 1:
            truth, predicted = [], []
    assert all(0.5 < f < 0.99 for f in fits)  # the noise leaves about 0.8 explained
    assert refitted == [floor == 0.99] * 3


def _misfit_stream(
    adapt: Adaptation, batches: int, size: int
) -> tuple[SparseOnlineGP, list[bool], list[bool]]:
    """A GP fed ``batches`` batches of ``size`` noisy points of a sine; whether each batch
    moved its lengthscale (a refit) and whether it took a snapshot of the posterior."""
    rng = np.random.default_rng(11)
    gp = SparseOnlineGP(1, RBFKernel(lengthscale=0.3), max_basis=20, adapt=adapt)
    moved, snapshots = [], []
    for _ in range(batches):
        x = rng.uniform(size=(size, 1))
        hyper, summarised = gp.lengthscale.clone(), int(gp.summary_batch)
        gp.update(x, np.sin(4 * x[:, 0]) + 0.3 * rng.normal(size=size))
        moved.append(not torch.equal(hyper, gp.lengthscale))
        snapshots.append(int(gp.summary_batch) != summarised)
    return gp, moved, snapshots


def test_fit_spacing_lets_a_misfitted_block_refit_only_that_many_points_after_the_last() -> None:
    """Every block is below the floor (0.99; the noise leaves about 0.8 explained) and only
    block 1 refits on the schedule. Blocks of 50 points, spacing 120: the refits fall where
    the points since the previous one first reach 120, counted by hand: blocks 1 (schedule),
    4, 7, 10 (points 200, 350, 500); without spacing every block refits."""
    base = dict(window=1000, interval=50, steps=3, max_gap=100, settle=False, fit_floor=0.99)
    _, spaced, _ = _misfit_stream(Adaptation(**base, fit_spacing=120), 10, 50)
    assert spaced == [i in (0, 3, 6, 9) for i in range(10)]
    _, unspaced, _ = _misfit_stream(Adaptation(**base), 10, 50)
    assert unspaced == [True] * 10


def test_fit_spacing_snapshots_exactly_the_blocks_it_refits() -> None:
    """With the snapshot summary a block of one batch takes its snapshot before absorbing,
    from its scores, and refits after: both must agree on the spacing. Batches of 50 points,
    one per block, spacing 120: the snapshots fall on the batches that refit for their fit
    (blocks 4, 7, 10, as counted in the test above), and only there."""
    adapt = Adaptation(
        window=1000, interval=50, steps=3, max_gap=100, settle=False, fit_floor=0.99,
        fit_spacing=120, summary="snapshot",
    )  # fmt: skip
    _, refits, snapshots = _misfit_stream(adapt, 10, 50)
    assert refits == [i in (0, 3, 6, 9) for i in range(10)]
    # block 1 refits on the schedule with an empty basis: nothing to score, no snapshot
    assert snapshots == [i in (3, 6, 9) for i in range(10)]


def test_fit_spacing_no_larger_than_a_block_changes_nothing() -> None:
    """Blocks of 100 points with spacing 100 (PPO's 4,096-point rollouts with the screen's
    4,096): the GP is the one without spacing, bit for bit, its refit count aside."""
    base = dict(window=300, interval=100, steps=2, max_gap=100, settle=False, fit_floor=0.99)
    spaced, moved, _ = _misfit_stream(Adaptation(**base, fit_spacing=100), 6, 100)
    unspaced, _, _ = _misfit_stream(Adaptation(**base), 6, 100)
    assert all(moved)
    assert int(spaced.refit_seen) == int(spaced.n_seen) == 600
    state, reference = spaced.state_dict(), unspaced.state_dict()
    for name, value in reference.items():
        if isinstance(value, torch.Tensor):
            torch.testing.assert_close(state[name], value, rtol=0, atol=0)


def test_a_state_saved_before_fit_spacing_loads_as_refitted_at_its_first_point() -> None:
    """0.37 stored no ``refit_seen``: the state loads and predicts as saved, and a spaced GP
    loading it counts every point seen since the first as arrived since a refit (zero)."""
    adapt = Adaptation(window=300, interval=100, steps=1, fit_floor=0.99, fit_spacing=100)
    gp, _, _ = _misfit_stream(adapt, 3, 100)
    state = {k: v for k, v in gp.state_dict().items() if k != "refit_seen"}
    copy = SparseOnlineGP(1, RBFKernel(lengthscale=0.3), max_basis=20, adapt=adapt)
    copy.load_state_dict(state)
    probe = np.linspace(0, 1, 9)[:, None]
    for a, b in zip(gp.predict(probe), copy.predict(probe), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    assert int(copy.refit_seen) == 0 and int(gp.refit_seen) == 300


def test_a_state_saved_by_0_6_loads_without_drift_moments() -> None:
    """0.6 stored no ``block_moments``: the state loads, predicts as saved, and the open
    block's drift counts the targets of the batches fed after loading only."""
    rng = np.random.default_rng(8)
    adapt = Adaptation(window=300, interval=200, steps=1, drift_tol=2.0)
    gp = SparseOnlineGP(2, "rbf", max_basis=30, adapt=adapt)
    for _ in range(3):  # 300 points: the second block is open, with 100 scored
        gp.update(rng.uniform(size=(100, 2)), rng.normal(size=100))
    # Also without what 0.8's linear prior mean added (a constant mean saved as before).
    added = ("block_moments", "block_errors", "y_slope", "summary_input", "trend_coef")
    added += ("summary_batch",)  # and without 0.11's snapshots
    state = {k: v for k, v in gp.state_dict().items() if k not in added}
    extra = state["_extra_state"]
    state["_extra_state"] = {k: v for k, v in extra.items() if k not in ("prior_mean", "trend")}
    copy = SparseOnlineGP(2, "rbf", max_basis=30, adapt=adapt)
    copy.load_state_dict(state)
    probe = rng.uniform(size=(7, 2))
    for a, b in zip(gp.predict(probe), copy.predict(probe), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    x, y = rng.uniform(size=(100, 2)), 3.0 + rng.normal(size=100)
    units = (float(copy.y_mean), float(copy.y_scale))
    copy.update(x, y)  # closes the block
    expected = np.mean(((y - units[0]) / units[1]) ** 2)
    assert copy.last_stats["target_drift"] == pytest.approx(expected, rel=1e-12)


def test_a_failure_inside_the_adaptation_leaves_the_state_unchanged(monkeypatch) -> None:
    """The fit has already rescaled the kernel (and the geodesic graph) when the rebuild fails."""
    rng = np.random.default_rng(5)
    gp = SparseOnlineGP(2, "geodesic", max_basis=30, adapt=Adaptation(window=200, interval=100))
    gp.update(rng.uniform(size=(120, 2)), rng.normal(size=120))
    before = snapshot(gp)

    def broken(*args: object) -> None:
        raise FloatingPointError("simulated")

    monkeypatch.setattr("sb3_geogp.sparse_gp.sparse_posterior", broken)
    with pytest.raises(FloatingPointError, match="simulated"):
        gp.update(rng.uniform(size=(100, 2)), rng.normal(size=100))
    assert_same_state(before, snapshot(gp))


def test_bvs_made_redundant_by_a_longer_lengthscale_are_pruned() -> None:
    """35x longer lengthscales make a dense basis nearly collinear: the near-duplicates go and
    the rebuilt GP still fits (without pruning its weights blow up off the data)."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(400, 2))
    y = x[:, 0] + 0.5 * x[:, 1] + 0.01 * rng.normal(size=400)
    gp = SparseOnlineGP(2, RBFKernel(lengthscale=0.05), max_basis=200, novelty_tol=1e-3)
    gp.update(x, y)
    gp.fit_hyperparameters(n_iter=200, lr=0.1)
    m = gp.n_basis
    assert float(gp.lengthscale.min()) > 20 * 0.05 and int(gp.n_pruned) > 0
    assert float(gp.Q[:m, :m].diagonal().max() * gp.kernel.variance) <= 1e4
    probe = rng.uniform(-1, 1, size=(500, 2))
    truth = probe[:, 0] + 0.5 * probe[:, 1]
    assert float(np.abs(gp.predict(probe)[0].numpy() - truth).max()) < 0.05


def test_a_window_too_large_for_memory_is_refused_up_front() -> None:
    with pytest.raises(ValueError, match="1000000-point window"):
        SparseOnlineGP(10**5, "rbf", max_basis=4, adapt=Adaptation(window=10**6))


def test_gaussian_nll_and_nlpd_are_scipys_log_density() -> None:
    """The one Gaussian negative log density of the scores and statistics, against scipy's, also
    broadcast as the forgetting candidates use it (a row per candidate); ``nlpd`` its mean."""
    rng = np.random.default_rng(5)
    y, mean, var = rng.normal(size=7), rng.normal(size=(3, 7)), rng.uniform(0.1, 2, size=(3, 7))
    got = gaussian_nll(*(torch.tensor(a) for a in (y, mean, var))).numpy()
    np.testing.assert_allclose(got, -norm.logpdf(y, mean, np.sqrt(var)), rtol=1e-12)
    one = nlpd(torch.tensor(mean[0]), torch.tensor(var[0]), torch.tensor(y))
    assert one == pytest.approx(-norm.logpdf(y, mean[0], np.sqrt(var[0])).mean(), rel=1e-12)


def test_strong_forgetting_over_many_short_batches_keeps_refitting() -> None:
    """Forgetting 0.03 per one-point batch: after about 200 batches ``0.03 ** age`` underflows
    to 0 and a point's noise ``noise_var / w`` to inf, which made every refit fail from then on.
    Floored weights keep every update and ``fit_hyperparameters`` going, and the state finite."""
    rng = np.random.default_rng(0)
    gp = SparseOnlineGP(3, "rbf", adapt=Adaptation(window=300, forgetting=(0.03,)))
    pos = np.zeros(3)
    for _ in range(450):
        pos = 0.9 * pos + 0.3 * rng.normal(size=3)
        gp.update(pos[None], [50.0 * rng.normal()])
    assert gp.last_stats["forgetting"] == 0.03 and int(gp.n_blocks) >= 1
    tensors = [v for v in gp.state_dict().values() if isinstance(v, torch.Tensor)]
    assert all(bool(torch.isfinite(v).all()) for v in tensors)
    plain = SparseOnlineGP(2, "rbf", forgetting=0.1)
    for _ in range(400):
        x = rng.normal(size=(5, 2))
        plain.update(x, np.sin(x[:, 0]))
    assert math.isfinite(plain.fit_hyperparameters()["nlml"])
    weights = age_weights(torch.arange(400.0), 0.03)
    assert float(weights.min()) == WEIGHT_FLOOR and bool((weights[:100] > WEIGHT_FLOOR).all())
    np.testing.assert_allclose(weights[:100].numpy(), 0.03 ** np.arange(100.0), rtol=1e-14)


def test_linear_moments_give_no_slope_along_inputs_that_do_not_vary() -> None:
    """Against numpy's weighted least squares on the inputs that vary; a constant input (or
    every input constant: one point) gets slope 0 and the line is the weighted mean."""
    rng = np.random.default_rng(1)
    x = np.column_stack([rng.normal(size=50), np.full(50, 0.3), rng.normal(size=50)])
    y = 2.0 + x[:, 0] - 3.0 * x[:, 2] + 0.1 * rng.normal(size=50)
    w = rng.uniform(0.5, 1.5, size=50)
    c, b, s = linear_moments(*(torch.tensor(a) for a in (x, y, w)))
    design = np.column_stack([np.ones(50), x[:, [0, 2]]]) * np.sqrt(w)[:, None]
    coef = np.linalg.lstsq(design, y * np.sqrt(w), rcond=None)[0]
    assert b[1] == 0.0
    np.testing.assert_allclose([c, float(b[0]), float(b[2])], coef, rtol=1e-9)
    residual = y - coef[0] - x[:, [0, 2]] @ coef[1:]
    assert s == pytest.approx(np.sqrt(np.sum(w * residual**2) / w.sum()), rel=1e-9)
    c, b, s = linear_moments(torch.full((4, 2), 0.3), torch.tensor([1.0, 2, 3, 4]), torch.ones(4))
    assert (c, b.tolist()) == (pytest.approx(2.5), [0.0, 0.0])
    gp = SparseOnlineGP(3, "rbf", prior_mean="linear")
    gp.update(np.array([[0.3, -0.2, 1.0]]), [0.7])  # one point: refused as NaN before
    assert float(gp.predict(np.zeros((1, 3)))[0]) == pytest.approx(0.7)


@pytest.mark.parametrize("scale", [1e-9, 1e9])
def test_the_adaptation_is_the_same_at_any_scale_of_the_targets(scale: float) -> None:
    """Targets times ``scale`` give the same standardised GP: refits re-estimate the target
    scale also where it is below 1e-8 (before, a fixed threshold kept the first batch's)."""

    def fitted(s: float) -> tuple[float, float, np.ndarray]:
        rng = np.random.default_rng(0)
        gp = SparseOnlineGP(2, "rbf", adapt=Adaptation(window=256, interval=128))
        for k in range(6):
            x = rng.uniform(-2, 2, (128, 2))
            gp.update(x, s * (np.sin(2 * x[:, 0]) + 3.0 * (k > 2)))
        probe = rng.uniform(-2, 2, (50, 2))
        return float(gp.y_scale) / s, float(gp.y_mean) / s, gp.predict(probe)[0].numpy() / s

    unit, scaled = fitted(1.0), fitted(scale)
    assert scaled[:2] == (pytest.approx(unit[0], rel=1e-9), pytest.approx(unit[1], rel=1e-9))
    np.testing.assert_allclose(scaled[2], unit[2], rtol=1e-8, atol=1e-10)


def test_the_gps_own_window_fed_back_is_kept_as_fed() -> None:
    """Views of the window fed to ``update`` are what the window keeps (the window shifted in
    place under them before): the same as feeding copies."""
    rng = np.random.default_rng(2)
    views, copies = (SparseOnlineGP(2, "laplacian") for _ in range(2))
    x = rng.normal(size=(2048, 2))
    for gp in (views, copies):
        gp.update(x, np.sin(x[:, 0]))
    wx, wy, _, _ = views.window.data()
    copies.update(wx[:500].clone(), wy[:500].clone())
    views.update(wx[:500], wy[:500])
    assert_same_state(views.state_dict(), copies.state_dict())


# -- lengthscales that follow the data's spread (follow_spread, 0.42) ---------------------------
def _narrow_then_wide(
    rng: np.random.Generator, n: int = 100
) -> list[tuple[np.ndarray, np.ndarray]]:
    """A first batch whose second input barely varies (a policy that has not moved yet), then
    batches spread 20x wider in it; the first input is uniform on [0, 1] throughout."""
    spreads = [0.05] + [1.0] * 3
    batches = []
    for spread in spreads:
        x = np.column_stack([rng.uniform(size=n), spread * rng.normal(size=n)])
        batches.append((x, np.sin(3 * x[:, 0]) + np.tanh(x[:, 1]) + 0.1 * rng.normal(size=n)))
    return batches


def _spread_gp(follow: bool, steps: int, rule: str = "spread") -> SparseOnlineGP:
    """An RBF GP: input 0 bounded ([0, 1]: its lengthscale from the bounds), input 1
    unbounded (from the first batch); a refit on every block of 100 points; no forgetting,
    and a window that keeps every point of :func:`_narrow_then_wide` (no summary of dropped
    points)."""
    adapt = Adaptation(
        window=400, interval=100, steps=steps, forgetting=(1.0,), follow_spread=follow
    )
    bounds = ([0.0, -np.inf], [1.0, np.inf])
    return SparseOnlineGP(
        2, "rbf", max_basis=40, adapt=adapt, input_bounds=bounds, lengthscale_rule=rule
    )


@pytest.mark.parametrize("follow", [False, True])
@pytest.mark.parametrize("rule", ["spread", "distance"])
def test_follow_spread_starts_the_first_batchs_lengthscales_from_the_windows_spread(
    follow: bool, rule: str
) -> None:
    """Without fitting steps the lengthscale is its start: the bounded input's stays at the
    bounds' ``1 / sqrt(12)``; the unbounded one's is the first batch's standard deviation, and
    with ``follow_spread`` that of the window at each refit (numpy's, independently); both
    times ``sqrt(2)`` under ``lengthscale_rule="distance"``."""
    rng = np.random.default_rng(11)
    batches = _narrow_then_wide(rng)
    gp = _spread_gp(follow, steps=0, rule=rule)
    factor = np.sqrt(2) if rule == "distance" else 1.0
    first = batches[0][0][:, 1].std()
    for x, y in batches:
        gp.update(x, y)
        window_x = gp.window.data()[0].numpy()
        expected = window_x[:, 1].std() if follow else first
        ls = gp.lengthscale.numpy()
        np.testing.assert_allclose(ls, factor * np.array([1 / np.sqrt(12), expected]), rtol=1e-12)
        np.testing.assert_allclose(gp.ls_start.numpy(), ls, rtol=1e-12)
    assert gp.ls_from_data.tolist() == [False, True]
    if follow:  # the window holds three wide batches and the narrow one
        assert gp.lengthscale[1] > 10 * first


@pytest.mark.parametrize("follow", [True, "widen"])
def test_follow_spread_widen_starts_from_the_widest_window_so_far(follow: bool | str) -> None:
    """Spreads that narrow, then widen past the first batch's: with ``True`` the unbounded
    input's start is each refit's window standard deviation; with ``"widen"`` the largest of
    those so far and the first batch's (numpy's, independently)."""
    rng = np.random.default_rng(16)
    adapt = Adaptation(window=200, interval=100, steps=0, forgetting=(1.0,), follow_spread=follow)
    gp = SparseOnlineGP(1, "rbf", max_basis=40, adapt=adapt)
    widest = 0.0
    for spread in (1.0, 0.05, 0.05, 0.05, 3.0):
        x = spread * rng.normal(size=(100, 1))
        gp.update(x, np.tanh(x[:, 0]) + 0.1 * rng.normal(size=100))
        spread_now = gp.window.data()[0].numpy()[:, 0].std()
        widest = max(widest, spread_now)
        expected = spread_now if follow is True else widest
        np.testing.assert_allclose(gp.lengthscale.numpy(), [expected], rtol=1e-12)
    assert gp.lengthscale[0] > 2.0  # the last window's spread, wider than the first batch's


def test_follow_spread_keeps_each_fitted_factor_to_its_new_start(monkeypatch) -> None:
    """With fitting steps, each refit's fit starts from the window's spread times the factor
    the previous fit left (lengthscale over start), dimension by dimension."""
    rng = np.random.default_rng(12)
    gp = _spread_gp(True, steps=3)
    entries: list[tuple[np.ndarray, np.ndarray]] = []
    fit = gp._fit

    def recording_fit(*args, **kwargs) -> None:
        entries.append((gp.lengthscale.numpy().copy(), gp.ls_start.numpy().copy()))
        fit(*args, **kwargs)

    monkeypatch.setattr(gp, "_fit", recording_fit)
    left = None
    for x, y in _narrow_then_wide(rng):
        gp.update(x, y)  # every block of 100 points refits
        ls, start = entries[-1]
        if left is not None:
            window_x = gp.window.data()[0].numpy()
            np.testing.assert_allclose(start[1], window_x[:, 1].std(), rtol=1e-12)
            np.testing.assert_allclose(ls / start, left, rtol=1e-12)
        left = (gp.lengthscale / gp.ls_start).numpy()
    assert len(entries) == 4 and not np.allclose(left, 1.0)  # the fits did move the factors


def test_after_following_the_spread_the_posterior_is_the_sparse_posterior_of_the_window() -> None:
    rng = np.random.default_rng(13)
    gp = _spread_gp(True, steps=2)
    for x, y in _narrow_then_wide(rng):
        gp.update(x, y)
    x, y, _, _ = (t.numpy() for t in gp.window.data())
    w = np.ones(len(y))  # no forgetting: every retained point at full weight
    assert_weighted_sparse_posterior(gp, x, y, w, rng)


def test_follow_spread_with_one_factor_moves_every_lengthscale_by_the_geometric_mean() -> None:
    """``GeodesicKernel(ard=False)`` has one factor: both (unbounded) inputs' lengthscales move
    by the geometric mean of their spreads' ratios, and keep their first batch's proportion."""
    rng = np.random.default_rng(14)
    adapt = Adaptation(window=300, interval=100, steps=0, follow_spread=True)
    gp = SparseOnlineGP(2, GeodesicKernel(ard=False), max_basis=40, adapt=adapt)
    batches = _narrow_then_wide(rng)
    first = batches[0][0].std(axis=0)
    for x, y in batches:
        gp.update(x, y)
    ratio = gp.window.data()[0].numpy().std(axis=0) / first
    np.testing.assert_allclose(gp.lengthscale.numpy(), first * np.sqrt(ratio.prod()), rtol=1e-10)


def test_follow_spread_widen_with_one_factor_never_shrinks() -> None:
    """``"widen"`` on ``GeodesicKernel(ard=False)``: windows that narrow leave the first
    batch's lengthscales as they were; a window that spreads wider moves both by the geometric
    mean of their ratios (numpy's)."""
    rng = np.random.default_rng(17)
    adapt = Adaptation(window=100, interval=100, steps=0, follow_spread="widen")
    gp = SparseOnlineGP(2, GeodesicKernel(ard=False), max_basis=40, adapt=adapt)
    first = None
    for spread in (1.0, 0.2, 0.2, 4.0):
        x = spread * rng.normal(size=(100, 2))
        gp.update(x, np.sin(x[:, 0]) + 0.1 * rng.normal(size=100))
        first = x.std(axis=0) if first is None else first
        if spread < 1:
            np.testing.assert_allclose(gp.lengthscale.numpy(), first, rtol=1e-12)
    ratio = gp.window.data()[0].numpy().std(axis=0) / first
    np.testing.assert_allclose(gp.lengthscale.numpy(), first * np.sqrt(ratio.prod()), rtol=1e-10)


def test_a_state_saved_before_follow_spread_loads_with_no_lengthscale_following() -> None:
    """0.41 stored no ``ls_from_data``: the state loads and predicts as saved, and no dimension
    follows the spread, as none did then."""
    rng = np.random.default_rng(15)
    batches = _narrow_then_wide(rng)
    gp = _spread_gp(True, steps=0)
    for x, y in batches[:2]:
        gp.update(x, y)
    state = {k: v for k, v in gp.state_dict().items() if k != "ls_from_data"}
    old = _spread_gp(True, steps=0)
    old.load_state_dict(state)
    probe = rng.uniform(size=(9, 2))
    for a, b in zip(gp.predict(probe), old.predict(probe), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)
    assert not old.ls_from_data.any()
    start = old.ls_start.clone()
    old.update(*batches[2])
    torch.testing.assert_close(old.ls_start, start, rtol=0, atol=0)
