"""Default hyperparameters of the sparse GP: the one place that decides them.

The GP asks this module at construction (:func:`resolve_lengthscale` with what is known then:
the user's request and the input bounds) and at its first batch (the same function with the
batch, and :func:`target_standardisation`); nothing else picks a default.

Lengthscale, per input dimension, first that applies:

1. the value the user gave the kernel;
2. where the input space is bounded: the standard deviation of a uniform distribution on the
   bounds, ``(high - low) / sqrt(12)`` (:func:`bounds_lengthscale`), so the choice does not
   depend on how much of the space the first batch covers;
3. the standard deviation of that dimension in the first batch (:func:`default_lengthscale`).

Rules 2 and 3 give a dimension's spread. The GP's ``lengthscale_rule`` may multiply it by
``sqrt(d)`` (:data:`LENGTHSCALE_RULES`), ``d`` the number of inputs.

Rule 2 trusts the bounds; :class:`BoundsCoverage` checks, once the data have had time to
spread, that they were not far wider than the data.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from numpy.typing import ArrayLike
from torch import Tensor

#: Default novelty threshold: a point this many lengthscales from a single BV is novel.
NOVELTY_RADIUS = 0.25
#: Bounds wider than this count as unbounded (gymnasium envs often use float32's maximum).
MAX_BOUND_WIDTH = 1e6
#: How an unset lengthscale follows a dimension's spread ``s`` (rules 2 and 3 above), for ``d``
#: inputs. ``"spread"``: ``s``. ``"distance"``: ``sqrt(d) s``. Two independent inputs lie
#: ``sqrt(2d)`` spreads apart on average, so under ``"spread"`` a kernel's correlation between
#: typical states falls with ``d`` (the Laplacian kernel's ``exp(-sqrt(2d))``: 0.06 at ``d = 4``,
#: 0.003 at ``d = 17``), while ``"distance"`` keeps them about ``sqrt(2)`` lengthscales apart in
#: any dimension, the scaling of the median heuristic on the whole distance.
LENGTHSCALE_RULES = ("spread", "distance")


def resolve_lengthscale(
    lengthscale: Tensor,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    x: Tensor | None = None,
    rule: str = "spread",
) -> Tensor:
    """Fill the unset (NaN) entries of ``lengthscale`` by the rule of this module.

    Parameters
    ----------
    lengthscale : Tensor, shape (d,)
        Requested lengthscales, NaN where none was requested.
    bounds : (low, high) of array-likes of d entries each, optional
        Bounds of the inputs; infinite, empty or wider than :data:`MAX_BOUND_WIDTH` count as
        unbounded.
    x : Tensor, shape (n, d), optional
        The first batch; without it, entries left unset stay NaN.
    rule : {"spread", "distance"}
        :data:`LENGTHSCALE_RULES`.

    Returns
    -------
    Tensor, shape (d,)
    """
    out = lengthscale
    factor = lengthscale_factor(rule, lengthscale.shape[0])
    if bounds is not None:
        from_bounds = torch.as_tensor(bounds_lengthscale(*bounds), dtype=out.dtype)
        out = torch.where(torch.isnan(out), factor * from_bounds.to(out.device), out)
    if x is not None:
        out = torch.where(torch.isnan(out), default_lengthscale(x, rule), out)
    return out


def lengthscale_factor(rule: str, d: int) -> float:
    """What ``rule`` (:data:`LENGTHSCALE_RULES`) multiplies a spread by for ``d`` inputs.

    Raises
    ------
    ValueError
        If ``rule`` is not one of :data:`LENGTHSCALE_RULES`.
    """
    if rule not in LENGTHSCALE_RULES:
        raise ValueError(f"lengthscale_rule must be one of {LENGTHSCALE_RULES}, got {rule!r}")
    return math.sqrt(d) if rule == "distance" else 1.0


def bounds_lengthscale(low: ArrayLike, high: ArrayLike) -> np.ndarray:
    """``(high - low) / sqrt(12)`` per dimension where bounded, NaN where not; shape (d,)."""
    width = (np.asarray(high, dtype=np.float64) - np.asarray(low, dtype=np.float64)).ravel()
    bounded = np.isfinite(width) & (width > 0) & (width < MAX_BOUND_WIDTH)
    return np.where(bounded, width / np.sqrt(12.0), np.nan)


def default_lengthscale(x: Tensor, rule: str = "spread") -> Tensor:
    """Lengthscale heuristic: the standard deviation of each input dimension (times
    ``sqrt(d)`` under ``rule="distance"``, :data:`LENGTHSCALE_RULES`).

    For spread-out data this is close to the per-dimension median heuristic (both are
    ``0.29 x range`` for uniform data), but unlike a median it does not collapse when most of
    the batch sits at one state (a pendulum balanced on top, say).

    Parameters
    ----------
    x : Tensor, shape (n, d)
    rule : {"spread", "distance"}

    Returns
    -------
    Tensor, shape (d,)
        Positive lengthscales; a dimension that does not vary gets its largest absolute value,
        or 1 (times the rule's factor).
    """
    std = x.std(dim=0, unbiased=False)
    fallback = x.abs().max(dim=0).values
    fallback = torch.where(fallback > 0, fallback, torch.ones_like(fallback))
    spread = torch.where(std > _spread_floor(x.dtype) * fallback, std, fallback)
    return lengthscale_factor(rule, x.shape[1]) * spread


def _spread_floor(dtype: torch.dtype) -> float:
    """The relative spread below which data count as not varying: 1e-12, or 64 ulps where the
    dtype's rounding alone spreads a constant that wide (float32: the mean of copies of 0.1
    is not 0.1, and their standard deviation about 7e-9)."""
    return max(1e-12, 64 * torch.finfo(dtype).eps)


def target_standardisation(
    y: Tensor, mean: float | None = None, scale: float | None = None
) -> tuple[Tensor | float, Tensor | float]:
    """Prior mean and scale of the targets: those given, else the first batch's.

    Parameters
    ----------
    y : Tensor, shape (n,)
        The first batch of targets.
    mean, scale : float or None
        Values fixed by the user (``None``: from ``y``).

    Returns
    -------
    mean, scale
        ``scale`` is the standard deviation of ``y``, or 1 when ``y`` (nearly) does not vary.
    """
    chosen_mean: Tensor | float = y.mean() if mean is None else mean
    if scale is not None:
        return chosen_mean, scale
    std = y.std() if y.numel() > 1 else torch.zeros((), dtype=y.dtype)
    return chosen_mean, std if bool(std > _spread_floor(y.dtype) * (1 + y.abs().max())) else 1.0


#: Points after which :class:`BoundsCoverage` compares the inputs' range with the bounds.
COVERAGE_POINTS = 10_000
#: Share of a dimension's bounds below which its inputs' range counts as a small part of them:
#: at 10,000 points the comparison's 14 cells fill at least 25 % of every bounded dimension
#: (seeds 0-2; PPO MountainCarContinuous-v0 and Acrobot-v1, results/loose_bounds/coverage.md),
#: a Pendulum declared in +-100 fills 1 %.
COVERAGE_SHARE = 0.05
#: A dimension whose inputs span more than this many times its bounds' width lies far outside
#: them: SB3's VecNormalize keeps an observation space's raw bounds while it normalises the
#: observations, and its VecFrameStack orders a vector space's stacked bounds element by element
#: while it stacks the observations frame by frame.
OUTSIDE_FACTOR = 2.0


class BoundsCoverage:
    """Whether the inputs spread over the bounds their default lengthscales came from.

    Loose bounds (a custom env declaring ``Box(-100, 100)``) give lengthscales far longer than
    the data's spread: the GP then barely varies along those dimensions, and a hyperprior
    keeps the lengthscales near their start. Bounds the inputs go far outside (observations
    normalised by VecNormalize, stacked by VecFrameStack) give lengthscales of the wrong
    scale. Once :data:`COVERAGE_POINTS` inputs have been seen, :meth:`check` names, once, the
    dimensions whose lengthscale came from the bounds and whose inputs either vary but span
    less than :data:`COVERAGE_SHARE` of them while the lengthscale is still longer than that
    span, or span more than :data:`OUTSIDE_FACTOR` times their width.

    Parameters
    ----------
    low, high : array-likes, shape (d,)
        The bounds.
    unset : array-like of bool, shape (d,)
        The dimensions whose lengthscale the user left to this module: of those, the bounded
        ones (:func:`bounds_lengthscale`) took theirs from the bounds (:attr:`from_bounds`).
    rule : {"spread", "distance"}
        The GP's :data:`LENGTHSCALE_RULES`, which the suggested lengthscales follow.
    """

    def __init__(
        self, low: ArrayLike, high: ArrayLike, unset: ArrayLike, rule: str = "spread"
    ) -> None:
        self.low = np.asarray(low, dtype=np.float64).ravel()
        self.high = np.asarray(high, dtype=np.float64).ravel()
        self.factor = lengthscale_factor(rule, self.low.size)
        bounded = np.isfinite(bounds_lengthscale(self.low, self.high))
        self.from_bounds = np.asarray(unset, dtype=bool).ravel() & bounded
        self.seen_low = np.full_like(self.low, np.inf)
        self.seen_high = np.full_like(self.high, -np.inf)
        self.points = 0
        self.checked = False

    def add(self, x: Tensor) -> None:
        """Widen the range seen by the inputs ``x : (n, d)``."""
        if x.shape[0] == 0:
            return
        self.seen_low = np.minimum(self.seen_low, x.min(dim=0).values.double().cpu().numpy())
        self.seen_high = np.maximum(self.seen_high, x.max(dim=0).values.double().cpu().numpy())
        self.points += x.shape[0]

    def check(self, lengthscale: Tensor) -> str | None:
        """Once :data:`COVERAGE_POINTS` inputs have been seen (and only then): a message naming
        the dimensions that barely fill their bounds, with lengthscales from the data's range
        by the bounds' rule, or ``None`` if there are none."""
        if self.checked or self.points < COVERAGE_POINTS:
            return None
        self.checked = True
        span = self.seen_high - self.seen_low
        width = self.high - self.low
        share = np.divide(span, width, out=np.ones_like(span), where=self.from_bounds)
        ls = lengthscale.double().cpu().numpy()
        # A constant input (span 0) carries nothing to fit along it, whatever its lengthscale.
        spread = span > 0
        loose = self.from_bounds & spread & (share < COVERAGE_SHARE) & (ls > span)
        outside = self.from_bounds & (share > OUTSIDE_FACTOR)
        if not (loose | outside).any():
            return None
        suggested = np.where(self.from_bounds & spread, self.factor * span / np.sqrt(12.0), ls)
        rule = "" if self.factor == 1 else f"{self.factor:.3g} x "  # sqrt(d), as the rule's
        dims = " and ".join(
            f"dimension {i} spans [{self.seen_low[i]:.3g}, {self.seen_high[i]:.3g}] "
            + (f"({share[i]:.1%} of" if loose[i] else f"({share[i]:.3g} times the width of")
            + f" its bounds [{self.low[i]:.3g}, {self.high[i]:.3g}]; lengthscale {ls[i]:.3g})"
            for i in np.flatnonzero(loose | outside)
        )
        return (
            f"the GP's first {self.points:,} inputs: {dims}. The lengthscales came from those "
            "bounds, not from the data's spread: far longer than a spread that fills little of "
            "its bounds (the GP then barely varies along it), too short for one far outside "
            "them (bounds of the inputs before they were normalised or reordered), so the GP "
            "fits its targets poorly. If the bounds are loose or describe other inputs (for "
            "GPActorCriticPolicy: the observation space's), declare bounds that fit the data, "
            f"or give the kernel lengthscales, e.g. lengthscale="
            f"{np.round(suggested, 3).tolist()} ({rule}the data's range / sqrt(12) wherever a "
            "lengthscale came from the bounds), for the policy through "
            "policy_kwargs=dict(gp_kwargs=dict(kernel_kwargs=dict(lengthscale=[...])))"
        )
