"""An exact GP whose noise follows the returns along a trajectory (Monte Carlo GPTD).

Monte Carlo returns are not independently noisy: ``G_t = sum_{k>=0} gamma^k r_{t+k}`` shares
all but its first terms with ``G_{t+1}``. Engel, Mannor & Meir's Monte Carlo GPTD (2005)
models them as the value plus a discounted sum of independent per-step noise to the episode's
end,

.. math::  G_t = V(x_t) + n_t, \\qquad n_t = \\sum_{k=0}^{T-1-t} \\gamma^k \\varepsilon_{t+k},
           \\qquad \\varepsilon_j \\sim N(0, \\sigma_\\varepsilon^2),

so within an episode of ``T`` steps (none across episodes)

.. math::  \\mathrm{Cov}(n_t, n_s)
           = s^2 \\gamma^{|t-s|}\\,\\big(1 - \\gamma^{2(T - \\max(t, s))}\\big),
           \\qquad s^2 = \\sigma_\\varepsilon^2 / (1 - \\gamma^2),

``s^2`` the noise variance far from the episode's end. :func:`trajectory_noise` builds the
bracketed correlation structure ``C``; :func:`fit_exact_gp` fits an exact GP with noise
covariance ``s^2 C``, or ``s^2 I`` (independent noise) without it, on the Laplacian kernel
``sigma_f^2 exp(-|(x - x') / l|)`` (one lengthscale per dimension), its hyperparameters at the
optimum of the exact log marginal likelihood of the standardised targets (L-BFGS-B from
lengthscales equal to the inputs' standard deviations, signal variance 1 and noise 0.1, within
:mod:`~sb3_geogp.studies.exact_gp`'s bounds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch as th

from sb3_geogp.studies.exact_gp import LENGTHSCALE_BOUNDS, NOISE_BOUNDS, SIGNAL_BOUNDS


def episode_steps(starts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Episode index, step within the episode and episode length of each point.

    Parameters
    ----------
    starts : ndarray, shape (n,)
        True where a point starts an episode; points are in time order within each episode
        (the first point starts one whatever its flag).

    Returns
    -------
    episode, step, length : ndarrays of int, shape (n,)
    """
    flags = np.asarray(starts, dtype=bool).copy()
    if flags.size:
        flags[0] = True
    episode = np.cumsum(flags) - 1
    first = np.flatnonzero(flags)
    step = np.arange(flags.size) - first[episode]
    length = np.diff(np.append(first, flags.size))[episode]
    return episode, step, length


def trajectory_noise(
    episode: np.ndarray, step: np.ndarray, length: np.ndarray, gamma: float
) -> np.ndarray:
    """The Monte Carlo GPTD noise correlation ``C`` of points given by their episode, step
    and episode length (any subset of an episode's steps).

    Returns
    -------
    ndarray, shape (n, n)
        ``gamma^|t-s| (1 - gamma^(2 (T - max(t, s))))`` within an episode, 0 across.
    """
    if not 0.0 <= gamma < 1.0:
        raise ValueError(f"gamma must be in [0, 1), got {gamma}")
    t = np.asarray(step, dtype=np.float64)
    same = np.asarray(episode)[:, None] == np.asarray(episode)[None, :]
    later = np.maximum(t[:, None], t[None, :])
    to_end = np.asarray(length, dtype=np.float64)[:, None] - later
    corr = gamma ** np.abs(t[:, None] - t[None, :]) * (1.0 - gamma ** (2.0 * to_end))
    return np.where(same, corr, 0.0)


@dataclass
class NoiseFit:
    """An exact GP fitted by :func:`fit_exact_gp`.

    Attributes
    ----------
    lengthscale : ndarray, shape (d,)
    signal_var, noise_var : float
        ``sigma_f^2`` and ``s^2``, in standardised target units.
    log_marginal_likelihood : float
        Of the standardised targets at the optimum.
    """

    lengthscale: np.ndarray
    signal_var: float
    noise_var: float
    log_marginal_likelihood: float
    _x: th.Tensor
    _alpha: th.Tensor
    _mean: float
    _scale: float

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Posterior mean of the value at ``x``, shape (m, d) -> (m,), in the targets' units."""
        lengthscale = th.as_tensor(self.lengthscale)
        # in row chunks: the differences of every pair take m x n x d numbers
        mean = th.cat(
            [
                self.signal_var * _laplacian(rows, self._x, lengthscale) @ self._alpha
                for rows in th.as_tensor(x, dtype=th.float64).split(1024)
            ]
        )
        return mean.numpy() * self._scale + self._mean


def fit_exact_gp(x: np.ndarray, y: np.ndarray, noise: np.ndarray | None = None) -> NoiseFit:
    """Exact Laplacian GP regression of ``y`` on ``x`` with noise covariance ``s^2 noise``
    (``s^2 I`` without it), hyperparameters by maximum likelihood.

    Parameters
    ----------
    x : ndarray, shape (n, d)
    y : ndarray, shape (n,)
        Not constant; standardised inside.
    noise : ndarray, shape (n, n), optional
        The noise's correlation structure, e.g. :func:`trajectory_noise`; positive definite.

    Returns
    -------
    NoiseFit
        Conditioned on every point given.
    """
    from scipy.optimize import minimize

    xt = th.as_tensor(np.asarray(x, dtype=np.float64))
    y = np.asarray(y, dtype=np.float64)
    if xt.ndim != 2 or y.shape != (xt.shape[0],):
        raise ValueError(f"x must have shape (n, d) and y shape (n,); got {xt.shape}, {y.shape}")
    if np.ptp(y) == 0:
        raise ValueError("y is constant: there is no variance for the GP to fit")
    n = xt.shape[0]
    shape = th.eye(n, dtype=th.float64) if noise is None else th.as_tensor(noise)
    if shape.shape != (n, n):
        raise ValueError(f"noise must have shape ({n}, {n}), got {tuple(shape.shape)}")
    mean, scale = float(y.mean()), float(y.std())
    target = th.as_tensor((y - mean) / scale)
    spread = np.where(xt.std(dim=0).numpy() > 0, xt.std(dim=0).numpy(), 1.0)
    start = np.log(np.concatenate([spread, [1.0, 0.1]]))
    bounds = [(np.log(b * s), np.log(c * s)) for s in spread for b, c in [LENGTHSCALE_BOUNDS]]
    bounds += [tuple(np.log(SIGNAL_BOUNDS)), tuple(np.log(NOISE_BOUNDS))]

    def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
        params = th.tensor(theta, dtype=th.float64, requires_grad=True)
        value = -_log_evidence(xt, target, shape, params)
        value.backward()
        assert params.grad is not None
        return float(value.detach()), params.grad.numpy().copy()

    found = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=bounds)
    theta = th.as_tensor(found.x)
    lengthscale, signal, noise_var = (
        theta[:-2].exp(),
        float(theta[-2].exp()),
        float(theta[-1].exp()),
    )
    covariance = signal * _laplacian(xt, xt, lengthscale) + noise_var * shape
    alpha = th.cholesky_solve(target[:, None], th.linalg.cholesky(covariance))[:, 0]
    return NoiseFit(
        lengthscale=lengthscale.numpy(),
        signal_var=signal,
        noise_var=noise_var,
        log_marginal_likelihood=-float(found.fun),
        _x=xt,
        _alpha=alpha,
        _mean=mean,
        _scale=scale,
    )


def log_evidence(
    x: np.ndarray, y: np.ndarray, lengthscale: np.ndarray, signal_var: float, noise: np.ndarray
) -> float:
    """Log marginal likelihood of ``y`` (as given, not standardised) under the zero-mean GP
    with the Laplacian kernel and noise covariance ``noise``, shape (n, n)."""
    params = th.as_tensor(np.log(np.concatenate([lengthscale, [signal_var, 1.0]])))
    return float(
        _log_evidence(
            th.as_tensor(x, dtype=th.float64), th.as_tensor(y), th.as_tensor(noise), params
        )
    )


def _log_evidence(x: th.Tensor, y: th.Tensor, shape: th.Tensor, params: th.Tensor) -> th.Tensor:
    """``log N(y; 0, sigma_f^2 K_l + s^2 shape)``, ``params`` = log (l, sigma_f^2, s^2)."""
    covariance = params[-2].exp() * _laplacian(x, x, params[:-2].exp()) + params[-1].exp() * shape
    chol = th.linalg.cholesky(covariance)
    alpha = th.cholesky_solve(y[:, None], chol)[:, 0]
    n = y.shape[0]
    return -0.5 * y @ alpha - chol.diagonal().log().sum() - 0.5 * n * np.log(2 * np.pi)


def _laplacian(a: th.Tensor, b: th.Tensor, lengthscale: th.Tensor) -> th.Tensor:
    """``exp(-|(a_i - b_j) / l|)``, shape (n, m); differentiable in ``l`` at zero distance."""
    diff = (a[:, None, :] - b[None, :, :]) / lengthscale
    # the clamp gives a zero gradient where a point meets itself (sqrt's is infinite at 0)
    return th.exp(-(diff.square().sum(-1).clamp_min(1e-300)).sqrt())
