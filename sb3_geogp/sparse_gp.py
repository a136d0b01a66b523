"""Sparse on-line Gaussian-process regression (Csató & Opper 2002) for value functions.

The posterior over the latent value ``f`` is kept in Csató–Opper form over ``m`` basis
vectors (BVs) ``b_1..b_m``,

.. math::  \\mu(x) = k_x^\\top \\alpha, \\qquad
           \\Sigma(x, x') = k(x, x') + k_x^\\top C k_{x'},

stored as ``alpha`` (m,), ``Q = K_b^{-1}`` (m, m) and ``P = Q + C`` (m, m). ``P`` is the
posterior covariance of the BV values in dual coordinates, ``K_b P K_b = Cov[f_b]``; it is
positive semi-definite, which keeps every variance below non-negative by construction:

.. math::  \\mathrm{var}(x) = \\max(\\gamma_x, 0) + k_x^\\top P k_x, \\qquad
           \\gamma_x = k(x, x) - k_x^\\top Q k_x,

``gamma_x`` being the novelty (residual variance of projecting ``k(x, .)`` on the BVs).
For a positive-definite kernel this equals the textbook ``k(x, x) + k_x^T C k_x``.
``docs/method.md`` derives every update; the code follows it line by line.

The GP knows kernels only through :class:`~sb3_geogp.kernels.Kernel`'s interface: it asks for
rows over the basis and tells the kernel of every insertion and deletion (the geodesic kernel
grows its graph from them). Default hyperparameters come from :mod:`sb3_geogp.defaults`.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, NamedTuple, TypeVar, cast

import numpy as np
import torch
from torch import Tensor, nn

from sb3_geogp import defaults, saved_state, trends
from sb3_geogp.adaptation import (
    Adaptation,
    Projection,
    RetainedWindow,
    Summary,
    age_weights,
    as_adaptation,
    forget_likelihood,
    gaussian_nll,
    jittered_cholesky,
    lagged_forgetting_scores,
    linear_moments,
    nlpd,
    sparse_posterior,
    thinned,
    weighted_moments,
)
from sb3_geogp.graph import BVGraph
from sb3_geogp.kernels import Kernel, KernelName, make_kernel
from sb3_geogp.kernels.base import BasisMatrices, Rows
from sb3_geogp.options import (
    check_number,
    check_same_options,
    non_negative_int,
    non_negative_number,
    positive_int,
)
from sb3_geogp.posterior_cache import PosteriorMatrices
from sb3_geogp.rollback import Rollback
from sb3_geogp.trends import RISE_THRESHOLD as RISE_THRESHOLD
from sb3_geogp.user_warnings import warn_user

ArrayLike = Tensor | np.ndarray | Sequence[Any]

#: Relative floor on a new BV's novelty: below it a nugget is added to its prior variance.
_GAMMA_FLOOR = 1e-6
#: Bounds on the rows of a batch whose novelty is screened at once (adapted in between).
_MIN_CHUNK, _MAX_CHUNK = 32, 1024
#: Factor by which the at-capacity novelty floor rises with each newcomer at capacity.
_FLOOR_STEP = 1.1
#: Deletions per absorbed point the floor tolerates in the long run (it falls by
#: ``_FLOOR_STEP ** _DELETION_RATE`` per point absorbed).
_DELETION_RATE = 0.003
_FLOOR_MAX = 0.99
#: The least floor a rise starts from: a floor of 0 (``novelty_tol=0``) would stay 0 under any
#: factor, and the churn it bounds would not be bounded. Below every tolerance in use above 0
#: (1e-3 is the least), so their floors move as before.
_FLOOR_BASE = 1e-3
#: Largest growth of ``||Q||`` (times the signal variance) one new BV may cause.
_Q_GROWTH = 1e4

#: Prior mean functions of :class:`SparseOnlineGP`.
_PRIOR_MEANS = ("constant", "linear")
#: Points retained for :meth:`SparseOnlineGP.fit_hyperparameters` without adaptation.
_DEFAULT_WINDOW = Adaptation.window
#: Weight of the newest batch in the spreads that cap the optimism bonus (session 29's value).
_SPREAD_WEIGHT = 0.1
#: Largest state the constructor allocates (bytes), or the machine's memory where smaller;
#: above it, it refuses with the estimate.
_MAX_STATE_BYTES = 2**36
#: Long scalar buffers of the GP.
_COUNTERS = (
    "count",
    "initialized",
    "n_seen",
    "n_added",
    "n_deleted",
    "n_batches",
    "n_blocks",
    "block_new",
    "n_pruned",
    "summary_batch",
    "last_batch_points",
    "refit_seen",
)


def _check_scalars(
    noise_var: float,
    novelty_tol: float | None,
    forgetting: float,
    target_mean: float | None,
    target_scale: float | None,
    optimism: float,
) -> None:
    """Refuse a scalar option of :class:`SparseOnlineGP` that is not a number or is outside
    its range."""
    given = dict(
        noise_var=noise_var,
        novelty_tol=novelty_tol,
        forgetting=forgetting,
        target_mean=target_mean,
        target_scale=target_scale,
        optimism=optimism,
    )
    for name, value in given.items():
        if value is not None:
            check_number(name, value)
    if not (noise_var > 0 and math.isfinite(noise_var)):
        raise ValueError(f"noise_var must be positive and finite, got {noise_var}")
    if novelty_tol is not None and not (0 <= novelty_tol < 1):
        raise ValueError(f"novelty_tol must be in [0, 1), got {novelty_tol}")
    if not (0 < forgetting <= 1):
        raise ValueError(f"forgetting must be in (0, 1], got {forgetting}")
    if target_scale is not None and not (target_scale > 0 and math.isfinite(target_scale)):
        raise ValueError(f"target_scale must be positive and finite, got {target_scale}")
    if target_mean is not None and not math.isfinite(target_mean):
        raise ValueError(f"target_mean must be finite, got {target_mean}")
    non_negative_number("optimism", optimism)


def _check_mean_and_trend(prior_mean: str, trend: str, target_mean: float | None) -> None:
    """Refuse an unknown prior mean or trend, or two that say the same thing."""
    if prior_mean not in _PRIOR_MEANS:
        raise ValueError(f"prior_mean must be one of {_PRIOR_MEANS}, got {prior_mean!r}")
    if prior_mean == "linear" and target_mean is not None:
        raise ValueError(
            "prior_mean='linear' fits its own intercept: leave target_mean None, or use "
            "prior_mean='constant' to fix the mean"
        )
    if trend not in trends.TRENDS:
        raise ValueError(f"trend must be one of {trends.TRENDS}, got {trend!r}")
    if trend == "linear" and prior_mean == "linear":
        raise ValueError(
            "trend='linear' and prior_mean='linear' are two ways of one line: choose one"
        )


def _check_cap(cap: float | None, optimism: float, adaptation: Adaptation | None) -> None:
    """Refuse an ``optimism_cap`` that is not positive and finite, or that has no bonus to cap
    or no out-of-sample errors to scale it by."""
    if cap is None:
        return
    if not (cap > 0 and math.isfinite(cap)):
        raise ValueError(f"optimism_cap must be a positive finite number or None, got {cap}")
    if not optimism:
        raise ValueError("optimism_cap caps the optimism bonus: set optimism > 0 with it")
    if adaptation is None:
        raise ValueError(
            "optimism_cap scales the bonus by the out-of-sample errors the adaptation measures: "
            "pass adapt=True (or an Adaptation) with it"
        )


def _check_dtype(dtype: Any, kernel: Kernel, adaptation: Adaptation | None) -> torch.dtype:
    """``dtype`` as a torch dtype the engine computes in safely with ``kernel`` and
    ``adaptation``."""
    if isinstance(dtype, str):  # a torch name: "float64", "double", "torch.float32", ...
        dtype = getattr(torch, dtype.removeprefix("torch."), dtype)
    if dtype not in (torch.float64, torch.float32):
        raise ValueError(
            f"dtype must be torch.float64 (default) or torch.float32, got {dtype!r}: the "
            "engine's distances and Cholesky factorisations need at least single precision"
        )
    if dtype == torch.float32 and not kernel.supports_float32():
        raise ValueError(
            f"{type(kernel).__name__}({kernel.extra_repr()}) is not numerically safe in "
            "float32 (its basis Gram matrix is too ill-conditioned: updates fail or diverge); "
            "use dtype=torch.float64, or a kernel with a Laplacian profile in float32 "
            "(GeodesicKernel(profile='laplacian'), LaplacianKernel; by name in "
            "GPActorCriticPolicy's gp_kwargs, kernel='geodesic' or kernel='laplacian')"
        )
    if dtype == torch.float32 and adaptation and adaptation.forgetting_score == "lagged":
        # The 10^6-point pendulum soak left P indefinite after 862k points (docs/benchmarks.md).
        raise ValueError(
            "Adaptation(forgetting_score='lagged') is not numerically safe in float32 (its "
            "forgetting in the likelihood left P indefinite in a long run); use "
            "dtype=torch.float64, or forgetting_score='shrink' in float32"
        )
    return cast(torch.dtype, dtype)


def _check_memory(
    capacity: int,
    input_dim: int,
    kernel: Kernel,
    dtype: torch.dtype,
    window: int,
    device: torch.device | str | None,
) -> None:
    itemsize = torch.empty((), dtype=dtype).element_size()
    nbytes = itemsize * (3 * capacity * capacity + (input_dim + 6) * capacity)
    nbytes += window * (itemsize * (input_dim + 1) + 8)
    nbytes += kernel.state_nbytes(capacity, input_dim, itemsize)
    limit, what = _MAX_STATE_BYTES, "the engine's limit"
    memory = _device_memory(device)
    if memory < limit:
        limit, what = memory, f"the memory of {torch.device(device or 'cpu')}"
    if nbytes > limit:
        raise ValueError(
            f"max_basis={capacity - 1} with a {window}-point window needs about "
            f"{nbytes / 2**30:.3g} GiB of state (more than {what}, {limit / 2**30:.3g} GiB); "
            "choose a smaller max_basis (or Adaptation.window)"
        )


def _device_memory(device: torch.device | str | None) -> int:
    """The memory of ``device`` in bytes: a GPU's, or this machine's where the OS says (else
    no bound). Beyond it a GPU raises out of memory mid-construction, and the OS kills the
    process without a word."""
    where = torch.device(device or "cpu")
    if where.type == "cuda":
        return int(torch.cuda.get_device_properties(where).total_memory)
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # no sysconf (Windows) or no such name
        return sys.maxsize


_Method = TypeVar("_Method", bound=Callable[..., Any])


def _engine_threads(method: _Method) -> _Method:
    """Run ``method`` of a GP with its ``num_threads`` torch threads, then restore the caller's."""

    @functools.wraps(method)
    def wrapper(gp: SparseOnlineGP, *args: Any, **kwargs: Any) -> Any:
        before = torch.get_num_threads()
        if gp.num_threads is None or gp.num_threads == before:
            return method(gp, *args, **kwargs)
        torch.set_num_threads(gp.num_threads)
        try:
            return method(gp, *args, **kwargs)
        finally:
            torch.set_num_threads(before)

    return cast(_Method, wrapper)


class SparseOnlineGP(nn.Module):
    """Sparse on-line GP value-function estimator with a Euclidean or geodesic kernel.

    Parameters
    ----------
    input_dim : int
        Dimension ``d`` of the inputs (flattened observations).
    kernel : Kernel or {"rbf", "laplacian", "matern", "geodesic"}
        Covariance function; a name builds :class:`RBFKernel`, :class:`LaplacianKernel`,
        :class:`MaternKernel` or :class:`GeodesicKernel` with default options.
    max_basis : int
        Capacity ``m_max`` of the basis set.
    noise_var : float
        Observation-noise variance ``sigma_n^2`` in standardised target units.
    novelty_tol : float or None
        A point becomes a BV when its relative novelty ``gamma / k(x, x)`` exceeds this
        (once the basis is full it must also beat the least novel BV and an adaptive floor).
        ``None``: the novelty of a point a quarter lengthscale from a single BV,
        ``1 - rho(0.25)^2`` (0.06 for the RBF kernel, 0.39 for the Laplacian geodesic one;
        :data:`sb3_geogp.defaults.NOVELTY_RADIUS`).
    forgetting : float
        ``lambda`` in (0, 1]; before each batch ``alpha <- sqrt(lambda) alpha`` and
        ``C <- lambda C`` (1 = no forgetting). With adaptation, the forgetting applied until
        the evidence has chosen one (docs/method.md, section 2.3).
    forgetting_points : int or None
        The number of points ``forgetting`` (and the adaptation's forgetting candidates) is
        per: a batch of ``n`` points is preceded by the factor ``lambda ** (n /
        forgetting_points)``, so batches of any size forget alike per point (SB3's PPO
        rollouts are 8 points on MountainCarContinuous, 4,096 on the pendulums). ``None``:
        per batch, whatever its size. Ages in a refit's rebuild and in the summary count
        batches of the newest batch's size.
    target_mean, target_scale : float or None
        Prior mean and scale of the targets: the GP models ``(y - target_mean) / target_scale``.
        ``None`` takes the mean and standard deviation of the first batch (the sample standard
        deviation, ``n - 1`` in the denominator; kept fixed after, unless the adaptation
        re-estimates them). The values in use are :attr:`y_mean` and :attr:`y_scale`, with
        which an exact GP on ``(y - y_mean) / y_scale`` (kernel :attr:`kernel`, noise
        :attr:`noise_var`) reproduces this one where every point is a BV.
    prior_mean : {"constant", "linear"}
        The GP's prior mean function ``m(x)``: a constant (``target_mean``), or ``c + b^T x``,
        fitted by least squares to the first batch and, with adaptation, to the retained
        window at every refit, the scale then being that of the residuals. Far from the data
        the constant mean reverts to the targets' average and the linear one follows their
        trend, as a linear model or an MLP would (docs/method.md, section 4); not with the
        geodesic kernel's default ``attach="interpolate"``, whose far points are predicted as
        their nearest basis vectors are (:class:`~sb3_geogp.GeodesicKernel`). ``"linear"``
        takes no ``target_mean``.
    trend : {"none", "level", "sloped_level", "rising_level", "constant", "linear"}
        A trend ``w^T [x, 1]`` under the GP, moved as each batch arrives, before the GP is fed
        what it leaves, ``y - w^T [x, 1]``; predictions are the current trend plus the GP.
        ``"linear"``: the batch's least-squares line (ridge ``1e-3 n`` on the raw second moments
        of ``[x, 1]``); ``"constant"``: its intercept alone (the batch's mean over ``1.001``);
        ``"level"``: an intercept ``b`` moved by the batch's mean error under the model before
        it absorbs the batch, ``b <- b + mean(y - b - mu(x))`` (the first batch leaves 0);
        ``"sloped_level"``: the level with slopes, the whole line moved by the ridge line of the
        batch's errors, ``w <- w + ridge(y - w^T [x, 1] - mu(x))``, where the lines fit on
        either half of the batch predict the other half's errors better than its mean error
        (else by the mean error alone, as the level); ``"rising_level"``: a level that only
        rises, by what the batch's mean error exceeds
        :data:`~sb3_geogp.trends.RISE_THRESHOLD` standard errors by,
        ``b <- b + max(0, mean(e) - 2 std(e) / sqrt(n))``, so that a critic left below
        its (bootstrapped) targets catches up within a batch while one above them, an
        optimistic one, comes down only as its GP absorbs the data, and noise alone rarely
        moves it (docs/method.md, section 4).
        Unlike ``prior_mean="linear"``, the GP's data are never re-expressed relative to a new
        trend: each keeps the residual of its own batch. Meant for batches of thousands of
        points (a PPO rollout); the out-of-sample statistics of :attr:`last_stats` are then the
        GP's, on the residuals (docs/method.md, section 4). ``"linear"`` not with
        ``prior_mean="linear"``.
    optimism : float
        ``beta >= 0``: the model's value (:meth:`forward`, what a policy's value head reads) is
        the upper confidence bound ``mu(x) + beta sigma(x)`` of the latent value instead of
        its mean, so that states the model knows little of look better than those it knows
        (an exploration bonus through the advantages; docs/method.md, section 4).
        :meth:`predict`, the trend and the adaptation use the mean alone. 0 (the default): the
        mean.
    optimism_cap : float or None
        ``c > 0``: the bonus is scaled down, ``beta s sigma(x)`` with
        ``s = min(1, c s_err / (beta s_sigma))``, so that its spread over the states is at
        most ``c`` times that of the model's errors: ``s_sigma`` and ``s_err`` are the standard
        deviations over each batch's scored points of ``sigma`` and of the out-of-sample errors
        before the batch is absorbed, each averaged over batches with weight ``0.1`` on the
        newest (:attr:`bonus_spreads`; ``s = 1`` until the second batch). Needs
        ``optimism > 0`` and ``adapt``, whose out-of-sample statistics it reads. ``None``
        (the default): no cap.
    drift_forgetting : float
        Forgetting by how far the source of the targets moved: a batch fed with
        ``update(..., drift=delta)`` weighs everything absorbed before it by
        ``exp(-drift_forgetting * delta)``, on top of ``forgetting``, on-line and in a refit's
        rebuild (each retained point keeps the log-weight it has lost,
        :class:`~sb3_geogp.adaptation.RetainedWindow`). Under a policy that does not move
        (``delta = 0``) nothing is forgotten. :class:`~sb3_geogp.GPActorCriticPolicy` passes
        the policy's mean KL divergence between consecutive feeds (docs/method.md, section
        2.3). 0 (the default): ``drift`` is ignored.
    input_bounds : (low, high) of array-likes with ``input_dim`` entries each, optional
        Bounds of the inputs where known: unset lengthscales of bounded dimensions then come
        from the bounds rather than from the first batch (:mod:`sb3_geogp.defaults`). Bounds
        the inputs barely fill (under 5 % of a dimension after 10,000 inputs), or go far
        outside (over twice their width), are named by a :class:`~sb3_geogp.GPCriticWarning`
        (:class:`~sb3_geogp.defaults.BoundsCoverage`).
    lengthscale_rule : {"spread", "distance"}
        How the kernel's unset lengthscales follow each input's spread (from ``input_bounds``
        or the first batch, and with ``Adaptation.follow_spread`` the window's):
        ``"spread"`` (the default) the spread itself, ``"distance"`` the spread times
        ``sqrt(input_dim)``, so that typical inputs stay about ``sqrt(2)`` lengthscales apart
        however many there are (:data:`sb3_geogp.defaults.LENGTHSCALE_RULES`). Under
        ``"spread"`` with many inputs (HalfCheetah-v5's 17) the kernel between typical states
        has all but vanished; yet on PPO HalfCheetah-v5 ``"distance"`` did not raise the
        return in its registered test (docs/results.md, "Lengthscales that grow with the
        number of inputs").
    num_threads : int or None
        Intra-op CPU threads of :meth:`update`, :meth:`predict` and :meth:`fit_hyperparameters`,
        set for the call and restored after it. The engine's work is many small matrix
        operations, which several threads slow down, by 10-100x on a busy machine (measured in
        docs/benchmarks.md). 1 by default; ``None`` keeps torch's setting.
    condition_guard : bool
        Project instead of inserting a novel point whose row would grow ``||Q||`` by more than
        ``1e4 / variance`` (docs/method.md, 2.5). It keeps long runs well conditioned, and is the
        one exception to ``novelty_tol=0`` making every point a BV: switch it off for an exact
        GP on a small, well-spread data set (with fixed hyperparameters: a refit of the
        adaptation or :meth:`fit_hyperparameters` still prunes redundant BVs, docs/method.md,
        section 4). The nugget of docs/method.md, 2.1 (a new BV's novelty floored at ``1e-6``
        of the signal variance) still applies.
    device : torch.device, str or None
        Where the state lives.
    dtype : torch.dtype or {"float64", "float32"}
        Floating type of the state (float64 by default). float32 is accepted only with kernels
        that are safe in it (:meth:`~sb3_geogp.kernels.Kernel.supports_float32`: the Laplacian
        profiles, checked against float64 in the tests); half precisions are refused.
    adapt : Adaptation, dict, bool or None
        Adapt hyperparameters, target mean and scale and forgetting to the data stream
        (:mod:`sb3_geogp.adaptation`); ``True`` takes :class:`Adaptation`'s defaults, a dict
        the settings it names (``{"prior_sd": 0.1}``). Off by
        default here (:class:`~sb3_geogp.GPActorCriticPolicy` turns it on). With it,
        ``forgetting`` is only the starting value, then chosen at every block.

    Attributes
    ----------
    window : RetainedWindow
        The most recent points fed (``adapt.window`` of them, else 2048): the data
        :meth:`fit_hyperparameters` and the adaptation fit and rebuild the posterior from.
    summary_prec, summary_shift, summary_unit : Tensor, shapes (m_max + 1, m_max + 1), (m_max + 1,)
        With adaptation, the :class:`~sb3_geogp.adaptation.Summary` of the points that left the
        window (a Gaussian likelihood of the standardised function values at the BVs), so that
        a rebuild keeps what they said; with ``Adaptation(summary="snapshot")``, of every
        batch before ``summary_batch`` and the points of later ones that left the window.
    last_stats : dict of str to float
        With adaptation, after each :meth:`update`: ``nlpd`` and ``explained_variance`` of the
        batch under the posterior before it was absorbed (out of sample, in the targets'
        units), and after each adaptation ``forgetting`` and ``target_drift`` (the block's
        mean squared standardised target, 1 where none was scored, see
        :class:`~sb3_geogp.Adaptation`'s ``drift_tol``),
        after each refit ``lengthscale`` (geometric mean), ``lengthscale_<i>``,
        ``signal_var``, ``noise_var``, ``target_mean``, ``target_scale``; with
        ``optimism_cap`` ``bonus_scale`` (:meth:`bonus_scale`).
    bonus_spreads : Tensor, shape (2,)
        With ``optimism_cap``, the averaged spreads ``(s_sigma, s_err)`` that scale the bonus,
        in the targets' units (zeros before the second batch).
    y_mean, y_scale : Tensor, shape ()
        The target standardisation in use: the GP models ``(y - y_mean) / y_scale`` (after
        the trend, if any).
    noise_var : Tensor, shape ()
        Observation noise variance, in standardised units.

    Notes
    -----
    Targets are standardised with the mean and sample standard deviation of the first batch
    (kept fixed afterwards unless the adaptation re-estimates them); :meth:`predict` returns
    values in the units fed to :meth:`update`, and before the first batch the prior (mean
    ``target_mean``, variance the signal variance times ``target_scale`` squared; 0 and 1 where
    they are not given). Lengthscales not given (``None``, or NaN entries)
    follow :mod:`sb3_geogp.defaults`: from ``input_bounds`` where bounded, else the population
    standard deviation (``n`` in the denominator) in the first batch.
    """

    bv_x: Tensor
    bv_y: Tensor
    nugget: Tensor
    alpha: Tensor
    P: Tensor
    Q: Tensor
    summary_prec: Tensor
    summary_shift: Tensor
    summary_unit: Tensor
    summary_input: Tensor
    noise_var: Tensor
    y_mean: Tensor
    y_scale: Tensor
    y_slope: Tensor
    trend_coef: Tensor
    count: Tensor
    initialized: Tensor
    n_seen: Tensor
    n_added: Tensor
    n_deleted: Tensor
    n_batches: Tensor
    n_blocks: Tensor
    block_new: Tensor
    forgetting_scores: Tensor
    block_moments: Tensor
    block_errors: Tensor
    n_pruned: Tensor
    summary_batch: Tensor
    last_batch_points: Tensor
    refit_seen: Tensor
    novelty_floor: Tensor
    block_forgetting: Tensor
    ls_start: Tensor
    ls_from_data: Tensor
    bonus_spreads: Tensor
    window: RetainedWindow

    def __init__(
        self,
        input_dim: int,
        kernel: Kernel | KernelName = "geodesic",
        max_basis: int = 256,
        noise_var: float = 0.05,
        novelty_tol: float | None = None,
        forgetting: float = 1.0,
        forgetting_points: int | None = None,
        target_mean: float | None = None,
        target_scale: float | None = None,
        input_bounds: tuple[ArrayLike, ArrayLike] | None = None,
        num_threads: int | None = 1,
        condition_guard: bool = True,
        device: torch.device | str | None = None,
        dtype: torch.dtype | str = torch.float64,
        adapt: Adaptation | Mapping[str, Any] | bool | None = None,
        prior_mean: str = "constant",
        trend: str = "none",
        optimism: float = 0.0,
        optimism_cap: float | None = None,
        drift_forgetting: float = 0.0,
        lengthscale_rule: str = "spread",
    ) -> None:
        super().__init__()
        input_dim = positive_int("input_dim", input_dim)
        defaults.lengthscale_factor(lengthscale_rule, input_dim)  # refuses an unknown rule
        self.lengthscale_rule = lengthscale_rule
        max_basis = positive_int("max_basis", max_basis)
        if forgetting_points is not None:
            forgetting_points = positive_int("forgetting_points", forgetting_points)
        _check_scalars(noise_var, novelty_tol, forgetting, target_mean, target_scale, optimism)
        _check_mean_and_trend(prior_mean, trend, target_mean)
        self.prior_mean = prior_mean
        self.trend = trend
        self.optimism = float(optimism)
        self.optimism_cap = None if optimism_cap is None else float(optimism_cap)
        self.drift_forgetting = non_negative_number("drift_forgetting", drift_forgetting)
        if num_threads is not None:
            num_threads = positive_int("num_threads", num_threads)
        self.input_dim = int(input_dim)
        self.max_basis = int(max_basis)
        self.forgetting = float(forgetting)
        self.forgetting_points = forgetting_points
        self.num_threads = num_threads
        self.condition_guard = bool(condition_guard)
        self.kernel = make_kernel(kernel)
        self.adaptation = as_adaptation(adapt)
        _check_cap(optimism_cap, optimism, self.adaptation)
        dtype = _check_dtype(dtype, self.kernel, self.adaptation)
        self.novelty_tol = (
            self.kernel.novelty_at(defaults.NOVELTY_RADIUS)
            if novelty_tol is None
            else float(novelty_tol)
        )
        # One spare slot: a new BV is inserted before the least informative one is deleted.
        cap = self.max_basis + 1
        size = self.adaptation.window if self.adaptation is not None else _DEFAULT_WINDOW
        _check_memory(cap, self.input_dim, self.kernel, dtype, size, device)
        self.kernel.bind(self.input_dim, cap)
        # Diagnostics, not state: bounds far wider than the data leave the GP nearly flat.
        self._coverage = self._lengthscale_from(input_bounds)
        kw: dict[str, Any] = {"dtype": dtype, "device": device}
        self.kernel.to(**kw)
        self._fixed_target = (target_mean, target_scale)
        self._register_state(cap, noise_var, kw)
        self.window = RetainedWindow(size, self.input_dim).to(**kw)
        self.last_stats: dict[str, float] = {}
        self._cache: PosteriorMatrices | None = None
        self._rollback: Rollback | None = None

    def _lengthscale_from(
        self, input_bounds: tuple[ArrayLike, ArrayLike] | None
    ) -> defaults.BoundsCoverage | None:
        """Set the kernel's unset lengthscales of bounded dimensions from ``input_bounds``;
        return the check of how the inputs fill those bounds (``None`` without bounds)."""
        if input_bounds is not None and any(np.size(b) != self.input_dim for b in input_bounds):
            raise ValueError(
                f"input_bounds must be (low, high) with {self.input_dim} entries each, got "
                f"sizes {[np.size(b) for b in input_bounds]}"
            )
        ls = self.kernel.lengthscale
        unset = torch.isnan(ls).cpu().numpy()
        ls.copy_(defaults.resolve_lengthscale(ls, bounds=input_bounds, rule=self.lengthscale_rule))
        return (
            None
            if input_bounds is None
            else defaults.BoundsCoverage(*input_bounds, unset, self.lengthscale_rule)
        )

    def _register_state(self, cap: int, noise_var: float, kw: dict[str, Any]) -> None:
        """Register the state's buffers (``cap`` BV slots; dtype and device ``kw``), empty:
        zeros, but the starting noise, target units, novelty floor and forgetting."""
        target_mean, target_scale = self._fixed_target
        self.register_buffer("noise_var", torch.tensor(float(noise_var), **kw))
        self.register_buffer("bv_x", torch.zeros(cap, self.input_dim, **kw))
        self.register_buffer("bv_y", torch.zeros(cap, **kw))
        self.register_buffer("nugget", torch.zeros(cap, **kw))
        self.register_buffer("alpha", torch.zeros(cap, **kw))
        self.register_buffer("P", torch.zeros(cap, cap, **kw))
        self.register_buffer("Q", torch.zeros(cap, cap, **kw))
        self.register_buffer("summary_prec", torch.zeros(cap, cap, **kw))
        self.register_buffer("summary_shift", torch.zeros(cap, **kw))
        self.register_buffer("summary_unit", torch.zeros(cap, **kw))
        self.register_buffer("summary_input", torch.zeros(cap, self.input_dim, **kw))
        self.register_buffer("y_mean", torch.tensor(float(target_mean or 0.0), **kw))
        self.register_buffer("y_scale", torch.tensor(float(target_scale or 1.0), **kw))
        self.register_buffer("y_slope", torch.zeros(self.input_dim, **kw))
        self.register_buffer("trend_coef", torch.zeros(self.input_dim + 1, **kw))
        # Counters and flags as long tensors so that they travel with state_dict().
        for name in _COUNTERS:
            self.register_buffer(name, torch.zeros((), dtype=torch.long, device=kw["device"]))
        self.register_buffer("novelty_floor", torch.tensor(self.novelty_tol, **kw))
        self.register_buffer("block_forgetting", torch.tensor(self.forgetting, **kw))
        n_candidates = len(self.adaptation.forgetting) if self.adaptation is not None else 1
        self.register_buffer("forgetting_scores", torch.zeros(n_candidates, **kw))
        # Points scored in the open block and the sum of their squared standardised targets;
        # the sums of those targets, of their out-of-sample errors and of the errors' squares.
        self.register_buffer("block_moments", torch.zeros(2, **kw))
        self.register_buffer("block_errors", torch.zeros(3, **kw))
        self.register_buffer("ls_start", self.kernel.lengthscale.to(**kw).clone())
        # The dimensions whose lengthscale the first batch chose (Adaptation.follow_spread).
        self.register_buffer(
            "ls_from_data", torch.zeros(self.input_dim, dtype=torch.bool, device=kw["device"])
        )
        self.register_buffer("bonus_spreads", torch.zeros(2, **kw))
        # Not state: what the posterior was computed under (_settle). A buffer so that .to()
        # converts it as it converts the hyperparameters; a saved state's are its own.
        self.register_buffer("_posterior_hypers", self._hyperparameters(), persistent=False)
        self.register_load_state_dict_post_hook(SparseOnlineGP._settle_after_load)

    # ------------------------------------------------------------------------------------------
    # Read-only views
    # ------------------------------------------------------------------------------------------
    @property
    def n_basis(self) -> int:
        """Current number of basis vectors."""
        return int(self.count)

    @property
    def basis_inputs(self) -> Tensor:
        """Basis-vector inputs, shape (n_basis, d), in the units given to :meth:`update`."""
        return self.bv_x[: self.n_basis]

    @property
    def lengthscale_from_bounds(self) -> np.ndarray:
        """Which input dimensions took their starting lengthscale from ``input_bounds`` (bool,
        shape (d,); all ``False`` without bounds)."""
        if self._coverage is None:
            return np.zeros(self.input_dim, dtype=bool)
        return self._coverage.from_bounds.copy()

    @property
    def C(self) -> Tensor:
        """Csató–Opper ``C = P - Q``, shape (n_basis, n_basis)."""
        m = self.n_basis
        return self.P[:m, :m] - self.Q[:m, :m]

    @property
    def lengthscale(self) -> Tensor:
        """Kernel lengthscale, shape (d,) (NaN where still to be chosen from the first batch)."""
        return self.kernel.lengthscale

    @property
    def graph(self) -> BVGraph | None:
        """The kernel's basis-vector graph (geodesic kernel), or ``None``."""
        return self.kernel.graph

    @property
    def adjacency(self) -> Tensor:
        """Weighted adjacency among graph nodes (geodesic kernel), shape (N, N), 0 = no edge.

        Rows follow :attr:`graph_nodes`.
        """
        return self._require_graph().dense_adjacency()

    @property
    def shortest_paths(self) -> Tensor:
        """Shortest-path distances among the basis vectors, shape (n_basis, n_basis)."""
        return self._require_graph().basis_distances()

    @property
    def graph_nodes(self) -> Tensor:
        """Positions of all graph nodes (BVs and routing nodes), shape (N, d), input units."""
        graph = self._require_graph()
        return graph.pos[graph.alive] * self.kernel.lengthscale

    def _require_graph(self) -> BVGraph:
        graph = self.graph
        if graph is None:
            raise AttributeError("only a SparseOnlineGP with a GeodesicKernel has a BV graph")
        return graph

    def extra_repr(self) -> str:
        ls = ", ".join(f"{v:.4g}" for v in self.kernel.lengthscale.tolist())
        return (
            f"input_dim={self.input_dim}, max_basis={self.max_basis}, n_basis={self.n_basis}, "
            f"lengthscale=[{ls}], noise_var={float(self.noise_var):.4g}, "
            f"novelty_tol={self.novelty_tol}, forgetting={self.forgetting}"
        )

    # ------------------------------------------------------------------------------------------
    # Prediction
    # ------------------------------------------------------------------------------------------
    @torch.no_grad()
    @_engine_threads
    def predict(self, x: ArrayLike, return_var: bool = True) -> tuple[Tensor, Tensor | None]:
        """Posterior mean and variance of the latent value at ``x``.

        Parameters
        ----------
        x : Tensor or array, shape (n, d)
            Query inputs (any real dtype; cast to the GP's).
        return_var : bool
            Skip the O(n m^2) variance when ``False`` (the second output is then ``None``).

        Returns
        -------
        mean : Tensor, shape (n,)
            In target units.
        var : Tensor, shape (n,) or None
            Predictive variance of the latent value (no observation noise), ``>= 0``.

        Raises
        ------
        RuntimeError
            If the lengthscales, signal variance or ``noise_var`` were changed in place since
            the posterior was computed (set them at construction, or refit them with
            :meth:`fit_hyperparameters`).
        """
        x = self._as_inputs(x, "x")
        self._check_hyperparameters()
        m = self.n_basis
        variance = self.kernel.variance
        if m == 0:
            mean = torch.zeros(x.shape[0], dtype=x.dtype, device=x.device)
            var = variance.expand(x.shape[0]).clone() if return_var else None
        else:
            mean, var = self._latent(self._scaled(x), return_var)
        return self._in_units(x, mean), None if var is None else var * self.y_scale**2

    def _in_units(self, x: Tensor, latent: Tensor) -> Tensor:
        """The model's mean at ``x : (n, d)`` in target units from the GP's standardised mean
        ``latent : (n,)`` there: ``latent * scale + m(x) + trend(x)``, shape (n,)."""
        return latent * self.y_scale + self._prior(x) + self._trend(x)

    def _trend(self, x: Tensor) -> Tensor:
        """The trend ``w^T [x, 1]`` of ``x : (n, d)``, shape (n,); 0 without one."""
        return trends.value(self.trend_coef, x)

    def _fit_trend(self, x: Tensor, y: Tensor) -> Tensor:
        """Move the trend with the batch ``(x, y)`` (:func:`~sb3_geogp.trends.move`; a level by
        the model's errors on the batch before it absorbs it); return what it leaves,
        ``y - trend(x)``."""
        error = None
        if self.trend in trends.LEVELS and self.n_basis > 0:
            latent = self._latent(self._scaled(x), return_var=False)[0]
            error = y - self._in_units(x, latent)
        trends.move(self.trend, self.trend_coef, x, y, error)
        return y - self._trend(x)

    def _prior(self, x: Tensor) -> Tensor:
        """The prior mean ``m(x) = c + b^T x`` of ``x : (n, d)``, shape (n,), target units."""
        return self.y_mean + x @ self.y_slope

    def _standardised(self, x: Tensor, y: Tensor) -> Tensor:
        """``(y - m(x)) / scale``: the targets the GP models."""
        return (y - self._prior(x)) / self.y_scale

    def _matrices(self) -> PosteriorMatrices:
        """The basis matrices of the current state, each formed once and kept while valid.

        Updates tell the cache what they change (the posterior, ``Q``, the basis, whose Gram
        matrix grows or shrinks by one row in O(m)), so a small batch pays for no (m, m)
        product it does not change. :meth:`fit_hyperparameters`, ``load_state_dict``, ``.to()``
        and the first batch (which sets the lengthscale) empty it.
        """
        if self._cache is None:
            self._cache = PosteriorMatrices(self)
        return self._cache

    def _hyperparameters(self) -> Tensor:
        """The lengthscales, signal variance and noise variance in one vector, shape (k + 2,)."""
        kernel = self.kernel
        return torch.cat(
            [kernel.lengthscale.reshape(-1), kernel.variance.reshape(1), self.noise_var.reshape(1)]
        )

    def _settle(self) -> None:
        """Record the hyperparameters as those the posterior now has."""
        self._posterior_hypers = self._hyperparameters()

    @staticmethod
    def _settle_after_load(gp: nn.Module, incompatible_keys: Any) -> None:
        # A post hook: the kernel's hyperparameters load after the GP's own buffers, and a
        # policy's load_state_dict reaches the GP only through torch's recursion.
        assert isinstance(gp, SparseOnlineGP)
        gp._settle()

    def _check_hyperparameters(self) -> None:
        """Refuse a posterior whose hyperparameters were changed from outside the engine.

        ``alpha``, ``P`` and ``Q`` hold for the hyperparameters they were computed under; after
        an in-place change (``gp.kernel.lengthscale.mul_(2)``) predictions would be silently
        wrong. With no basis vectors there is no posterior to contradict.
        """
        if self.n_basis == 0:
            return
        now = self._hyperparameters()
        if torch.equal(now, self._posterior_hypers):
            return
        raise RuntimeError(
            "the GP's hyperparameters (lengthscales, signal variance, noise_var) were changed in "
            f"place, from {self._posterior_hypers.tolist()} to {now.tolist()}, but its "
            "posterior was computed under the old ones and would now predict wrongly. Put the "
            "old values back; or fit new ones with fit_hyperparameters() (change a geodesic "
            "kernel's lengthscales through kernel.rescale(), which moves its tree too); or "
            "set them when the GP is built "
            f"(kernel={type(self.kernel).__name__}(lengthscale=...), noise_var=...; in a "
            "policy's gp_kwargs, kernel_kwargs=dict(lengthscale=...))"
        )

    def _apply(self, fn: Callable[[Tensor], Tensor], recurse: bool = True) -> SparseOnlineGP:
        # .to(dtype), .float(), .half() convert through here: refuse what the constructor
        # refuses, before any buffer changes.
        current = self.alpha.dtype
        converted = fn(torch.zeros((), dtype=current, device=self.alpha.device)).dtype
        if converted != current:
            _check_dtype(converted, self.kernel, self.adaptation)
        self._cache = None
        return super()._apply(fn, recurse)

    def options(self) -> dict[str, Any]:
        """Options stored in the state (``state_dict()["_extra_state"]``).

        A state saved with another ``input_dim`` or ``max_basis`` (or another kernel, see
        :meth:`~sb3_geogp.kernels.Kernel.options`) is refused on load, before anything is
        loaded. ``novelty_tol`` and ``forgetting`` may differ: they only steer later updates.
        """
        return {
            "input_dim": self.input_dim,
            "max_basis": self.max_basis,
            "novelty_tol": self.novelty_tol,
            "forgetting": self.forgetting,
            "forgetting_points": self.forgetting_points,
            "window": self.window.size,
            "adapt": None if self.adaptation is None else self.adaptation.as_dict(),
            "prior_mean": self.prior_mean,
            "trend": self.trend,
            "optimism": self.optimism,
            "optimism_cap": self.optimism_cap,
            "drift_forgetting": self.drift_forgetting,
            "lengthscale_rule": self.lengthscale_rule,
        }

    def get_extra_state(self) -> dict[str, Any]:
        return self.options()

    def set_extra_state(self, state: Any) -> None:
        state = saved_state.upgrade_options(state)
        check_same_options("SparseOnlineGP", state, self.options(), saved_state.UPDATE_RULES)

    def _load_from_state_dict(
        self, state_dict: dict[str, Any], prefix: str, *args: Any, **kwargs: Any
    ) -> None:
        saved_state.upgrade(state_dict, prefix, self)
        # Check every stored option before loading anything, so a refused state leaves this
        # GP exactly as it was (the kernel's check would otherwise come after the GP's buffers).
        for key, module in (("_extra_state", self), ("kernel._extra_state", self.kernel)):
            if prefix + key in state_dict:
                module.set_extra_state(state_dict[prefix + key])
        saved_state.check_posterior(state_dict, prefix, self.max_basis)
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)
        self._cache = None

    def load_state_dict(
        self, state_dict: Mapping[str, Any], strict: bool = True, assign: bool = False
    ) -> Any:
        """As :meth:`torch.nn.Module.load_state_dict`; a state refused for any reason (other
        options, a missing or misshapen buffer, a corrupted posterior) leaves this GP exactly as
        it was (torch alone would have copied the buffers it could before raising)."""
        before = saved_state.state_to_restore(self, assign)
        try:
            return super().load_state_dict(state_dict, strict=strict, assign=assign)
        except Exception:
            super().load_state_dict(before, assign=assign)
            raise

    def _latent(self, xs: Tensor, return_var: bool) -> tuple[Tensor, Tensor | None]:
        """Standardised posterior mean and variance at scaled inputs ``xs : (n, d)``."""
        basis = self._matrices()
        rows = self.kernel.rows(xs, basis.z)
        mean = rows.mean(basis)
        return mean, self._latent_variance(rows, basis)[1] if return_var else None

    def _latent_variance(
        self, rows: Rows, basis: BasisMatrices, kqk: Tensor | None = None
    ) -> tuple[Tensor, Tensor]:
        """The basis's residual ``gamma = k(x, x) - k_x^T Q k_x`` and the latent variance
        ``gamma + k_x^T P k_x`` of points with kernel rows ``rows``, shapes (n,), ``>= 0``
        (``kqk``: ``k_x^T Q k_x`` where already known)."""
        kqk = rows.kqk(basis) if kqk is None else kqk
        gamma = (self.kernel.variance - kqk).clamp_min(0)
        return gamma, (gamma + rows.kpk(basis)).clamp_min(0)

    def forward(self, x: Tensor) -> Tensor:
        """The value at ``x : (n, d)``, shape (n,): the posterior mean, plus ``optimism``
        posterior standard deviations of the latent value where ``optimism > 0``,
        ``mu(x) + beta sigma(x)`` (``beta s sigma(x)`` with ``optimism_cap``)."""
        if not self.optimism:
            return self.predict(x, return_var=False)[0]
        mean, var = self.predict(x)
        assert var is not None
        return mean + self.optimism * self.bonus_scale() * var.sqrt()

    def bonus_scale(self) -> float:
        """``s`` of ``optimism_cap``: ``min(1, c s_err / (beta s_sigma))``; 1 without a cap
        or before the spreads are known."""
        if self.optimism_cap is None:
            return 1.0
        sigma_spread, error_spread = self.bonus_spreads.tolist()
        if sigma_spread <= 0:
            return 1.0
        return min(1.0, self.optimism_cap * error_spread / (self.optimism * sigma_spread))

    # ------------------------------------------------------------------------------------------
    # Learning
    # ------------------------------------------------------------------------------------------
    @torch.no_grad()
    @_engine_threads
    def update(
        self,
        x: ArrayLike,
        y: ArrayLike,
        episode_starts: ArrayLike | None = None,
        drift: float = 0.0,
    ) -> None:
        """Absorb a batch of points in order, as Csató–Opper on-line updates.

        Parameters
        ----------
        x : Tensor or array, shape (n, d)
            Inputs, in trajectory order.
        y : Tensor or array, shape (n,)
            Noisy targets (e.g. returns), in the user's units.
        episode_starts : Tensor or array of bool, shape (n,), optional
            ``True`` where a new trajectory starts. A new BV is joined to the previous BV of its
            own trajectory (geodesic kernel with ``edges="trajectory"``); ``False`` at index 0
            continues the trajectory of the previous call. ``None`` means no trajectory
            information: every new BV joins its nearest BV.
        drift : float
            How far the source of the targets moved since the previous batch, in any
            non-negative measure (:class:`~sb3_geogp.GPActorCriticPolicy` passes the policy's
            mean KL divergence). With ``drift_forgetting=r`` everything absorbed before this
            batch then weighs ``exp(-r * drift)`` times as much, on top of ``forgetting``; in
            a refit's rebuild too. 0 (default): no drift.

        Raises
        ------
        ValueError
            On wrong shapes, non-finite values or non-numeric input, or a negative or
            non-finite ``drift``; the state is left
            exactly as it was (as it is on any error raised inside the update).
        RuntimeError
            As :meth:`predict`, before anything changes.
        """
        x, y, starts = self._validate(x, y, episode_starts)
        decay = self.drift_forgetting * non_negative_number("drift", drift)
        self._check_hyperparameters()
        with self._transaction():
            self._update(x, y, starts, decay)
        self._settle()
        if self._coverage is not None and not self._coverage.checked:
            self._coverage.add(x)
            if (message := self._coverage.check(self.kernel.lengthscale)) is not None:
                warn_user(message)

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[None]:
        """Undo every change of the state if the body raises."""
        self._rollback = Rollback(self)
        try:
            yield
        except BaseException:
            try:
                self._rollback.restore()
            finally:
                self._cache = None
            raise
        finally:
            self._rollback = None

    def _update(self, x: Tensor, y: Tensor, starts: Tensor, decay: float) -> None:
        if self.trend != "none":
            y = self._fit_trend(x, y)
        if not bool(self.initialized):
            self._initialize(x, y)
            self._cache = None
        xs = self._scaled(x)
        yn = self._standardised(x, y)
        # Squares too: the statistics of a batch sum them, and Python's floats raise on overflow.
        if not bool(torch.isfinite(yn.square()).all()):
            raise ValueError(
                f"targets standardised with mean {float(self.y_mean):.3g} and scale "
                f"{float(self.y_scale):.3g} overflow; rescale the targets or pass "
                "target_mean and target_scale"
            )
        screen, scored = self._score(x, xs, y)
        lam = self.forgetting if self.adaptation is None else float(self.block_forgetting)
        lam = self._batch_forgetting(lam, x.shape[0])
        if decay > 0:
            # The retained points age with what the posterior forgets, so that a rebuild
            # weighs them as the on-line updates did.
            self.window.age(decay)
            lam *= math.exp(-decay)
        if lam < 1 and self.n_basis > 0:
            self._forget(lam)
        added_before = int(self.n_added)
        self._absorb_in_order(x, y, xs, yn, starts, screen, scored)
        if int(self.n_added) > added_before:
            self._refresh_Q()
        n = x.shape[0]
        self.n_seen += n
        self.n_batches += 1
        self.last_batch_points.fill_(n)
        self._retain(x, y)
        self._check_finite()

    def _score(self, x: Tensor, xs: Tensor, y: Tensor) -> tuple[_Screen, _BatchRows | None]:
        """With adaptation and a basis: the batch's statistics out of sample and its scores
        (:meth:`_out_of_sample`), and a snapshot where one is due. Returns the novelty and the
        rows the scoring formed, for the rest of the update to reuse."""
        screen = _Screen()
        if self.adaptation is None or self.n_basis == 0:
            return screen, None
        stats, scored = self._out_of_sample(x, xs, y)
        self.last_stats.update(stats)
        if scored is not None and self.kernel.novelty_from_rows:
            screen.keep(scored.version, 0, self._relative_novelty(scored.kqk))
        if self._snapshot_due(self.adaptation, x.shape[0]):
            self._snapshot()
        return screen, scored

    def _absorb_in_order(
        self,
        x: Tensor,
        y: Tensor,
        xs: Tensor,
        yn: Tensor,
        starts: Tensor,
        screen: _Screen,
        scored: _BatchRows | None,
    ) -> None:
        """The batch's points in order: each novel one inserted as a BV (with a deletion at
        capacity), the runs between them absorbed by projection, trajectories started where
        ``starts`` says. ``x, y``: inputs and targets in the user's units (the targets less the
        trend, if any); ``xs, yn``: scaled and standardised; ``screen``, ``scored``: novelty
        and rows already known."""
        n = x.shape[0]
        # Rows [pending, i) wait to be absorbed in one block: non-novel rows and novel ones
        # whose BV row is rejected. Rows after the last inserted one may start a trajectory
        # (checked from ``linked`` on). At capacity a newcomer takes the spare slot and the
        # least informative BV is deleted only when the next newcomer arrives or the batch
        # ends: the newcomer is judged with the support of the points absorbed after it.
        i = pending = linked = 0
        while i < n:
            p = self._next_novel(xs, i, screen)
            self._scale_floor(_FLOOR_STEP ** (-_DELETION_RATE * (p - i)))
            i = p + 1
            if p == n:
                break
            if bool(starts[linked : p + 1].any()):
                self.kernel.start_trajectory()
            linked = p + 1
            if pending < p:
                self._absorb(xs, yn, pending, p, scored)
                pending = p
            if self.n_basis > self.max_basis:
                self._delete_least_informative()
                i = p  # judged again against the basis without the deleted BV
                continue
            plan = self._plan_insertion(x[p], yn[p])
            if plan is None:
                continue
            if self.n_basis == self.max_basis:
                self._scale_floor(_FLOOR_STEP)
            self._insert(plan, x[p], y[p])
            pending = p + 1
        if pending < n:
            self._absorb(xs, yn, pending, n, scored)
        if self.n_basis > self.max_basis:
            self._delete_least_informative()
        if bool(starts[linked:].any()):
            self.kernel.start_trajectory()

    def _forget(self, lam: float) -> None:
        """Age everything absorbed by one batch, and the summary's weights times ``lam``:
        ``alpha <- sqrt(lam) alpha``, ``C <- lam C`` (``P <- lam P + (1 - lam) Q``), or with
        ``Adaptation(forgetting_score="lagged")`` the posterior's likelihood times ``lam``
        (:func:`~sb3_geogp.adaptation.forget_likelihood`, in float64)."""
        if self.adaptation is not None and self.adaptation.forgetting_score == "lagged":
            m = self.n_basis
            L = self._matrices().P_cholesky
            state = (self.alpha[:m].double(), L, self.Q[:m, :m].double())
            alpha, P = forget_likelihood(*state, lam)
            self.alpha[:m], self.P[:m, :m] = alpha.to(self.alpha), P.to(self.P)
        else:
            self.alpha.mul_(math.sqrt(lam))
            self.P.mul_(lam).add_(self.Q, alpha=1 - lam)
        for buf in (self.summary_prec, self.summary_shift, self.summary_unit, self.summary_input):
            buf.mul_(lam)
        self._matrices().posterior_changed()

    def _initialize(self, x: Tensor, y: Tensor) -> None:
        """Standardise targets and choose the remaining lengthscales from the first batch."""
        mean, scale = defaults.target_standardisation(y, *self._fixed_target)
        if self.prior_mean == "linear":
            mean, slope, residual = linear_moments(x, y, torch.ones_like(y))
            self.y_slope.copy_(slope)
            if self._fixed_target[1] is None and residual > 1e-8 * float(scale):
                scale = residual
        self.y_mean.fill_(mean)
        self.y_scale.fill_(scale)
        if not (math.isfinite(float(self.y_mean)) and 0 < float(self.y_scale) < math.inf):
            raise ValueError(
                f"the first batch's targets (|y| up to {float(y.abs().max()):.3g}) give target "
                f"mean {float(self.y_mean):.3g} and scale {float(self.y_scale):.3g}; rescale "
                "the targets or pass target_mean and target_scale"
            )
        ls = self.kernel.lengthscale
        self.ls_from_data.copy_(torch.isnan(ls))
        ls.copy_(defaults.resolve_lengthscale(ls, x=x, rule=self.lengthscale_rule))
        if not bool((torch.isfinite(ls) & (ls > 0)).all()):
            raise ValueError(
                f"the first batch's inputs (|x| up to {float(x.abs().max()):.3g}) give "
                f"lengthscale {ls.tolist()}; rescale the inputs or give the kernel a lengthscale"
            )
        self.ls_start.copy_(ls)
        self.initialized.fill_(1)

    def _scaled(self, x: Tensor) -> Tensor:
        """``x : (n, d)`` in lengthscale units, refused if that or a squared distance between
        such points would overflow (the geodesic kernel's edges and weights square them)."""
        xs = self.kernel.scale(x)
        # |xs_i - zs_i| <= 2 max|xs|, so below this every sum of d squared differences is finite
        # (with a factor 2 to spare)
        limit = math.sqrt(torch.finfo(xs.dtype).max / xs.shape[1]) / 4
        largest = float(xs.abs().max()) if xs.numel() else 0.0
        if not largest <= limit:  # also NaN
            raise ValueError(
                f"inputs divided by the lengthscale {self.kernel.lengthscale.tolist()} reach "
                f"{largest:.3g} (|x| up to {float(x.abs().max()):.3g}), beyond {limit:.3g}, "
                f"where squared distances overflow {xs.dtype}; give the kernel a larger "
                "lengthscale or rescale the inputs"
            )
        return xs

    def _scale_floor(self, factor: float) -> None:
        # Python floats: called twice per novel point, where tensor ops cost more than the math.
        floor = float(self.novelty_floor)
        floor = max(floor, _FLOOR_BASE) * factor if factor > 1 else floor * factor
        self.novelty_floor.fill_(min(max(floor, self.novelty_tol), _FLOOR_MAX))

    def _novelty_threshold(self) -> float:
        """Relative novelty a point needs to become a BV.

        Below capacity: ``novelty_tol``. Once the basis is full, a newcomer must beat both the
        least novel current BV (``1 / Q_ii`` relative to its prior variance) and the adaptive
        ``novelty_floor``, which rises by ``_FLOOR_STEP`` whenever a newcomer arrives at capacity
        (a BV, possibly the newcomer, is deleted after it) and falls back towards ``novelty_tol`` by
        ``_FLOOR_STEP ** _DELETION_RATE`` per absorbed point, so that in the long run about one
        point in 300 at most causes a deletion.
        Without it, a stream of points denser than ``max_basis`` can cover at ``novelty_tol``
        turns every step into an insert-then-delete (churn), and each deletion is a lossy
        projection.
        """
        if self.n_basis < self.max_basis:
            return self.novelty_tol
        return max(float(self.novelty_floor), float(self._matrices().least_novelty))

    def _next_novel(self, xs: Tensor, start: int, screen: _Screen) -> int:
        """Index of the first novel row of ``xs`` (scaled inputs) at or after ``start``
        (``len(xs)`` if none).

        Novelty depends only on the basis set, not on ``alpha`` or ``P``, so rows can be
        screened ahead of absorbing them, and a screened block stays valid until the basis
        changes (``screen``; only the threshold moves in between). Rows are screened in chunks
        that start small (a new basis is often followed by more new BVs, and each addition
        re-screens) and double while nothing is found.
        """
        n, m = xs.shape[0], self.n_basis
        if m == 0:
            return start
        basis, threshold = self._matrices(), self._novelty_threshold()
        version = self._basis_version()
        known = screen.novelty(version, start)
        if known is not None:
            novel = (known > threshold).nonzero()
            if novel.numel():
                return start + int(novel[0])
            start += known.shape[0]
        chunk = _MIN_CHUNK
        while start < n:
            block = xs[start : start + chunk]
            gamma = self._relative_novelty(self.kernel.novelty_rows(block, basis.z).kqk(basis))
            screen.keep(version, start, gamma)
            novel = (gamma > threshold).nonzero()
            if novel.numel():
                return start + int(novel[0])
            start += block.shape[0]
            chunk = min(2 * chunk, _MAX_CHUNK)
        return n

    def _basis_version(self) -> tuple[int, int]:
        """Changes whenever a BV is added or deleted."""
        return int(self.n_added), int(self.n_deleted)

    def _relative_novelty(self, kqk: Tensor) -> Tensor:
        """``gamma / k(x, x) = 1 - k_x^T Q k_x / sigma_f^2`` from ``kqk : (n,)``."""
        return 1.0 - kqk / self.kernel.variance

    def _absorb(
        self, xs: Tensor, yn: Tensor, start: int, stop: int, scored: _BatchRows | None
    ) -> None:
        """Projected (sparse) update with the run ``start:stop`` of non-novel points (scaled
        inputs ``xs : (n, d)``, standardised targets ``yn : (n,)``), all at once; their rows
        are taken from ``scored`` while its basis is current.

        A sparse Csató–Opper update is the exact Bayesian update of the model
        ``y = e_x^T f_b + noise`` with ``e_x = Q k_x`` and noise variance
        ``N_x = sigma_n^2 + gamma_x``, so a run of them is one block (Kalman) update, identical
        to the sequential one. With rows ``K_x`` (n, m) and residuals ``r = y - K_x alpha``:

        * ``n < m`` (observation form): ``S = K_x P K_x^T + N``,
          ``alpha += P K_x^T S^{-1} r``, ``P -= P K_x^T S^{-1} K_x P``;
        * otherwise (information form): ``G = K_x^T N^{-1} K_x``,
          ``alpha += (I + P G)^{-1} P K_x^T N^{-1} r``, ``P <- (I + P G)^{-1} P``.
        """
        m = self.n_basis
        basis = self._matrices()
        basis.posterior_changed()
        known = None if scored is None else scored.run(start, stop, self._basis_version())
        if known is None:
            mixed = self.kernel.rows(xs[start:stop], basis.z)
            known = mixed, mixed.kqk(basis)
        mixed, kqk = known
        rows = mixed.dense(basis)
        noise = self.noise_var + (self.kernel.variance - kqk).clamp_min(0)
        resid = yn[start:stop] - rows @ self.alpha[:m]
        # In float64 whatever the state's dtype (a no-op for float64): with a float32 state,
        # a dense Laplacian basis (novelty_tol=0.1) and 2,048-point rollouts this update made
        # P indefinite within ten batches (smallest eigenvalue -1.6x the largest), and with
        # long fitted lengthscales the observation form's S failed to factorise.
        dtype = self.P.dtype
        P, rows, noise, resid = (t.double() for t in (self.P[:m, :m], rows, noise, resid))
        if stop - start < m:
            PK = P @ rows.T
            S = rows @ PK + torch.diag(noise)
            L, _ = jittered_cholesky(_sym(S), float(noise.mean()))
            gain = torch.cholesky_solve(PK.T, L)  # S^{-1} K_x P, shape (n, m)
            self.alpha[:m] += (gain.T @ resid).to(dtype)
            _store_sym(self.P[:m, :m], P - PK @ gain)
            return
        weighted = rows.T / noise
        system = torch.eye(m, dtype=P.dtype, device=P.device) + P @ (weighted @ rows)
        rhs = torch.cat([P, (P @ (weighted @ resid))[:, None]], dim=1)
        sol = torch.linalg.solve(system, rhs).to(dtype)
        self.alpha[:m] += sol[:, m]
        _store_sym(self.P[:m, :m], sol[:, :m])

    def _plan_insertion(self, x: Tensor, yn: Tensor) -> _Insertion | None:
        """The full update that would make ``x : (d,)`` the next BV, or ``None`` if its row
        fails :meth:`_reject_row` (then it is projected). Changes nothing.

        With ``k = k(x, BV)``, ``e = Q k``, ``gamma = k(x, x) - k^T e`` (floored by a nugget),
        ``s2 = gamma + k^T P k``, ``q = (y - k^T alpha) / (sigma_n^2 + s2)``,
        ``r = -1 / (sigma_n^2 + s2)`` and ``e~ = [e; -1]``, ``s = [P k; 0] - e~``:
        ``alpha <- [alpha; 0] + q s``, ``Q <- [Q 0; 0 0] + e~ e~^T / gamma``,
        ``P <- [P 0; 0 0] + e~ e~^T / gamma + r s s^T``.
        """
        m = self.n_basis
        xs = self.kernel.scale(x)
        variance = self.kernel.variance
        rows, attachments = self.kernel.insertion_rows(xs[None], self._matrices().z)
        k, attachment = rows[0], attachments[0]
        Q, P, alpha = self.Q[:m, :m], self.P[:m, :m], self.alpha[:m]
        e = Q @ k
        gamma = variance - k @ e
        if m > 0 and self._reject_row(float(gamma), float(e @ e), float(variance)):
            return None
        nugget = (_GAMMA_FLOOR * variance - gamma).clamp_min(0)
        gamma = gamma + nugget
        Pk = P @ k
        denom = self.noise_var + gamma + k @ Pk
        q = (yn - k @ alpha) / denom
        e_ext = torch.cat([e, e.new_full((1,), -1.0)])
        s = torch.cat([Pk, Pk.new_zeros(1)]) - e_ext
        alpha_new = torch.cat([alpha, alpha.new_zeros(1)]) + q * s
        return _Insertion(m, xs, k, attachment, nugget, gamma, denom, e_ext, s, alpha_new)

    def _insert(self, plan: _Insertion, x: Tensor, y: Tensor) -> None:
        """Carry out a planned insertion: ``x`` becomes a BV (and a graph node)."""
        m = plan.m
        self.alpha[: m + 1] = plan.alpha_new
        # In-place rank-one updates (BLAS ger): no (m, m) temporaries.
        inv_gamma, inv_denom = float(1.0 / plan.gamma), float(1.0 / plan.denom)
        e_ext, s = plan.e_ext, plan.s
        self.Q[: m + 1, : m + 1].addr_(e_ext, e_ext, alpha=inv_gamma)
        self.P[: m + 1, : m + 1].addr_(e_ext, e_ext, alpha=inv_gamma).addr_(s, s, alpha=-inv_denom)
        self.bv_x[m] = x
        self.bv_y[m] = y
        self.nugget[m] = plan.nugget
        assert self._rollback is not None
        self._rollback.before_basis_change()
        self.kernel.on_insert(plan.xs, plan.attachment)
        self._matrices().basis_grew(plan.k, self.kernel.variance)
        self.count += 1
        self.n_added += 1

    def _reject_row(self, gamma: float, e_sq: float, variance: float) -> bool:
        """Whether a novel point's actual BV row would harm ``Q``; it is projected instead.

        Two checks. (1) Novelty was judged on the row as a leaf of the nearest BV, the actual row
        hangs on the trajectory predecessor. For positive-definite kernels its ``gamma`` is at
        least the judged one; for the Gaussian geodesic profile (not positive definite) it can be
        anything down to negative, so it must clear the threshold again. (2) Every Cholesky pivot
        can be large while the Gram matrix is numerically singular (measured with the Gaussian
        geodesic profile: pivots >= 0.02, smallest eigenvalue 3e-11, ``||Q||`` 8e9, after which
        ``P`` lost definiteness; and with the RBF kernel at ``novelty_tol=1e-3``). A new BV grows
        ``||Q||`` by ``(1 + ||e||^2) / gamma``; capping that at ``1e4 / variance`` bounds
        ``||Q|| <= 1e4 (m_max + 1) / variance`` and keeps ``P = Q + C`` accurate.
        """
        if gamma <= self._novelty_threshold() * variance:
            return True
        return self.condition_guard and (1.0 + e_sq) / gamma > _Q_GROWTH / variance

    def _delete_least_informative(self) -> None:
        """Delete the BV with the smallest Csató–Opper score (:func:`_least_informative`)."""
        m = self.n_basis
        self._delete(_least_informative(self.alpha[:m], torch.diagonal(self.P[:m, :m])))

    def _delete(self, j: int) -> None:
        """Remove BV ``j`` by the Csató–Opper KL projection.

        With ``T = [I, -Q_{r j} / Q_jj]`` (rows ``r`` = the other BVs):
        ``alpha <- T alpha``, ``P <- T P T^T``, ``Q <- Q_rr - Q_rj Q_rj^T / Q_jj``. The summary
        of the points that left the window transforms as ``alpha`` and ``P``: for a quadratic
        form in the function values ``f``, ``T^T`` substitutes for ``f_j`` its conditional mean
        given the others, ``K_jr K_rr^{-1} f_r = -Q_jr f_r / Q_jj``.
        """
        m = self.n_basis
        keep = torch.cat([torch.arange(j), torch.arange(j + 1, m)]).to(self.alpha.device)
        Q = self.Q[:m, :m]
        q_star = Q[keep, j] / Q[j, j]
        new_Q = Q[keep][:, keep] - torch.outer(q_star, Q[keep, j])
        for vec, mat in ((self.alpha, self.P), (self.summary_shift, self.summary_prec)):
            vec[: m - 1], mat_new = _substitute(vec[:m], mat[:m, :m], j, keep, q_star)
            vec[m - 1] = 0.0
            self._set_square(mat, _sym(mat_new))
        for unit in (self.summary_unit, self.summary_input):
            unit[: m - 1] = unit[keep] - unit[j] * q_star.reshape(-1, *[1] * (unit.ndim - 1))
            unit[m - 1] = 0.0
        for buf in (self.bv_x, self.bv_y, self.nugget):
            buf[: m - 1] = buf[keep].clone()
            buf[m - 1] = 0
        self._set_square(self.Q, _sym(new_Q))
        assert self._rollback is not None
        self._rollback.before_basis_change()
        self._matrices().basis_shrank(keep)
        self.count -= 1
        self.n_deleted += 1
        self.kernel.on_delete(j)

    @staticmethod
    def _set_square(buf: Tensor, value: Tensor) -> None:
        n = value.shape[0]
        buf.zero_()
        buf[:n, :n] = value

    def _refresh_Q(self) -> None:
        """Recompute ``Q = (K_b + diag(nugget))^{-1}`` exactly, so rank-one drift cannot build up.

        If rounding has made the Gram matrix numerically indefinite, the nuggets grow by a
        jitter (10x per try, from 1e-6 of the signal variance) until its Cholesky exists.
        """
        m, basis = self.n_basis, self._matrices()
        L, jitter = jittered_cholesky(basis.K_nugget, float(self.kernel.variance))
        self.nugget[:m] += jitter
        _store_sym(self.Q[:m, :m], torch.cholesky_inverse(L))
        basis.Q_changed()

    def _check_finite(self) -> None:
        m = self.n_basis
        blocks = {"alpha": self.alpha[:m], "P": self.P[:m, :m], "Q": self.Q[:m, :m]}
        # One reduction first: a NaN or inf anywhere makes its block's sum non-finite (a sum
        # can also overflow, so a non-finite sum is only a suspicion, checked block by block).
        if math.isfinite(float(sum(b.sum() for b in blocks.values()))):
            return
        bad = [name for name, b in blocks.items() if not bool(torch.isfinite(b).all())]
        if not bad:
            return
        raise FloatingPointError(
            f"SparseOnlineGP.{', '.join(bad)} became non-finite; state restored"
        )

    # ------------------------------------------------------------------------------------------
    # Hyperparameters
    # ------------------------------------------------------------------------------------------
    @_engine_threads
    def fit_hyperparameters(self, n_iter: int = 100, lr: float = 0.05) -> dict[str, float]:
        """Fit lengthscale(s), signal and noise variance to the retained data.

        Minimises the negative collapsed bound (Titsias 2009) of the points in :attr:`window`,
        with the BVs as inducing points and each point weighted by the forgetting per batch
        (:mod:`sb3_geogp.adaptation`), by Adam on log-parameters within
        :class:`~sb3_geogp.adaptation.Adaptation`'s bounds, plus its hyperprior if it has one
        (this GP's settings, else the defaults). The
        kernel says which lengthscale factors are free
        (:meth:`~sb3_geogp.kernels.Kernel.correlation_fn`): one per input dimension for the
        Euclidean kernels, one on all lengthscales for the geodesic kernel (every graph
        distance scales by its inverse, so the tree stays exact). The posterior is then the
        exact sparse posterior of the retained data under the new hyperparameters, times the
        summary of the points it no longer retains (with ``Adaptation(summary="snapshot")``,
        of the retained points from ``summary_batch`` on, times the summary of the others).

        Parameters
        ----------
        n_iter : int
            Optimiser steps (0: the posterior is only rebuilt under the current values).
        lr : float
            Adam step size on the log-parameters.

        Returns
        -------
        dict
            The fitted ``lengthscale`` (first dimension), ``variance``, ``noise_var`` and the
            negative bound per point ``nlml`` of the retained data after the fit and rebuild
            (the negative log marginal likelihood per point when every retained point is a BV).

        Raises
        ------
        ValueError
            Before the first :meth:`update`, or if ``n_iter`` is not a non-negative integer
            or ``lr`` not a positive finite number; the state is then unchanged.
        RuntimeError
            If a geodesic kernel's lengthscales were changed in place rather than through
            :meth:`~sb3_geogp.kernels.Kernel.rescale` (its tree would not follow them); the
            state is then unchanged.
        """
        non_negative_int("n_iter", n_iter)
        check_number("lr", lr)
        if not 0 < lr < math.inf:
            raise ValueError(f"lr must be a positive finite Adam step size, got {lr}")
        x, y, batch, decay = self.window.data()
        if x.shape[0] == 0 or self.n_basis == 0:
            raise ValueError("fit_hyperparameters needs retained data; call update first")
        if not self.kernel.follows_lengthscale(self.bv_x[: self.n_basis]):
            raise RuntimeError(
                f"{type(self.kernel).__name__}'s basis-vector tree is no longer in its "
                "lengthscales' units: they were changed in place, which the tree does not "
                "follow. Put the old values back, then change them with "
                "kernel.rescale(factor), which moves the tree with them"
            )
        forgetting = float(self.block_forgetting) if self.adaptation else self.forgetting
        w = self._age_weights(batch, decay, forgetting).to(y)
        yn = self._standardised(x, y)
        with self._transaction(), torch.no_grad():
            self._fit(x, yn, w, n_iter, lr, self.adaptation or Adaptation())
            Kzz, Kxz = self._rebuild(x, yn, w, batch)
            if Kxz.shape[0] < x.shape[0]:  # the rebuild used only the points after a snapshot
                Kzz, Kxz = self._basis_covariances(x)
            variance = self.kernel.variance
            projection = Projection(Kzz, Kxz, float(variance))
            final = projection.negative_bound(yn, self.noise_var / w, variance.expand(len(yn)))
        self._settle()
        return {
            "lengthscale": float(self.kernel.lengthscale[0]),
            "variance": float(self.kernel.variance),
            "noise_var": float(self.noise_var),
            "nlml": float(final),
        }

    # ------------------------------------------------------------------------------------------
    # Adaptation (sb3_geogp.adaptation)
    # ------------------------------------------------------------------------------------------
    def _retain(self, x: Tensor, y: Tensor) -> None:
        """Keep the batch in the window; close the block (and adapt) when it is due. The
        points leaving the window go to the summary, except, with
        ``Adaptation(whole_batch=True)``, those of this batch when its block refits: the
        rebuild then takes them as it takes the window's (:meth:`_adapt`)."""
        newest = int(self.n_batches) - 1
        dropped = self.window.append(x, y, newest)
        self.block_new += x.shape[0]
        a = self.adaptation
        closes = a is None or int(self.block_new) >= a.block
        if closes:
            self.n_blocks += 1
            self.block_new.zero_()
        if a is None or self.n_basis == 0:
            return
        if not closes:
            self._summarise(*dropped)
            return
        drift, explained = self._block_fit()
        refit = a.refit_due(int(self.n_blocks), drift, explained, self._since_refit(0))
        kept = int((dropped[2] == newest).sum()) if refit and a.whole_batch else 0
        # dropped is oldest first: this batch's points that found no room are its tail
        cut = dropped[0].shape[0] - kept
        self._summarise(*(t[:cut] for t in dropped))
        self._adapt(a, drift, explained, refit, tuple(t[cut:] for t in dropped))

    def _summarise(self, x: Tensor, y: Tensor, batch: Tensor, decay: Tensor) -> None:
        """Add what the points leaving the window say to the summary, with their weights;
        those of batches the summary already holds (:meth:`_snapshot`) are skipped.

        The summary is kept per unit noise variance (noise ``1 / w``) and divided by the noise
        variance of the moment when used (:meth:`_summary`), so that a summarised point counts
        exactly as it would in the window, also after the noise has been re-fitted.
        """
        assert self.adaptation is not None
        first = self._first_unsummarised(batch)
        x, y, batch, decay = x[first:], y[first:], batch[first:], decay[first:]
        if x.shape[0] == 0:
            return
        m = self.n_basis
        (x, y, batch, decay), count, _ = _thin(self.adaptation.fold_points, x, y, batch, decay)
        Kzz, Kxz = self._basis_covariances(x)
        w = self._age_weights(batch, decay, float(self.block_forgetting)).to(y) * count.to(y)
        yn = self._standardised(x, y)
        variance = float(self.kernel.variance)
        part = Summary.of_data(Kzz, Kxz, x, yn, 1 / w, variance, inverse=self.Q[:m, :m])
        self.summary_prec[:m, :m] += part.precision
        self.summary_shift[:m] += part.shift
        self.summary_unit[:m] += part.unit_shift
        self.summary_input[:m] += part.input_shift

    def _snapshot_due(self, a: Adaptation, n: int) -> bool:
        """Whether a batch of ``n`` points, scored but not yet absorbed, opens a block that
        needs a snapshot of the posterior first (``Adaptation(summary="snapshot")``).

        A block of several batches always does: whether it refits is known only at its end.
        A block of this batch alone (a PPO rollout) only if it refits, which its scores
        already tell. The summary serves only a refit's rebuild, so the posterior is the same
        as with a snapshot at the start of every block, at the price of the refits alone.
        """
        if a.summary != "snapshot" or int(self.block_new) > 0:
            return False
        closing = (int(self.n_blocks) + 1, *self._block_fit(), self._since_refit(n))
        return n < a.block or a.refit_due(*closing)

    def _since_refit(self, pending: int) -> int:
        """Points that arrived since the last refit, ``pending`` points not yet counted
        included (``Adaptation.fit_spacing``)."""
        return int(self.n_seen) + pending - int(self.refit_seen)

    def _snapshot(self) -> None:
        """Make the summary the likelihood the posterior implies
        (:meth:`~sb3_geogp.adaptation.Summary.of_posterior`, per unit noise variance as the
        summary is kept): it then holds every batch before this one, and the next rebuild
        adds only the window's points from this batch on."""
        m = self.n_basis
        # In float64 whatever the state's dtype, as the absorb: Q P^-1 Q - Q cancels.
        alpha, Q, z = (t.double() for t in (self.alpha[:m], self.Q[:m, :m], self.bv_x[:m]))
        implied = Summary.of_posterior(alpha, self._matrices().P_cholesky, Q, z)
        noise = self.noise_var
        self.summary_prec[:m, :m] = implied.precision * noise
        self.summary_shift[:m] = implied.shift * noise
        self.summary_unit[:m] = implied.unit_shift * noise
        self.summary_input[:m] = implied.input_shift * noise
        self.summary_batch.fill_(int(self.n_batches))

    def _first_unsummarised(self, batch: Tensor) -> int:
        """Index of the first point the summary does not hold, among points oldest first
        that arrived in batches ``batch : (n,)``: 0 unless a :meth:`_snapshot` made it."""
        return int((batch < self.summary_batch).sum())

    def _summary(self) -> Summary:
        m, noise = self.n_basis, self.noise_var
        return Summary(
            self.summary_prec[:m, :m] / noise,
            self.summary_shift[:m] / noise,
            self.summary_unit[:m] / noise,
            self.summary_input[:m] / noise,
        )

    def _ages(self, batch: Tensor) -> Tensor:
        """Age in batches of points that arrived in ``batch : (n,)`` (0: the newest batch)."""
        return self.n_batches - 1 - batch

    def _batch_forgetting(self, lam: float, n: int) -> float:
        """The factor by which forgetting ``lam`` weighs what came before a batch of ``n``
        points: ``lam``, or ``lam ** (n / forgetting_points)``."""
        return lam if self.forgetting_points is None else lam ** (n / self.forgetting_points)

    def _age_weights(self, batch: Tensor, decay: Tensor, lam: float) -> Tensor:
        """Weights of points that arrived in ``batch : (n,)`` under forgetting ``lam``, each
        batch counted as the newest batch's size (:meth:`_batch_forgetting`), that lost
        ``decay : (n,)`` to drift since (:meth:`RetainedWindow.age`)."""
        lam = self._batch_forgetting(lam, int(self.last_batch_points))
        return age_weights(self._ages(batch), lam, decay)

    def _adapt(
        self,
        a: Adaptation,
        drift: float,
        explained: float,
        refit: bool,
        unretained: tuple[Tensor, ...],
    ) -> None:
        """Close the block whose targets drifted by ``drift`` and were predicted with
        ``explained`` (:meth:`_block_fit`): choose the forgetting and, if ``refit``, refit on
        the window's points preceded by ``unretained`` (inputs, targets, batches, decays: the newest
        batch's points the window had no room for, oldest first; none but with
        ``whole_batch``)."""
        scores = self.forgetting_scores
        # All zero: no batch of this block was scored (the basis was still empty).
        scored = bool((scores != 0).any())
        lam = a.forgetting[int(scores.argmin())] if scored else float(self.block_forgetting)
        scores.zero_()
        self.block_moments.zero_()
        self.block_errors.zero_()
        self.block_forgetting.fill_(lam)
        self.last_stats.update(forgetting=lam, target_drift=drift, block_fit=explained)
        if refit:
            x, y, batch, decay = (
                torch.cat(parts) for parts in zip(unretained, self.window.data(), strict=True)
            )
            self._refit(a, x, y, self._age_weights(batch, decay, lam).to(y), batch)
            self.refit_seen.copy_(self.n_seen)

    def _block_fit(self) -> tuple[float, float]:
        """The open block's drift (mean square of its scored standardised targets; 1 if none
        was scored) and the explained variance of its out-of-sample predictions (NaN if its
        targets do not vary)."""
        points, squares = self.block_moments.tolist()
        total, errors, error_squares = self.block_errors.tolist()
        if points <= 0:
            return 1.0, math.nan
        spread = squares / points - (total / points) ** 2
        miss = error_squares / points - (errors / points) ** 2
        explained = 1.0 - miss / spread if spread > 1e-12 * squares / points else math.nan
        return squares / points, explained

    def _refit(self, a: Adaptation, x: Tensor, y: Tensor, w: Tensor, batch: Tensor) -> None:
        """Steps 2-4 of the adaptation on the window ``x, y`` with weights ``w`` (points of
        batches ``batch``)."""
        if a.targets:
            self._restandardise(x, y, w)
        yn = self._standardised(x, y)
        if a.follow_spread:
            self._follow_spread(x, widen=a.follow_spread == "widen")
        if a.steps:
            k = a.fit_points
            self._fit(x[-k:], yn[-k:], w[-k:], a.steps, a.lr, a)
        self._rebuild(x, yn, w, batch)
        ls = self.kernel.lengthscale
        self.last_stats.update(
            lengthscale=float(ls.log().mean().exp()),
            **{f"lengthscale_{i}": float(v) for i, v in enumerate(ls)},
            signal_var=float(self.kernel.variance),
            noise_var=float(self.noise_var),
            target_mean=float(self.y_mean),
            target_scale=float(self.y_scale),
        )

    def _follow_spread(self, x: Tensor, widen: bool) -> None:
        """Start the lengthscales the first batch chose again from the spread of the window's
        inputs ``x : (n, d)`` (``Adaptation.follow_spread``; with ``widen`` only where that
        is wider), each keeping its factor to its start. The posterior does not follow:
        the refit rebuilds it."""
        chosen = self.ls_from_data
        if not bool(chosen.any()):
            return
        spread = defaults.default_lengthscale(x, self.lengthscale_rule)
        ratio = torch.where(chosen, spread / self.ls_start, 1.0)
        # A kernel with one factor for all inputs (GeodesicKernel(ard=False)) takes their
        # geometric mean, which keeps its paths exact.
        per_dimension = getattr(self.kernel, "ard", True)
        factor = ratio if per_dimension else ratio[chosen].log().mean().exp().reshape(1)
        if widen:
            factor = factor.clamp(min=1.0)
        assert self._rollback is not None
        self._rollback.before_basis_change()
        self.kernel.rescale(factor)
        self.ls_start.mul_(factor)
        self._cache = None

    def _basis_covariances(self, x: Tensor) -> tuple[Tensor, Tensor]:
        """``K_zz`` (with the nuggets), shape (m, m), and ``K_xz`` of ``x : (n, d)``, (n, m)."""
        basis = self._matrices()
        return basis.K_nugget, self.kernel.rows(self.kernel.scale(x), basis.z).dense(basis)

    def _out_of_sample(
        self, x: Tensor, xs: Tensor, y: Tensor
    ) -> tuple[dict[str, float], _BatchRows | None]:
        """NLPD and explained variance of a batch (inputs ``x``, scaled ``xs``) under the
        posterior before it is absorbed; scores the forgetting candidates on it
        (:meth:`_score_forgetting`, or :meth:`_lagged_scores`) and adds it to the open block's
        sums. All use at most ``Adaptation.score_points`` points of the batch (:func:`_thin`);
        where that is all of them, their rows are returned for the rest of the update."""
        assert self.adaptation is not None
        n = x.shape[0]
        (x, xs, y), count, whole = _thin(self.adaptation.score_points, x, xs, y)
        count = count.to(y)
        basis = self._matrices()
        rows = self.kernel.rows(xs, basis.z)
        kqk = rows.kqk(basis)
        mean = rows.mean(basis)
        gamma, var = self._latent_variance(rows, basis, kqk)
        yn = self._standardised(x, y)
        if self.adaptation.forgetting_score == "lagged":
            batch = (rows.dense(basis), gamma, yn, count)
            self.forgetting_scores += self._lagged_scores(*(t.double() for t in batch)).to(y)
        else:
            self._score_forgetting(mean, var, yn, count, n)
        self._count_block(mean, yn, count)
        stats = {}
        if self.optimism_cap is not None and y.shape[0] > 1:
            errors = y - mean * self.y_scale - self._prior(x)
            self._average_spreads(var.sqrt() * self.y_scale, errors)
            stats["bonus_scale"] = self.bonus_scale()
        mean = mean * self.y_scale + self._prior(x)
        var = (var + self.noise_var) * self.y_scale**2
        spread = float(y.var()) if y.shape[0] > 1 else 0.0
        explained = 1.0 - float((y - mean).var()) / spread if spread > 0 else math.nan
        stats = {"nlpd": nlpd(mean, var, y), "explained_variance": explained, **stats}
        return stats, _BatchRows(self._basis_version(), rows, kqk) if whole else None

    def _average_spreads(self, sigma: Tensor, error: Tensor) -> None:
        """Average into :attr:`bonus_spreads` the standard deviations of a batch's latent
        ``sigma : (n,)`` and out-of-sample ``error : (n,)``, in the targets' units: single
        A2C batches of a few dozen points are too noisy to scale the bonus by alone."""
        spreads = torch.stack([sigma.std(), error.std()]).to(self.bonus_spreads)
        if float(self.bonus_spreads[0]) > 0:
            spreads = (1 - _SPREAD_WEIGHT) * self.bonus_spreads + _SPREAD_WEIGHT * spreads
        self.bonus_spreads.copy_(spreads)

    def _score_forgetting(
        self, mean: Tensor, var: Tensor, yn: Tensor, count: Tensor, points: int
    ) -> None:
        """Add to each candidate's score the negative log density of the batch ``yn : (n,)``
        (thinned from ``points`` points) under the posterior forgotten by that candidate
        first (:meth:`_batch_forgetting`), point ``i`` counted ``count[i]`` times.

        Forgetting by ``lambda`` (:meth:`_forget`) maps the latent mean ``mu`` and variance
        ``v`` of a point to ``sqrt(lambda) mu`` and ``(1 - lambda) sigma_f^2 + lambda v``, so
        the candidates cost nothing beyond the prediction the statistics make anyway.
        """
        assert self.adaptation is not None
        candidates = [self._batch_forgetting(c, points) for c in self.adaptation.forgetting]
        lam = torch.tensor(candidates, dtype=mean.dtype, device=mean.device)[:, None]
        means = lam.sqrt() * mean
        variances = (1 - lam) * self.kernel.variance + lam * var + self.noise_var
        self.forgetting_scores += gaussian_nll(yn, means, variances) @ count

    def _lagged_scores(self, rows: Tensor, gamma: Tensor, yn: Tensor, count: Tensor) -> Tensor:
        """Scores of the forgetting candidates on a batch with kernel rows ``rows : (n, m)``,
        basis residuals ``gamma : (n,)``, standardised targets ``yn : (n,)`` and point weights
        ``count : (n,)`` (:func:`~sb3_geogp.adaptation.lagged_forgetting_scores`), all float64.

        The previous batch's likelihood is estimated from its points in the window (at most
        ``score_points`` of them, :func:`~sb3_geogp.adaptation.thinned`), scaled up to the
        batch's size where the window keeps only its tail (PPO's rollouts)."""
        assert self.adaptation is not None
        a, m = self.adaptation, self.n_basis
        # each candidate as it would have weighed the data before the previous batch
        previous_points = int(self.last_batch_points)
        factors = [self._batch_forgetting(c, previous_points) for c in a.forgetting]
        candidates = torch.tensor(factors, dtype=torch.float64, device=yn.device)
        wx, wy, batch, _ = self.window.data()
        last = batch == int(self.n_batches) - 1
        kept = int(last.sum())
        if kept == 0:  # nothing of the previous batch retained: every candidate scores alike
            return torch.zeros_like(candidates)
        (px, py), runs, _ = _thin(a.score_points, wx[last], wy[last])
        px, py = px.to(self.y_mean), py.to(self.y_mean)
        weight = runs.to(torch.float64) * max(1.0, int(self.last_batch_points) / kept)
        noise = float(self.noise_var)
        basis = self._matrices()
        # The previous batch's rows alone: the geodesic kernel attaches a point given its
        # neighbours, as it did for the new batch's.
        rows_b = self.kernel.rows(self.kernel.scale(px), basis.z)
        gamma_b = self._latent_variance(rows_b, basis)[0].double()
        previous = (rows_b.dense(basis).double(), self._standardised(px, py).double())
        L, S = basis.P_factor
        alpha = self.alpha[:m].double()
        return lagged_forgetting_scores(
            L,
            S,
            alpha,
            (*previous, (noise + gamma_b) / weight),
            (rows, gamma, yn, count),
            noise,
            candidates,
        )

    def _count_block(self, mean: Tensor, yn: Tensor, count: Tensor) -> None:
        """Add a scored batch's targets and out-of-sample errors to the open block's sums."""
        self.block_moments += torch.stack([count.sum(), yn.square() @ count])
        error = yn - mean
        self.block_errors += torch.stack([yn @ count, error @ count, error.square() @ count])

    def _restandardise(self, x: Tensor, y: Tensor, w: Tensor) -> None:
        """The prior mean and scale of the retained targets ``y : (n,)`` at ``x : (n, d)``
        with weights ``w``, where the user fixed neither: their weighted mean and standard
        deviation, or (``prior_mean="linear"``) their weighted least-squares line and the
        standard deviation of its residuals.

        The summary follows the new units as its points would in the window: with
        ``y_old = a y_new + b + c^T x``, ``a`` the ratio of the new scale to the old and
        ``b + c^T x`` the prior mean's change in old units, its shift becomes
        ``(eta - b u - U c) / a`` (``u``, ``U``: its unit and input shifts); its precision and
        those shifts (per unit noise variance, :meth:`_summarise`) do not change.
        """
        old_mean, old_scale = self.y_mean.clone(), self.y_scale.clone()
        old_slope = self.y_slope.clone()
        if self.prior_mean == "linear":
            mean, slope, scale = linear_moments(x, y, w)
            self.y_slope.copy_(slope)
        else:
            mean, scale = weighted_moments(y, w)
        fixed_mean, fixed_scale = self._fixed_target
        if fixed_mean is None:
            self.y_mean.fill_(mean)
        # Relative: the engine is otherwise the same at any scale of the targets.
        if fixed_scale is None and scale > max(1e-8 * abs(mean), torch.finfo(y.dtype).tiny):
            self.y_scale.fill_(scale)
        a, b = self.y_scale / old_scale, (self.y_mean - old_mean) / old_scale
        c = (self.y_slope - old_slope) / old_scale
        m = self.n_basis
        shift = self.summary_shift[:m] - b * self.summary_unit[:m] - self.summary_input[:m] @ c
        self.summary_shift[:m] = shift / a

    def _fit(
        self, x: Tensor, yn: Tensor, w: Tensor, steps: int, lr: float, bounds: Adaptation
    ) -> None:
        """Adam on the negative collapsed bound of ``(x, yn)`` with weights ``w``, plus the
        hyperprior of ``bounds.prior_sd`` if any. Changes the kernel's hyperparameters and the
        noise only."""
        kernel, m = self.kernel, self.n_basis
        n_factors, correlations = kernel.correlation_fn(x, self.bv_x[:m])
        nugget = torch.diag(self.nugget[:m])
        log_var = kernel.variance.log().clone().requires_grad_(True)
        log_noise = self.noise_var.log().clone().requires_grad_(True)
        log_f = torch.zeros(n_factors, dtype=yn.dtype, device=yn.device, requires_grad=True)
        ratio = (self.ls_start / kernel.lengthscale)[:n_factors].log()
        limits = [
            (log_f, *(ratio + math.log(b) for b in bounds.lengthscale_range)),
            (log_var, *(torch.tensor(b).log().to(yn) for b in bounds.variance_bounds)),
            (log_noise, *(torch.tensor(b).log().to(yn) for b in bounds.noise_bounds)),
        ]

        def loss() -> Tensor:
            R_xz, R_zz = correlations(log_f)
            var = log_var.exp()
            projection = Projection(var * R_zz + nugget, var * R_xz, float(var.detach()))
            value = projection.negative_bound(yn, log_noise.exp() / w, var.expand(yn.shape[0]))
            if bounds.prior_sd is None:
                return value
            # log(lengthscale / start) = log_f - ratio; per point, as the bound is.
            logs = torch.cat([log_f - ratio, log_var[None]])
            return value + logs.square().sum() / (2 * bounds.prior_sd**2 * yn.shape[0])

        opt = torch.optim.Adam([log_f, log_var, log_noise], lr=lr)
        with torch.enable_grad():
            for _ in range(steps):
                opt.zero_grad()
                loss().backward()
                opt.step()
                with torch.no_grad():
                    for param, lo, hi in limits:
                        param.copy_(torch.clamp(param, lo, hi))
        assert self._rollback is not None
        self._rollback.before_basis_change()
        kernel.rescale(log_f.detach().exp())
        kernel.variance.copy_(log_var.detach().exp())
        self.noise_var.copy_(log_noise.detach().exp())
        self._cache = None

    def _rebuild(self, x: Tensor, yn: Tensor, w: Tensor, batch: Tensor) -> tuple[Tensor, Tensor]:
        """The exact sparse posterior of the points of ``(x, yn)`` that the summary does not
        hold (of batches ``batch``), with noise ``sigma_n^2 / w``, times the summary,
        replaces the current one (:func:`~sb3_geogp.adaptation.sparse_posterior`), after
        pruning. Returns the covariances it used: ``K_zz`` and the rows of those points."""
        self._refresh_Q()
        self._prune_redundant()
        m = self.n_basis
        first = self._first_unsummarised(batch)
        Kzz, Kxz = self._basis_covariances(x[first:])
        variance, noise = float(self.kernel.variance), self.noise_var / w[first:]
        alpha, P = sparse_posterior(Kzz, Kxz, yn[first:], noise, variance, self._summary())
        self.alpha[:m] = alpha
        self.P[:m, :m] = P
        self._matrices().posterior_changed()
        return Kzz, Kxz

    def _prune_redundant(self) -> None:
        """Delete, least novel first, the BVs that new hyperparameters made near-duplicates.

        A longer lengthscale makes neighbouring BVs nearly collinear; their Gram matrix is then
        numerically singular and the posterior's weights grow until predictions off the data
        are meaningless (measured: critic RMSE 1e5 on CartPole, then a failed Cholesky). A
        BV's residual variance given the others is ``1 / Q_jj``; each must keep the share of
        the signal variance that the insertion guard requires of a newcomer's whole row
        (:meth:`_reject_row`), ``Q_jj <= 1e4 / variance``. The posterior is rebuilt afterwards.
        """
        limit = _Q_GROWTH / float(self.kernel.variance)
        while self.n_basis > 1:
            q = torch.diagonal(self.Q[: self.n_basis, : self.n_basis])
            j = int(q.argmax())
            if float(q[j]) <= limit:
                return
            self._delete(j)
            self.n_pruned += 1

    # ------------------------------------------------------------------------------------------
    # Validation
    # ------------------------------------------------------------------------------------------
    def _as_tensor(self, value: ArrayLike, name: str) -> Tensor:
        t = _to_tensor(value, name)
        if t.is_complex() or not (t.is_floating_point() or t.dtype in _INT_TYPES):
            raise ValueError(
                f"{name} has dtype {t.dtype}, which cannot be cast to {self.alpha.dtype}; "
                "pass real numbers"
            )
        converted = t.to(device=self.alpha.device, dtype=self.alpha.dtype)
        if bool(torch.isfinite(converted).all()):
            return converted
        # Only a failed check looks at the input: NaN or inf given, or finite values the
        # GP's dtype cannot hold.
        if not bool(torch.isfinite(t).all()):
            raise ValueError(f"{name} contains NaN or inf; remove or impute those entries first")
        raise ValueError(
            f"{name} holds values up to {float(t.abs().max()):.3g}, beyond the range of "
            f"this GP's {self.alpha.dtype}; scale them down, or build the GP with "
            "dtype=torch.float64"
        )

    def _as_inputs(self, x: ArrayLike, name: str) -> Tensor:
        t = self._as_tensor(x, name)
        if t.ndim != 2 or t.shape[1] != self.input_dim:
            raise ValueError(
                f"{name} must have shape (n, {self.input_dim}), got {tuple(t.shape)}; "
                "flatten observations to one row per point"
            )
        return t

    def _validate(
        self, x: ArrayLike, y: ArrayLike, episode_starts: ArrayLike | None
    ) -> tuple[Tensor, Tensor, Tensor]:
        xt = self._as_inputs(x, "x")
        yt = self._as_tensor(y, "y")
        n = xt.shape[0]
        if yt.ndim == 2 and yt.shape[1] == 1:
            yt = yt[:, 0]
        if yt.shape != (n,):
            raise ValueError(f"y must have shape ({n},) to match x, got {tuple(yt.shape)}")
        if n == 0:
            raise ValueError("update needs at least one point")
        if episode_starts is None:
            starts = torch.ones(n, dtype=torch.bool, device=xt.device)
        else:
            s = _to_tensor(episode_starts, "episode_starts")
            if s.shape != (n,):
                raise ValueError(f"episode_starts must have shape ({n},), got {tuple(s.shape)}")
            if s.is_complex() or not bool(((s == 0) | (s == 1)).all()):
                raise ValueError("episode_starts must be boolean (0/1)")
            starts = s.to(device=xt.device, dtype=torch.bool)
        return xt, yt, starts


def _to_tensor(value: ArrayLike, name: str) -> Tensor:
    """``value`` as a tensor (any layout), or a ValueError naming ``name``."""
    try:
        if isinstance(value, Tensor):
            return value
        return torch.as_tensor(np.ascontiguousarray(value))
    except (TypeError, ValueError, RuntimeError) as err:
        raise ValueError(f"{name} must be a real numeric array or tensor: {err}") from err


_INT_TYPES = (torch.int8, torch.int16, torch.int32, torch.int64, torch.uint8, torch.bool)


def _least_informative(alpha: Tensor, p_diag: Tensor) -> int:
    """Index of the BV with the smallest Csató–Opper score
    ``alpha_i^2 / (Q_ii + C_ii) = alpha_i^2 / P_ii`` (``alpha``, ``p_diag`` of shape (m,))."""
    return int((alpha**2 / p_diag.clamp_min(torch.finfo(p_diag.dtype).tiny)).argmin())


def _substitute(
    vec: Tensor, mat: Tensor, j: int, keep: Tensor, q_star: Tensor
) -> tuple[Tensor, Tensor]:
    """``T vec`` and ``T mat T^T`` for ``T = [I, -q_star]`` (column ``j`` removed): a deletion's
    projection of ``vec : (m,)`` and ``mat : (m, m)`` onto the other ``m - 1`` slots."""
    col = mat[keep, j]
    projected = (
        mat[keep][:, keep]
        - torch.outer(q_star, col)
        - torch.outer(col, q_star)
        + mat[j, j] * torch.outer(q_star, q_star)
    )
    return vec[keep] - vec[j] * q_star, projected


def _thin(cap: int | None, *batch: Tensor) -> tuple[tuple[Tensor, ...], Tensor, bool]:
    """The points of ``batch`` (tensors of ``n`` rows) that :func:`~sb3_geogp.adaptation.
    thinned` keeps under ``cap``, the length of the run each stands for, and whether that is
    every point (then ``batch`` itself, not a copy)."""
    n, device = batch[0].shape[0], batch[0].device
    if cap is None or n <= cap:
        return batch, torch.ones(n, dtype=torch.long, device=device), True
    index, runs = thinned(n, cap, device)
    return tuple(t[index] for t in batch), runs, False


def _sym(M: Tensor) -> Tensor:
    return 0.5 * (M + M.T)


def _store_sym(dest: Tensor, M: Tensor) -> None:
    """``dest <- (M + M^T) / 2`` in ``dest``'s dtype; where the dtypes agree without (m, m)
    temporaries (the same rounding: the sum, then its half)."""
    if dest.dtype != M.dtype:
        dest.copy_(_sym(M))
        return
    torch.add(M, M.T, out=dest)
    dest.mul_(0.5)


class _Insertion(NamedTuple):
    """A planned full update (see :meth:`SparseOnlineGP._plan_insertion`)."""

    m: int
    xs: Tensor
    k: Tensor
    attachment: Any
    nugget: Tensor
    gamma: Tensor
    denom: Tensor
    e_ext: Tensor
    s: Tensor
    alpha_new: Tensor


class _BatchRows(NamedTuple):
    """A batch's kernel rows over the basis of ``version`` and their ``k_x^T Q k_x``, formed
    once to score the batch (:meth:`SparseOnlineGP._out_of_sample`), and used again by its
    screening and absorption while no BV has been added or deleted. Each row is formed on
    its own, so those of a run of points are a slice of them."""

    version: tuple[int, int]
    rows: Rows
    kqk: Tensor

    def run(self, start: int, stop: int, version: tuple[int, int]) -> tuple[Rows, Tensor] | None:
        """Rows and ``k_x^T Q k_x`` of points ``start:stop``; ``None`` if the basis is no
        longer that of ``version``."""
        if version != self.version:
            return None
        return self.rows.take(slice(start, stop)), self.kqk[start:stop]


class _Screen:
    """Novelty of the last screened block of a batch, valid while the basis is unchanged."""

    def __init__(self) -> None:
        self._version: tuple[int, int] | None = None
        self._start = 0
        self._gamma: Tensor | None = None

    def keep(self, version: tuple[int, int], start: int, gamma: Tensor) -> None:
        self._version, self._start, self._gamma = version, start, gamma

    def novelty(self, version: tuple[int, int], start: int) -> Tensor | None:
        """Relative novelty of the rows from ``start`` to the block's end, if still known."""
        if self._gamma is None or version != self._version:
            return None
        offset = start - self._start
        if not 0 <= offset < self._gamma.shape[0]:
            return None
        return self._gamma[offset:]
