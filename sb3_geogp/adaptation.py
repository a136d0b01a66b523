"""Adaptation of the sparse GP to its data stream: hyperparameters, target scale, forgetting.

A :class:`~sb3_geogp.SparseOnlineGP` built with ``adapt=Adaptation(...)`` retains the last
``window`` points it was fed. Forgetting acts per *batch* (one :meth:`update` call: a PPO
rollout, or one A2C rollout of a few steps): a point ``age`` batches old has weight
``w = lambda^age``. Once ``interval`` new points have arrived (one PPO rollout, a dozen or more
A2C rollouts), the GP closes a *block* and adapts, in this order:

1. **Forgetting.** Before each batch of the block was absorbed, every candidate ``lambda``
   was scored by the negative log predictive density (NLPD) of that batch under the posterior
   forgotten by ``lambda`` first (:meth:`~sb3_geogp.SparseOnlineGP.update`'s out-of-sample
   statistics, so scoring costs nothing extra). The candidate with the lowest total over the
   block is chosen: an out-of-sample test of how fast the targets drift, which uses every
   point, also when a batch is larger than the window.
2. **Targets.** Mean and scale of the targets become the ``w``-weighted mean and standard
   deviation of the window's targets (unless the user fixed them).
3. **Hyperparameters.** ``steps`` Adam steps on the log lengthscale factors (as the kernel
   allows: one per dimension, or one for all with ``GeodesicKernel(ard=False)``; the geodesic
   kernel's tree keeps its paths and sums its stretched edges along them), the log signal and
   log noise variance, minimising the
   negative collapsed variational bound (Titsias 2009) of the window per point, with the basis
   vectors as inducing points and noise ``sigma_n^2 / w_i`` on point ``i``:

   .. math::  -\\mathcal{F} = -\\log \\mathcal{N}(y \\mid 0, Q_{xx} + \\Lambda)
              + \\tfrac12 \\sum_i (k_{ii} - q_{ii}) / \\Lambda_{ii},
              \\qquad Q_{xx} = K_{xz} K_{zz}^{-1} K_{zx}.

   Each parameter is kept within its bounds. With ``follow_spread=True`` the lengthscales
   that the first batch chose (unbounded inputs, none given) first start again from the
   window's standard deviation of their inputs, each keeping its fitted factor; with
   ``"widen"`` (the policy's PPO default since 0.43) only where that is wider than their start.
   The hyperprior and the bounds are relative to that start.
4. **Posterior.** The exact sparse posterior of the window under the new hyperparameters,
   times the :class:`Summary` of the points that have left the window, replaces the on-line
   one (:func:`sparse_posterior`): nothing is rebuilt from the targets stored with the basis
   vectors, which are stale in RL.

A point leaving the window is projected onto the basis vectors of that moment, as the sparse
posterior projects every point, and added, with its weight, to the summary: a Gaussian
likelihood of the function values at the basis vectors. It does not depend on the kernel, so
it survives a change of hyperparameters; it ages with the window's points (times ``lambda``
per batch), follows a change of the target units, and a deletion of a basis vector
substitutes that vector's conditional mean given the others, as the on-line deletion does.
Without it a rebuild would forget everything older than the window (measured: 2-4x the batch
sparse GP's error on the fixed-policy pendulum check, against about 1x without adaptation).
With ``Adaptation(summary="snapshot")`` (the policy's PPO default since 0.11) the summary is
instead, when a block that refits opens, the likelihood the posterior implies
(:meth:`Summary.of_posterior`): it holds every point absorbed so far, unthinned, and the
refit's rebuild uses the window's points from then on.

With ``Adaptation(max_gap=g)``, steps 2-4 (the *refit*) run only on the first block, on the
blocks numbered by a power of two below ``g`` (unless ``settle=False``) and on the multiples of
``g``; every block still chooses its forgetting. With ``drift_tol=c``, a block whose new
targets have drifted, their mean square in the current standardised units (over the points
scored in step 1) outside ``[1/c, c]``, refits too: returns that grow as the policy improves
get their new scale, and hyperparameters fitted on the first returns (often nearly constant)
their refit, when the data say so rather than on a fixed schedule. With ``fit_floor=f``, a
block whose targets the posterior predicted (step 1's out-of-sample predictions, over the
points it scored) with an explained variance below ``f`` refits too: the refits go where the
model is wrong; with ``fit_spacing=s`` only once ``s`` points have arrived since the last
refit, so that a stream of small blocks does not refit each one. ``score_points`` and
``fold_points`` make step 1 and the summary below use an evenly spaced subsample of a batch
(:func:`thinned`). All of these are off by default;
:data:`CHEAP_ADAPTATION` combines the cheaper ones, and since 0.10 the GP critic's policy under
PPO uses all but ``drift_tol`` and ``fit_spacing`` and since 0.11 the snapshot summary
(:data:`sb3_geogp.policies.DEFAULT_ADAPTATION`; 0.14's used the lagged forgetting score below;
since 0.23 it adds the hyperprior ``prior_sd=0.1``, since 0.35 ``whole_batch``, since 0.39
``fit_spacing=4096``).
docs/benchmarks.md measures what they save and what fit they cost, docs/results.md what they
cost in training.

Between adaptations the GP learns on-line as without adaptation, forgetting with the chosen
``lambda`` before each batch (``alpha <- sqrt(lambda) alpha``, ``C <- lambda C``), which the
next rebuild's weights then make exact.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any, NamedTuple

import torch
from torch import Tensor, nn

from sb3_geogp.options import positive_int

#: Ways the summary of :class:`Adaptation` is kept.
SUMMARIES = ("fold", "snapshot")
#: Ways the forgetting candidates of :class:`Adaptation` are scored (and forgetting applied).
FORGETTING_SCORES = ("shrink", "lagged")
#: Multiplies the signal variance for the first jitter a failed Cholesky factorisation gets.
_JITTER_START = 1e-6
_JITTER_TRIES = 12


@dataclass(frozen=True)
class Adaptation:
    """Settings of a GP's adaptation to its data stream (see the module docstring).

    Parameters
    ----------
    window : int
        Points retained (the most recent).
    interval : int or None
        New points per block: the GP adapts once this many have arrived since the last
        adaptation (at the end of the batch that completes them). ``None``: half the window.
    steps : int
        Adam steps on the hyperparameters per adaptation (0: only forgetting, targets and the
        rebuild).
    fit_points : int
        The steps fit the newest ``fit_points`` retained points (the cost of a step is linear
        in them); the rebuild uses the whole window.
    lr : float
        Adam step size on the log-parameters.
    forgetting : tuple of float
        Candidates for ``lambda`` per batch, each in (0, 1]. The default spans what PPO
        (one batch per rollout of thousands of points) and A2C (dozens of small batches per
        block) need; A2C's recommended fixed value is 0.9 (docs/results.md).
    lengthscale_range : (float, float)
        Bounds on the lengthscales as factors of those the GP started with.
    variance_bounds, noise_bounds : (float, float)
        Bounds on the signal and the noise variance (standardised target units).
    targets : bool
        Re-estimate the target mean and scale (ignored where the user fixed them).
    prior_sd : float or None
        Standard deviation of a Gaussian hyperprior on the log lengthscale factors (relative
        to the lengthscales the GP started with) and on the log signal variance (whose
        natural scale is 1 in standardised target units): the steps then maximise the
        posterior, ``F - sum(u^2) / (2 prior_sd^2)`` over the fitted points, ``u`` those logs.
        ``None``: no prior, the bounds alone (docs/benchmarks.md measures 0.1).
    max_gap : int
        Most blocks between refits: targets, hyperparameters and the rebuild (steps 2-4 of
        the module docstring) run on the blocks numbered by a power of two below ``max_gap``
        (1, 2, 4, ...: often while they settle) and on every multiple of ``max_gap``; the other
        blocks only choose the forgetting (step 1). 1: every block refits.
    score_points : int or None
        The out-of-sample statistics and forgetting scores of a batch use at most this many of
        its points: an evenly spaced subsample (:func:`thinned`), each point counted for the
        run of points it stands for. ``None``: every point.
    fold_points : int or None
        Points leaving the window at once are added to the summary through an evenly spaced
        subsample of at most this many, each with its weight times the length of its run.
        ``None``: every point (the summary is then exact). Not free where consecutive points
        are far apart or share their noise, as along a trajectory: on the fixed-policy
        pendulum 256 of 1,520 points cost 1.35x a batch sparse GP's error at 200 basis
        vectors, every point 1.13x (docs/results.md).
    settle : bool
        Whether the blocks numbered by a power of two below ``max_gap`` refit too (while the
        hyperparameters settle); ``False``: only the first block and the multiples.
    drift_tol : float or None
        Refit a block whose targets drifted beyond this factor (module docstring); ``> 1``.
        ``None``: only on the schedule of ``max_gap``.
    fit_floor : float or None
        Refit a block whose targets the posterior predicted, before absorbing each batch,
        with an explained variance below this (over the points scored in step 1; a block of
        targets that do not vary never counts); ``< 1``. ``None``: only on the schedule of
        ``max_gap`` (and ``drift_tol``).
    fit_spacing : int or None
        A block refits for its fit (``fit_floor``) only once at least this many points have
        arrived since the last refit, the block's own included. Blocks of at least this many
        points are unaffected; smaller ones (PPO's CartPole-v1 blocks of 1,024 points, its zoo
        rollouts being 256) refit for their fit at most once per ``fit_spacing`` points.
        ``None``: any block below the floor refits.
    summary : {"fold", "snapshot"}
        How the summary comes to hold the points a rebuild does not use (module docstring).
        ``"fold"``: each point leaving the window is folded in (through ``fold_points``).
        ``"snapshot"``: when a block that refits opens (every block of several batches, whose
        refit is known only at its end), the summary becomes the likelihood that the
        posterior implies (:meth:`Summary.of_posterior`), which holds every point absorbed so
        far; the refit's rebuild then uses the window's points that arrived since, and only
        those of them that left the window in between are folded in (under PPO, the part of
        a rollout larger than the window). No thinning of older points: on the fixed-policy
        pendulum with the PPO default's schedule 1.08-1.12x a batch sparse GP's error at
        50-200 basis vectors, against 1.23x / 1.35x at 100 / 200 with folds
        (docs/results.md).
    forgetting_score : {"shrink", "lagged"}
        How the forgetting candidates are scored and what forgetting does.
        ``"shrink"``: forgetting by ``lambda`` shrinks the posterior towards the prior
        (``alpha <- sqrt(lambda) alpha``, ``C <- lambda C``), and a candidate is scored by how
        the posterior shrunk by it predicts the new batch. Shrinking never sharpens what the
        newest data say, so where the values drift with the policy (PPO) it chooses 1.
        ``"lagged"``: forgetting multiplies the likelihood of everything absorbed so far by
        ``lambda`` (every point then counts ``lambda ** age``, as in a refit's rebuild), and a
        candidate is scored by how the posterior that had forgotten the older data by it
        *before the previous batch* predicts the new one
        (:func:`lagged_forgetting_scores`): the evidence of one batch ahead. It costs a few
        ``(m, m)`` factorisations per batch, made for PPO's large batches, not A2C's small
        ones; float64 only (a float32 GP refuses it: its 10^6-point soak left ``P``
        indefinite). In its first pre-registered PPO test (0.12, an option) it made the
        pendulums' critics more accurate and changed no cell's return, at 17 % of the GP
        critic's time; 0.14's PPO default used it, starting from forgetting 0.1 per 4,096
        points, and 0.15's went back to the shrinking score at half the cost, after a
        pre-registered test against it (docs/results.md).
    follow_spread : bool or "widen"
        Whether every refit first moves the starting lengthscales of the dimensions that took
        theirs from the first batch (an unbounded input for which none was given) to the
        window's standard deviation of that input, the rule the first batch used, each
        lengthscale keeping its fitted factor relative to its start (``prior_sd`` and
        ``lengthscale_range`` are relative to the start). The first batch of a policy that has
        barely moved (32 steps of PPO's InvertedPendulum-v5 from rest) holds a tenth of the
        spread that the states later have in some inputs, and without it each dimension's
        lengthscale stays near that batch's (docs/results.md, session 82). ``True`` follows
        the spread both ways; ``"widen"`` only where the window spreads wider than the start,
        so each start is the widest spread a window has shown (PPO's CartPole-v1 states
        narrow to a third of the first batch's spread as its policy learns to balance, and
        following them there made the critic less accurate, session 82); ``"widen"`` is part
        of the policy's PPO default since 0.43 (docs/results.md, session 83). A kernel with one
        factor for all dimensions (``GeodesicKernel(ard=False)``) moves all by the geometric
        mean of those dimensions' ratios. Bounded and given lengthscales never follow.
    whole_batch : bool
        Whether a refit's rebuild uses every point of the batch that closed the block, also
        those the window had no room for (a batch larger than ``window``: PPO's Acrobot-v1 and
        Pendulum-v1 rollouts of 4,096 points against the 2,048 of the policy's default).
        ``False``: they leave the window before the refit and reach the rebuild only through
        the summary, projected under the hyperparameters the refit replaces and thinned to
        ``fold_points``; on Acrobot-v1's recorded PPO streams the critic then predicted the
        next rollout worse than one whose window held the whole rollout (docs/results.md,
        "The first batches"). Batches no larger than the room in the window are unaffected.
        Part of the policy's PPO default since 0.35, after two registered tests (the second:
        issue 13's critic-fit score on Acrobot-v1 +0.127 [+0.060, +0.194] over 40 fresh seeds,
        no return different; docs/results.md, "The whole rollout in the refit's rebuild").

    Raises
    ------
    ValueError
        For a non-positive count, a bad step size or ``prior_sd``, an empty or out-of-range
        candidate list, or bounds that are not ``0 < low <= high < inf``.
    """

    window: int = 2048
    interval: int | None = None
    steps: int = 5
    fit_points: int = 512
    lr: float = 0.05
    forgetting: tuple[float, ...] = (1.0, 0.97, 0.9, 0.7, 0.5, 0.25, 0.1, 0.03)
    lengthscale_range: tuple[float, float] = (0.01, 100.0)
    variance_bounds: tuple[float, float] = (1e-2, 1e2)
    noise_bounds: tuple[float, float] = (1e-4, 1.0)
    targets: bool = True
    prior_sd: float | None = None
    max_gap: int = 1
    score_points: int | None = None
    fold_points: int | None = None
    settle: bool = True
    drift_tol: float | None = None
    fit_floor: float | None = None
    fit_spacing: int | None = None
    summary: str = "fold"
    forgetting_score: str = "shrink"
    whole_batch: bool = False
    follow_spread: bool | str = False

    def __post_init__(self) -> None:
        optional = ("interval", "score_points", "fold_points", "fit_spacing")
        for name in ("window", "fit_points", "max_gap", *optional):
            value = getattr(self, name)
            if value is not None or name not in optional:
                # frozen: a NumPy integer is stored as Python's (as_dict goes to JSON)
                object.__setattr__(self, name, positive_int(f"Adaptation.{name}", value))
        if isinstance(self.steps, bool) or not isinstance(self.steps, int) or self.steps < 0:
            raise ValueError(f"Adaptation.steps must be an integer >= 0, got {self.steps!r}")
        if not (self.lr > 0 and math.isfinite(self.lr)):
            raise ValueError(f"Adaptation.lr must be positive and finite, got {self.lr}")
        if self.prior_sd is not None and not (self.prior_sd > 0 and math.isfinite(self.prior_sd)):
            raise ValueError(
                f"Adaptation.prior_sd must be positive and finite (or None: no prior), got "
                f"{self.prior_sd}"
            )
        if not (isinstance(self.follow_spread, bool) or self.follow_spread == "widen"):
            raise ValueError(
                f'Adaptation.follow_spread must be True, False or "widen", got '
                f"{self.follow_spread!r}"
            )
        for name in ("settle", "whole_batch"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(
                    f"Adaptation.{name} must be True or False, got {getattr(self, name)!r}"
                )
        tol = self.drift_tol
        if tol is not None and not (tol > 1 and math.isfinite(tol)):
            raise ValueError(
                f"Adaptation.drift_tol must be a finite factor > 1 (or None: no drift refits), "
                f"got {self.drift_tol}"
            )
        floor = self.fit_floor
        if floor is not None and not (floor < 1 and math.isfinite(floor)):
            raise ValueError(
                f"Adaptation.fit_floor must be a finite explained variance < 1 (or None: no fit "
                f"refits), got {self.fit_floor}"
            )
        if self.summary not in SUMMARIES:
            raise ValueError(f"Adaptation.summary must be one of {SUMMARIES}, got {self.summary!r}")
        if self.forgetting_score not in FORGETTING_SCORES:
            raise ValueError(
                f"Adaptation.forgetting_score must be one of {FORGETTING_SCORES}, got "
                f"{self.forgetting_score!r}"
            )
        candidates = tuple(float(c) for c in self.forgetting)
        if not candidates or not all(0 < c <= 1 for c in candidates):
            raise ValueError(
                f"Adaptation.forgetting must be a non-empty tuple of values in (0, 1], got "
                f"{self.forgetting!r}; pass (1.0,) for no forgetting"
            )
        object.__setattr__(self, "forgetting", candidates)
        for name in ("lengthscale_range", "variance_bounds", "noise_bounds"):
            bounds = getattr(self, name)
            if len(bounds) != 2 or not (0 < bounds[0] <= bounds[1] < math.inf):
                raise ValueError(
                    f"Adaptation.{name} must be (low, high) with 0 < low <= high < inf, got "
                    f"{bounds!r}"
                )
            object.__setattr__(self, name, (float(bounds[0]), float(bounds[1])))

    @property
    def block(self) -> int:
        """New points per block."""
        return self.interval if self.interval is not None else max(1, self.window // 2)

    def refits(self, block: int) -> bool:
        """Whether the ``block``-th block (from 1) refits: the first, a multiple of
        ``max_gap`` or, with ``settle``, a power of two below it."""
        if block == 1 or block % self.max_gap == 0:
            return True
        return self.settle and block < self.max_gap and block & (block - 1) == 0

    def drifted(self, mean_square: float) -> bool:
        """Whether targets whose mean square in standardised units is ``mean_square`` have
        drifted beyond ``drift_tol`` (never without one)."""
        tol = self.drift_tol
        return tol is not None and not (1 / tol <= mean_square <= tol)

    def misfitted(self, explained: float, since: int) -> bool:
        """Whether a block whose targets were predicted with explained variance ``explained``
        (NaN: targets that do not vary) falls below ``fit_floor`` (never without one), ``since``
        points after the last refit (the block's included): at least ``fit_spacing``."""
        spaced = self.fit_spacing is None or since >= self.fit_spacing
        return self.fit_floor is not None and explained < self.fit_floor and spaced

    def refit_due(self, block: int, drift: float, explained: float, since: int) -> bool:
        """Whether the ``block``-th block, closing ``since`` points after the last refit,
        refits: on its schedule (:meth:`refits`), or for the drift (:meth:`drifted`) or the
        fit (:meth:`misfitted`) of its scored targets."""
        return self.refits(block) or self.drifted(drift) or self.misfitted(explained, since)

    def as_dict(self) -> dict[str, Any]:
        """JSON-compatible settings (stored in the GP's state)."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


#: Adaptation at a fraction of the default's cost (0.7): targets, hyperparameters (fitted on 256
#: points) and posterior are refitted on the first block, every 16th, and any block whose
#: targets drifted by a factor 2 in mean square; scores and summary use at most 256 points of a
#: batch. With the PPO default critic it halves the GP's time (adaptation 60 % -> 17 % of it on
#: PPO Pendulum-v1) but loses MountainCarContinuous at 95 % (final return -13 against the
#: default's adaptation; not firmly attributed) and Acrobot falls behind SB3's MLP
#: critic at 95 % (docs/results.md, "Cheaper adaptation, 0.7"), so it is an option, not the
#: default.
CHEAP_ADAPTATION = Adaptation(
    max_gap=16, settle=False, drift_tol=2.0, fit_points=256, score_points=256, fold_points=256
)


def as_adaptation(adapt: Adaptation | Mapping[str, Any] | bool | None) -> Adaptation | None:
    """``adapt`` as settings: ``True`` gives the defaults, ``False``/``None`` none, a mapping
    the :class:`Adaptation` of those settings (what a command line or a YAML file can say,
    e.g. ``{"prior_sd": 0.1}``)."""
    if adapt is None or adapt is False:
        return None
    if adapt is True:
        return Adaptation()
    if isinstance(adapt, Mapping):
        names = [f.name for f in fields(Adaptation)]
        unknown = sorted(set(adapt) - set(names))
        if unknown:
            raise ValueError(f"adapt has unknown settings {unknown}; Adaptation takes {names}")
        return Adaptation(**adapt)
    if not isinstance(adapt, Adaptation):
        raise ValueError(
            f"adapt must be True, False, None, an Adaptation or a dict of its settings, got "
            f"{adapt!r}"
        )
    return adapt


def thinned(n: int, cap: int | None, device: torch.device | None = None) -> tuple[Tensor, Tensor]:
    """An evenly spaced subsample of ``n`` points, at most ``cap`` of them.

    The points are cut into runs of ``ceil(n / cap)`` consecutive ones (the last may be
    shorter); each run is represented by its middle point. Consecutive points of a trajectory
    are close, so a sum over the points is approximated by the representatives' terms times
    their runs' lengths (exact for ``cap >= n`` or ``cap=None``: every point, runs of 1).

    Parameters
    ----------
    n : int
        Points to subsample.
    cap : int or None
        Most representatives (``None``: every point).
    device : torch.device, optional
        Where the index tensors are made.

    Returns
    -------
    index : Tensor, shape (k,)
        The representatives, in order.
    count : Tensor, shape (k,)
        Length of each one's run (they sum to ``n``).
    """
    stride = 1 if cap is None or n <= cap else -(-n // cap)
    starts = torch.arange(0, n, stride, device=device)
    count = (n - starts).clamp_max(stride)
    return starts + (count - 1) // 2, count


def jittered_cholesky(A: Tensor, scale: float) -> tuple[Tensor, float]:
    """Cholesky factor of the symmetric ``A : (m, m)``, with jitter if it needs one.

    As GPyTorch does, a failed factorisation is retried with ``jitter * I`` added, starting at
    ``1e-6 * scale`` (``scale``: the size of ``A``'s diagonal, e.g. the signal variance) and
    growing 10x per try, up to 12 tries (``1e4 * scale``).

    Parameters
    ----------
    A : Tensor, shape (m, m)
        Symmetric, positive (semi-)definite.
    scale : float
        Size of ``A``'s diagonal, which the jitter is relative to.

    Returns
    -------
    L : Tensor, shape (m, m)
    jitter : float
        What was added to the diagonal (0.0 when none was needed).

    Raises
    ------
    FloatingPointError
        Only if ``A`` is not finite or not even ``A + 1e4 * scale * I`` factorises.
    """
    L, info = torch.linalg.cholesky_ex(A)
    if int(info) == 0:
        return L, 0.0
    eye = torch.eye(A.shape[0], dtype=A.dtype, device=A.device)
    jitter = _JITTER_START * scale
    for _ in range(_JITTER_TRIES - 1):
        L, info = torch.linalg.cholesky_ex(A + jitter * eye)
        if int(info) == 0:
            return L, jitter
        jitter *= 10
    raise FloatingPointError(
        f"a ({A.shape[0]}, {A.shape[0]}) matrix is not positive definite even with jitter "
        f"{jitter:.3g}"
    )


class Projection:
    """The window seen through the inducing points: ``K_zz`` factored, ``A = L^{-1} K_zx``.

    Parameters
    ----------
    Kzz : Tensor, shape (m, m)
        Prior covariance of the inducing points (with their nuggets).
    Kxz : Tensor, shape (n, m)
        Cross covariance of the points with the inducing points.
    variance : float
        Signal variance (the jitter scale).
    """

    def __init__(self, Kzz: Tensor, Kxz: Tensor, variance: float) -> None:
        self.L, _ = jittered_cholesky(Kzz, variance)
        self.Kxz = Kxz

    @functools.cached_property
    def A(self) -> Tensor:
        """``L^{-1} K_zx``, shape (m, n)."""
        return torch.linalg.solve_triangular(self.L, self.Kxz.T, upper=False)

    def q_diag(self) -> Tensor:
        """``diag(K_xz K_zz^{-1} K_zx)``, shape (n,)."""
        return self.A.square().sum(dim=0)

    def posterior(
        self, y: Tensor, noise: Tensor, summary: Summary | None = None
    ) -> tuple[Tensor, Tensor]:
        """:func:`sparse_posterior` from this projection.

        Parameters
        ----------
        y : Tensor, shape (n,)
            Standardised targets.
        noise : Tensor, shape (n,)
            Each point's noise variance.
        summary : Summary, optional
            A likelihood at the inducing points to multiply in (points no longer retained).

        Returns
        -------
        alpha, P : Tensor, shapes (m,), (m, m)
        """
        B, Ay = self._system(y, noise)
        if summary is not None:
            # The summary's precision and shift in the whitened coordinates v = L^-1 f_z.
            B = B + self.L.T @ summary.precision @ self.L
            Ay = Ay + self.L.T @ summary.shift
        return self.solve(0.5 * (B + B.T), Ay)

    def solve(self, B: Tensor, Ay: Tensor) -> tuple[Tensor, Tensor]:
        """``alpha`` and ``P`` from ``B = I + A N^-1 A^T`` and ``A N^-1 y``.

        Parameters
        ----------
        B : Tensor, shape (m, m)
            Symmetric positive definite.
        Ay : Tensor, shape (m,)

        Returns
        -------
        alpha, P : Tensor, shapes (m,), (m, m)
        """
        LB, _ = jittered_cholesky(B, 1.0)
        # P = L^-T B^-1 L^-1, alpha = L^-T B^-1 A N^-1 y.
        eye = torch.eye(self.L.shape[0], dtype=self.L.dtype, device=self.L.device)
        Linv = torch.linalg.solve_triangular(self.L, eye, upper=False)
        W = torch.cholesky_solve(torch.cat([Linv, Ay[:, None]], dim=1), LB)
        P = Linv.T @ W[:, :-1]
        return Linv.T @ W[:, -1], 0.5 * (P + P.T)

    def _system(self, y: Tensor, noise: Tensor) -> tuple[Tensor, Tensor]:
        """``B = I + A N^-1 A^T`` and ``A N^-1 y`` (for ``y : (n,)`` or ``(n, k)``)."""
        S = self._gram(noise)
        eye = torch.eye(S.shape[0], dtype=S.dtype, device=S.device)
        return eye + S, self._rhs(y, noise)

    def _gram(self, noise: Tensor) -> Tensor:
        """``A N^-1 A^T``, shape (m, m), symmetric."""
        m, n = self.Kxz.shape[1], self.Kxz.shape[0]
        if "A" in self.__dict__ or n <= 2 * m:
            scaled = self.A / noise.sqrt()
            S = scaled @ scaled.T
        else:
            # Many more points than inducing points: one (n, m) product, then (m, m) solves only.
            scaled = self.Kxz / noise.sqrt()[:, None]
            half = torch.linalg.solve_triangular(self.L, scaled.T @ scaled, upper=False)
            S = torch.linalg.solve_triangular(self.L, half.T, upper=False)
        return 0.5 * (S + S.T)

    def _rhs(self, y: Tensor, noise: Tensor) -> Tensor:
        """``A N^-1 y``: ``L^-1 (K_zx N^-1 y)``, one triangular solve instead of ``A``."""
        # y : (n,) or (n, k); the noise divides its rows either way.
        y_over_noise = (y.mT / noise).mT if y.ndim == 2 else y / noise
        if "A" in self.__dict__:
            return self.A @ y_over_noise
        weighted = self.Kxz.T @ y_over_noise
        column = weighted.ndim == 1
        solved = torch.linalg.solve_triangular(
            self.L, weighted[:, None] if column else weighted, upper=False
        )
        return solved[:, 0] if column else solved

    def negative_bound(self, y: Tensor, noise: Tensor, kxx: Tensor) -> Tensor:
        """The negative collapsed bound ``-F`` per point (module docstring); differentiable.

        Parameters
        ----------
        y : Tensor, shape (n,)
            Standardised targets.
        noise : Tensor, shape (n,)
            Each point's noise variance.
        kxx : Tensor, shape (n,)
            The prior variance ``k(x_i, x_i)`` of each point.

        Returns
        -------
        Tensor, shape ()
        """
        n = y.shape[0]
        q_diag = self.q_diag()
        B, Ay = self._system(y, noise)
        LB = torch.linalg.cholesky(B)
        c = torch.linalg.solve_triangular(LB, Ay[:, None], upper=False)[:, 0]
        quad = (y * y / noise).sum() - c @ c
        logdet = 2 * LB.diagonal().log().sum() + noise.log().sum()
        trace = ((kxx - q_diag).clamp_min(0) / noise).sum()
        return 0.5 * (quad + logdet + trace + n * math.log(2 * math.pi)) / n


def sparse_posterior(
    Kzz: Tensor,
    Kxz: Tensor,
    y: Tensor,
    noise: Tensor,
    variance: float,
    summary: Summary | None = None,
) -> tuple[Tensor, Tensor]:
    """Exact sparse (DTC / projected-process) posterior of data in Csató–Opper form.

    The model ``y_i = f(x_i) + eps_i``, ``eps_i ~ N(0, noise_i)``, with ``f`` restricted to
    the span of the inducing points ``z``: the posterior mean is ``mu(x) = k_xz^T alpha`` and
    the latent variance ``k(x, x) - k_xz^T K_zz^{-1} k_zx + k_xz^T P k_zx``, where

    .. math::  P = (K_{zz} + K_{zx} N^{-1} K_{xz})^{-1}, \\qquad
               \\alpha = P K_{zx} N^{-1} y,

    computed through ``K_zz = L L^T`` and ``B = I + L^{-1} K_zx N^{-1} K_xz L^{-T}`` (whose
    eigenvalues are at least 1), never by inverting ``K_zz + K_zx N^{-1} K_xz`` directly.
    A ``summary`` of further data (a Gaussian likelihood ``exp(-f^T Lambda f / 2 + eta^T f)``
    of the function values ``f`` at ``z``) multiplies in: with ``Lambda`` and ``eta`` of data
    projected as above, the result is the posterior of both data sets together.

    Parameters
    ----------
    Kzz : Tensor, shape (m, m)
    Kxz : Tensor, shape (n, m)
    y : Tensor, shape (n,)
    noise : Tensor, shape (n,)
        Noise variance of each point.
    variance : float
        Signal variance (the jitter scale of the factorisations).

    summary : Summary, optional

    Returns
    -------
    alpha : Tensor, shape (m,)
    P : Tensor, shape (m, m)
        Symmetric positive definite.
    """
    return Projection(Kzz, Kxz, variance).posterior(y, noise, summary)


class Summary(NamedTuple):
    """A Gaussian likelihood of the function values ``f : (m,)`` at the inducing points,
    ``exp(-f^T precision f / 2 + shift^T f)``: what data that is no longer retained says.

    Data ``(x, y)`` with noise ``N`` contributes, as in :func:`sparse_posterior`,
    ``precision = K_zz^{-1} K_zx N^{-1} K_xz K_zz^{-1}`` and
    ``shift = K_zz^{-1} K_zx N^{-1} y`` (:meth:`of_data`); ``unit_shift`` and
    ``input_shift`` are the shifts the same points would give with every target 1 and with
    targets ``x_k`` (column ``k``), which a change of the prior mean ``c + b^T x`` needs: the
    shift of ``y - c - b^T x`` is ``shift - c unit_shift - input_shift b`` (the projection of
    a constant or of a linear function is neither).
    """

    precision: Tensor
    shift: Tensor
    unit_shift: Tensor
    input_shift: Tensor

    @staticmethod
    def of_data(
        Kzz: Tensor,
        Kxz: Tensor,
        x: Tensor,
        y: Tensor,
        noise: Tensor,
        variance: float,
        inverse: Tensor | None = None,
    ) -> Summary:
        """The summary of ``y : (n,)`` at inputs ``x : (n, d)``, rows ``Kxz : (n, m)``, with
        noise ``noise : (n,)``.

        Given ``inverse`` (``K_zz^{-1}``, which the GP keeps as ``Q``) and few points
        (``n < 2m``, e.g. an A2C rollout leaving the window): through ``F = K_zz^{-1} K_zx``,
        ``precision = F N^-1 F^T``, ``O(m^2 n)``. Otherwise :class:`Projection`'s whitened
        sums, taken back from ``v = L^-1 f`` to ``f`` by ``(m, m)`` solves,
        ``O(m^2 n + m^3)``. The same quantities; the order of the products is the cheaper one.
        """
        targets = torch.cat([y[:, None], torch.ones_like(y)[:, None], x], dim=1)
        if inverse is not None and Kxz.shape[0] < 2 * Kxz.shape[1]:
            F = inverse @ Kxz.T
            precision = (F / noise) @ F.T
            shifts = F @ (targets / noise[:, None])
        else:
            projection = Projection(Kzz, Kxz, variance)

            def unwhiten(X: Tensor) -> Tensor:  # L^-T X
                return torch.linalg.solve_triangular(projection.L.T, X, upper=True)

            precision = unwhiten(unwhiten(projection._gram(noise)).T)
            shifts = unwhiten(projection._rhs(targets, noise))
        return Summary(0.5 * (precision + precision.T), shifts[:, 0], shifts[:, 1], shifts[:, 2:])

    @staticmethod
    def of_posterior(alpha: Tensor, L: Tensor, Q: Tensor, z: Tensor) -> Summary:
        """The likelihood a posterior in Csató–Opper form implies, relative to its prior.

        With the prior ``f ~ N(0, K)`` at the inducing points ``z : (m, d)``, ``Q = K^{-1}``,
        the posterior ``Cov[f] = K P K``, ``E[f] = K alpha`` is the prior times the Gaussian
        likelihood

        .. math::  \\Lambda = \\mathrm{Cov}[f]^{-1} - K^{-1} = Q P^{-1} Q - Q, \\qquad
                   \\eta = \\mathrm{Cov}[f]^{-1} E[f] = Q P^{-1} \\alpha,

        whatever data it holds: for the sparse posterior of data (:func:`sparse_posterior`)
        it is the data's :meth:`of_data` (plus any summary multiplied in). The unit and input
        shifts are those of pseudo-observations at ``z`` itself, ``Lambda 1`` and
        ``Lambda z``: exact for data at the inducing points, otherwise they stand in for the
        data's own, which a posterior no longer knows.

        Parameters
        ----------
        alpha : Tensor, shape (m,)
        L : Tensor, shape (m, m)
            Lower Cholesky factor of ``P`` (:func:`posterior_cholesky`), which the GP shares
            with its other uses of ``P^-1`` (lagged forgetting) in the same state.
        Q : Tensor, shape (m, m)
            Symmetric positive definite.
        z : Tensor, shape (m, d)
            Inducing inputs, in the units of the prior mean's inputs.
        """
        m = alpha.shape[0]
        W = torch.linalg.solve_triangular(L, torch.cat([Q, alpha[:, None]], dim=1), upper=False)
        precision = W[:, :m].T @ W[:, :m] - Q
        precision = 0.5 * (precision + precision.T)
        return Summary(precision, W[:, :m].T @ W[:, m], precision.sum(dim=1), precision @ z)


def forget_likelihood(alpha: Tensor, L: Tensor, Q: Tensor, lam: float) -> tuple[Tensor, Tensor]:
    """The posterior whose likelihood (relative to the prior) is ``lam`` times that of the
    posterior ``alpha : (m,)``, ``P = L L^T`` in Csató–Opper form, whose prior precision at the
    inducing points is ``Q`` (the GP's ``K^-1``).

    With :meth:`Summary.of_posterior`'s ``Lambda = Q P^-1 Q - Q``, ``eta = Q P^-1 alpha``, the
    posterior of ``lam Lambda, lam eta`` has precision ``G = (1 - lam) Q + lam Q P^-1 Q``:

    .. math::  P' = Q G^{-1} Q, \\qquad \\alpha' = \\lambda Q G^{-1} Q P^{-1} \\alpha,

    through ``W = L^-1 Q`` (``Q P^-1 Q = W^T W``). ``Q`` itself is the prior, as in the
    shrinking form ``P <- lam P + (1 - lam) Q``: ``lam = 0`` gives ``P' = Q``, ``alpha' = 0``
    whatever the rounding of ``Q``.

    Parameters
    ----------
    alpha : Tensor, shape (m,)
    L : Tensor, shape (m, m)
        :func:`posterior_cholesky` of the posterior's ``P``.
    Q : Tensor, shape (m, m)
        The prior precision at the inducing points.
    lam : float
        The forgetting, in [0, 1].

    Returns
    -------
    alpha, P : Tensor, shapes (m,), (m, m)
    """
    m = alpha.shape[0]
    W = torch.linalg.solve_triangular(L, Q, upper=False)
    G = (1 - lam) * Q + lam * (W.T @ W)
    chol, _ = jittered_cholesky(0.5 * (G + G.T), float(G.diagonal().abs().mean()))
    white = torch.linalg.solve_triangular(L, alpha[:, None], upper=False)
    solved = torch.cholesky_solve(torch.cat([Q, lam * (W.T @ white)], dim=1), chol)
    P = Q @ solved[:, :m]
    return Q @ solved[:, m], 0.5 * (P + P.T)


def posterior_cholesky(P: Tensor) -> Tensor:
    """``L : (m, m)`` with ``P = L L^T`` (jittered if it needs it): what
    :func:`forget_likelihood` and :meth:`Summary.of_posterior` work through."""
    return jittered_cholesky(P, float(P.diagonal().abs().mean()))[0]


def whitened_prior(L: Tensor, K: Tensor) -> Tensor:
    """``S = L^T K L : (m, m)``, symmetric: the prior covariance in the coordinates ``v`` with
    ``f = K L v`` in which :func:`lagged_forgetting_scores` works."""
    S = L.T @ K @ L
    return 0.5 * (S + S.T)


def lagged_forgetting_scores(
    L: Tensor,
    S: Tensor,
    alpha: Tensor,
    previous: tuple[Tensor, Tensor, Tensor],
    batch: tuple[Tensor, Tensor, Tensor, Tensor],
    noise: float,
    candidates: Tensor,
) -> Tensor:
    """Weighted negative log densities of a batch under, for each candidate ``lambda``, the
    posterior that had forgotten the data older than the previous batch by ``lambda`` before
    absorbing it.

    At the inducing points the current posterior (``alpha``, ``P = L L^T``) has precision
    ``C = Q P^-1 Q``, the prior and the previous batch ``A = Q + Lambda_b``
    (:meth:`Summary.of_data`); the candidate's precision is ``(1 - lambda) A + lambda C``,
    its shift ``(1 - lambda) eta_b + lambda eta_c``: the older data's likelihood times
    ``lambda``. In the coordinates ``v`` with ``f = K L v`` (``S = L^T K L``), ``C`` is the
    identity and ``A`` is ``A' = S + R^T N^-1 R`` with ``R = K_bz L`` the previous batch's
    rows; one eigendecomposition ``A' = U E U^T`` serves every candidate, whose precision is
    ``U ((1 - lambda) E + lambda I) U^T`` (positive definite for ``lambda`` in [0, 1]). The
    shifts are ``R^T N^-1 y_b`` and ``L^-1 alpha``. A point with rows ``k_x`` has
    ``g = k_x L U`` and mean ``sum_j g_j c_j / ((1 - lambda) e_j + lambda)``, variance
    ``gamma + sum_j g_j^2 / ((1 - lambda) e_j + lambda) + noise``, ``gamma`` the basis's
    residual (as the on-line update models it): with ``lambda = 1``, ``k_x alpha`` and
    ``gamma + k_x P k_x^T + noise``, the GP's own prediction.

    Parameters
    ----------
    L, S : Tensor, shape (m, m)
        :func:`posterior_cholesky` of the current posterior's ``P`` and :func:`whitened_prior`
        of ``K``.
    alpha : Tensor, shape (m,)
    previous : (Tensor, Tensor, Tensor)
        The previous batch's rows ``K_bz : (b, m)``, standardised targets ``(b,)`` and noise
        variances ``(b,)`` (each point's noise divided by the number of points it stands for).
    batch : (Tensor, Tensor, Tensor, Tensor)
        The new batch's rows ``K_xz : (n, m)``, residuals ``gamma : (n,)``, standardised
        targets ``(n,)`` and the weight of each point's term ``(n,)``.
    noise : float
    candidates : Tensor, shape (k,)

    Returns
    -------
    Tensor, shape (k,)
    """
    rows_b, y_b, noise_b = previous
    rows, gamma, yn, count = batch
    R = rows_b @ L
    A = S + (R.T / noise_b) @ R
    e, U = torch.linalg.eigh(0.5 * (A + A.T))
    g = rows @ (L @ U)
    base = U.T @ (R.T @ (y_b / noise_b))
    own = U.T @ torch.linalg.solve_triangular(L, alpha[:, None], upper=False)[:, 0]
    lam = candidates[:, None]
    inverse = 1 / ((1 - lam) * e + lam)  # (k, m): the precisions inverted, per direction
    mean = (inverse * ((1 - lam) * base + lam * own)) @ g.T  # (k, n)
    var = gamma + inverse @ g.square().T + noise
    return gaussian_nll(yn, mean, var) @ count


#: The least weight of a retained point (the square root of float64's smallest normal number):
#: a point weighs in with noise ``noise_var / w``, which must stay finite. With strong
#: forgetting and short batches ``forgetting ** age`` underflows to 0 (0.03 per one-point
#: batch, after about 200 batches), the noise and its gradient become inf and NaN, and every
#: refit failed from then on. Above the floor nothing changes.
WEIGHT_FLOOR = math.sqrt(torch.finfo(torch.float64).tiny)


def age_weights(age: Tensor, forgetting: float, decay: Tensor | None = None) -> Tensor:
    """Weights ``forgetting ** age * exp(-decay)`` of points ``age : (n,)`` batches old that
    have lost ``decay : (n,)`` to drift since they arrived (:class:`RetainedWindow`; ``None``:
    none), at least :data:`WEIGHT_FLOOR`."""
    w = torch.as_tensor(forgetting, dtype=torch.float64).pow(age.double())
    if decay is not None:
        w = w * torch.exp(-decay.double())
    return w.clamp_min(WEIGHT_FLOOR)


def gaussian_nll(y: Tensor, mean: Tensor, var: Tensor) -> Tensor:
    """``-log N(y | mean, var)`` elementwise, broadcast over the three (e.g. ``y : (n,)``
    against ``mean, var : (k, n)``, one row per forgetting candidate)."""
    return 0.5 * (torch.log(2 * math.pi * var) + (y - mean).square() / var)


def nlpd(mean: Tensor, var: Tensor, y: Tensor) -> float:
    """Mean negative log predictive density of ``y`` under ``N(mean, var)``, all shape (n,)."""
    var = var.clamp_min(torch.finfo(var.dtype).tiny)
    return float(gaussian_nll(y, mean, var).mean())


def weighted_moments(y: Tensor, w: Tensor) -> tuple[float, float]:
    """Weighted mean and standard deviation of ``y : (n,)`` with weights ``w : (n,)``."""
    w = w / w.sum()
    mean = (w * y).sum()
    return float(mean), float((w * (y - mean).square()).sum().sqrt())


def linear_moments(x: Tensor, y: Tensor, w: Tensor) -> tuple[float, Tensor, float]:
    """Weighted least-squares line through ``(x : (n, d), y : (n,))`` with weights ``w``.

    Returns ``(c, b, s)``: ``y ~ c + b^T x`` with ``b : (d,)``, and ``s`` the weighted standard
    deviation of the residuals. ``b`` is 0 along inputs that do not vary (whose spread is
    below ``1000 eps``, the dtype's, of their mean's size: rounding); along the others a ridge
    of ``1000 eps`` relative to each input's variance, plus 1e-12 of the largest, keeps it
    finite.
    """
    w = w / w.sum()
    x_bar, y_bar = w @ x, w @ y
    xc, yc = x - x_bar, y - y_bar
    cov = (xc * w[:, None]).T @ xc
    eps = 1e3 * torch.finfo(cov.dtype).eps
    varies = torch.diagonal(cov) > (eps * x_bar).square()
    b = torch.zeros_like(x_bar)
    if bool(varies.any()):
        sub = cov[varies][:, varies]
        ridge = eps * torch.diagonal(sub) + 1e-12 * float(sub.abs().max())
        rhs = (xc[:, varies] * w[:, None]).T @ yc
        b[varies] = torch.linalg.solve(sub + torch.diag(ridge), rhs)
    residual = yc - xc @ b
    return float(y_bar - x_bar @ b), b, float((w * residual.square()).sum().sqrt())


class RetainedWindow(nn.Module):
    """The last ``size`` points fed to a GP, oldest first, with the batch each arrived in and
    the log-weight each has lost to drift since (:meth:`age`; the GP's ``drift_forgetting``).

    Parameters
    ----------
    size : int
        Capacity.
    input_dim : int
    """

    x: Tensor
    y: Tensor
    batch: Tensor
    decay: Tensor
    count: Tensor

    def __init__(self, size: int, input_dim: int) -> None:
        super().__init__()
        self.size = int(size)
        self.register_buffer("x", torch.zeros(self.size, input_dim, dtype=torch.float64))
        self.register_buffer("y", torch.zeros(self.size, dtype=torch.float64))
        self.register_buffer("batch", torch.zeros(self.size, dtype=torch.long))
        self.register_buffer("decay", torch.zeros(self.size, dtype=torch.float64))
        self.register_buffer("count", torch.zeros((), dtype=torch.long))

    def append(self, x: Tensor, y: Tensor, batch: int) -> tuple[Tensor, Tensor, Tensor, Tensor]:
        """Keep ``x : (n, d)``, ``y : (n,)`` as arrivals of ``batch`` (no decay yet), dropping
        the oldest.

        Returns
        -------
        x, y, batch, decay : Tensor, shapes (k, d), (k,), (k,), (k,)
            The ``k`` points that no longer fit (copies), oldest first.
        """
        n, kept = min(x.shape[0], self.size), int(self.count)
        keep = min(kept, self.size - n)
        arrived = torch.full((x.shape[0] - n,), batch, dtype=torch.long, device=x.device)
        dropped = (
            torch.cat([self.x[: kept - keep], x[: x.shape[0] - n]]),
            torch.cat([self.y[: kept - keep], y[: y.shape[0] - n]]),
            torch.cat([self.batch[: kept - keep], arrived]),
            torch.cat([self.decay[: kept - keep], self.decay.new_zeros(x.shape[0] - n)]),
        )
        # Copies first: x and y may be views of this window (its own data fed back).
        x, y = x[-n:].clone(), y[-n:].clone()
        for buf in (self.x, self.y, self.batch, self.decay):
            buf[:keep] = buf[kept - keep : kept].clone()
        self.x[keep : keep + n] = x[-n:]
        self.y[keep : keep + n] = y[-n:]
        self.batch[keep : keep + n] = batch
        self.decay[keep : keep + n] = 0
        self.count.fill_(keep + n)
        return dropped

    def age(self, decay: float) -> None:
        """Add ``decay`` to the log-weight every retained point has lost: what came before a
        batch that the data's source drifted by ``decay`` before (each point then weighs
        ``exp(-decay)`` times as much)."""
        self.decay[: int(self.count)] += decay

    def data(self) -> tuple[Tensor, Tensor, Tensor, Tensor]:
        """Retained ``x (n, d)``, ``y (n,)``, ``batch (n,)`` and ``decay (n,)``, oldest first
        (views)."""
        n = int(self.count)
        return self.x[:n], self.y[:n], self.batch[:n], self.decay[:n]
