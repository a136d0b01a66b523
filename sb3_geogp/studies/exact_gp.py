"""An exact GP with type-II maximum-likelihood hyperparameters: what the model allows.

The GP critic is a sparse on-line approximation of GP regression. To separate what its
approximations (the basis, the summary of older data, a few adaptation steps per batch) lose
from what the model itself allows on the same data, :func:`exact_gp` fits the model without
them: the exact GP posterior with a stationary kernel on Euclidean distance,

.. math::  k(x, x') = \\sigma_f^2 \\rho\\big(\\|(x - x') / l\\|\\big) + \\sigma_n^2 [x = x'],

``rho(r) = exp(-r)`` (``"laplacian"``, the GP critic's profile under PPO; Matérn 1/2),
Matérn 3/2 and 5/2 (``"matern32"``, ``"matern52"``) or ``exp(-r^2 / 2)`` (``"rbf"``), one
lengthscale per input dimension, on targets standardised
to zero mean and unit variance. The hyperparameters ``(l, sigma_f^2, sigma_n^2)`` maximise the
exact log marginal likelihood of ``fit_points`` of the points drawn at random (the cost is
cubic in their number); the posterior then conditions on all of them. scikit-learn's
:class:`~sklearn.gaussian_process.GaussianProcessRegressor` does both (L-BFGS-B from
lengthscales equal to the inputs' spreads). It needs the ``bench`` or ``dev`` extra.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from sb3_geogp.kernels import MaternKernel

#: Kernel profiles :func:`exact_gp` fits.
KERNELS = ("laplacian", "matern32", "matern52", "rbf")
#: Matérn smoothness ``nu`` of each profile but the RBF's (the engine's profile names).
_NU: dict[str, float] = {profile: nu for nu, profile in MaternKernel.NU.items()}
#: Box of each hyperparameter during the fit (standardised targets; lengthscales in units of
#: the inputs' spreads): wide enough that the optimum of a learnable target is inside.
LENGTHSCALE_BOUNDS = (1e-3, 1e3)
SIGNAL_BOUNDS = (1e-4, 1e2)
NOISE_BOUNDS = (1e-6, 1e1)


@dataclass
class ExactFit:
    """A fitted exact GP (:func:`exact_gp`).

    Attributes
    ----------
    lengthscale : ndarray, shape (d,)
        ``l``, in the inputs' units.
    signal_var, noise_var : float
        ``sigma_f^2`` and ``sigma_n^2``, in standardised target units.
    log_marginal_likelihood : float
        Of the standardised targets: at the optimum on the fit points, or, for given
        hyperparameters, on all the points.
    regressor : GaussianProcessRegressor
        Conditioned on every point given.
    """

    lengthscale: np.ndarray
    signal_var: float
    noise_var: float
    log_marginal_likelihood: float
    regressor: Any

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Posterior mean at ``x``, shape (n, d) -> (n,), in the targets' units."""
        return np.asarray(self.regressor.predict(_checked(x, "x")), dtype=np.float64)


def exact_gp(
    x: np.ndarray,
    y: np.ndarray,
    kernel: str = "laplacian",
    fit_points: int = 1024,
    seed: int = 0,
    fixed: tuple[np.ndarray, float, float] | None = None,
) -> ExactFit:
    """Exact GP regression of ``y`` on ``x`` with maximum-likelihood (or given) hyperparameters.

    Parameters
    ----------
    x : ndarray, shape (n, d)
        Inputs.
    y : ndarray, shape (n,)
        Targets (not constant).
    kernel : {"laplacian", "matern32", "matern52", "rbf"}
        The profile ``rho``.
    fit_points : int
        How many of the points, drawn without replacement with ``seed``, the hyperparameters
        are fitted on (all of them when ``n`` is smaller).
    seed : int
        Seed of that draw.
    fixed : (lengthscale, signal_var, noise_var), optional
        Hyperparameters to use instead of fitting them (``lengthscale`` shape (d,), the
        variances in standardised target units); the log marginal likelihood is then that of
        all ``n`` points.

    Returns
    -------
    ExactFit
        Its posterior conditions on all ``n`` points.
    """
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor

    x = _checked(x, "x")
    y = _checked(y, "y")
    if y.ndim != 1 or x.ndim != 2 or x.shape[0] != y.shape[0]:
        raise ValueError(
            f"x must have shape (n, d) and y shape (n,); got {x.shape} and {y.shape}: "
            "pass one target per input row"
        )
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    if fit_points < 2:
        raise ValueError(f"fit_points must be at least 2, got {fit_points}")
    if np.ptp(y) == 0:
        raise ValueError("y is constant: there is no variance for the GP to fit")
    if fixed is None:
        spread = np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
        rng = np.random.default_rng(seed)
        fit = rng.choice(x.shape[0], min(fit_points, x.shape[0]), replace=False)
        tuned = GaussianProcessRegressor(
            _kernel(kernel, (spread, 1.0, 0.1), spread), normalize_y=True, random_state=seed
        )
        with warnings.catch_warnings():
            # a lengthscale at its upper bound is a dimension the targets do not depend on
            warnings.simplefilter("ignore", ConvergenceWarning)
            tuned.fit(x[fit], y[fit])
        found = tuned.kernel_
    else:
        found = _kernel(kernel, _checked_hyper(fixed, x.shape[1]), None)
    regressor = GaussianProcessRegressor(found, optimizer=None, normalize_y=True).fit(x, y)
    params = found.get_params()
    return ExactFit(
        lengthscale=np.atleast_1d(np.asarray(params["k1__k2__length_scale"], dtype=np.float64)),
        signal_var=float(params["k1__k1__constant_value"]),
        noise_var=float(params["k2__noise_level"]),
        log_marginal_likelihood=float(
            tuned.log_marginal_likelihood_value_
            if fixed is None
            else regressor.log_marginal_likelihood_value_
        ),
        regressor=regressor,
    )


def _kernel(name: str, hyper: tuple[np.ndarray, float, float], spread: np.ndarray | None) -> Any:
    """``sigma_f^2 rho(|(x - x') / l|) + sigma_n^2`` at ``hyper`` = ``(l, sigma_f^2,
    sigma_n^2)``; free within the bounds scaled by ``spread``, or fixed without it."""
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern, WhiteKernel

    lengthscale, signal, noise = hyper
    free = spread is not None
    bounds: Any = "fixed"
    if spread is not None:
        bounds = (LENGTHSCALE_BOUNDS[0] * spread.min(), LENGTHSCALE_BOUNDS[1] * spread.max())
    profile = (
        RBF(length_scale=lengthscale, length_scale_bounds=bounds)
        if name == "rbf"
        else Matern(length_scale=lengthscale, length_scale_bounds=bounds, nu=_NU[name])
    )
    return ConstantKernel(signal, SIGNAL_BOUNDS if free else "fixed") * profile + WhiteKernel(
        noise, NOISE_BOUNDS if free else "fixed"
    )


def _checked_hyper(
    fixed: tuple[np.ndarray, float, float], dims: int
) -> tuple[np.ndarray, float, float]:
    """``fixed`` with its lengthscales as shape (``dims``,), refused with the fix unless every
    entry is positive and finite."""
    lengthscale = np.broadcast_to(_checked(fixed[0], "fixed lengthscale"), (dims,)).copy()
    values = np.array([*lengthscale, fixed[1], fixed[2]], dtype=np.float64)
    if not (np.isfinite(values).all() and (values > 0).all()):
        raise ValueError(
            f"fixed hyperparameters must be positive: got lengthscale {lengthscale}, "
            f"signal_var {fixed[1]}, noise_var {fixed[2]}; pass positive values or fixed=None "
            "to fit them"
        )
    return lengthscale, float(fixed[1]), float(fixed[2])


def _checked(a: np.ndarray, name: str) -> np.ndarray:
    """``a`` as float64, refused with the fix if it holds NaN or inf."""
    out = np.asarray(a, dtype=np.float64)
    if not np.isfinite(out).all():
        raise ValueError(f"{name} holds NaN or inf: drop or repair those points first")
    return out
