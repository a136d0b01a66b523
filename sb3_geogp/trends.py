"""Trends under the sparse GP: a line ``w^T [x, 1]`` that takes the coarse shape of the
targets, moved as each batch arrives, so that the GP models only what it leaves.

Which trend a :class:`~sb3_geogp.SparseOnlineGP` keeps is its ``trend`` option (documented
there, and in docs/method.md, section 4); this module holds how each kind moves with a batch.
The line's coefficients ``w``, shape (d + 1,), are the GP's ``trend_coef`` buffer.
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

#: The kinds of trend: none, refitted to each batch (``"constant"``, ``"linear"``), or moved by
#: the errors of the model on each batch before it absorbs it (:data:`LEVELS`).
TRENDS = ("none", "constant", "linear", "level", "sloped_level", "rising_level")
#: The trends moved by the model's errors on a batch rather than refitted to its targets.
LEVELS = ("level", "sloped_level", "rising_level")
#: Standard errors of a batch's mean error by which ``trend="rising_level"`` must exceed 0
#: to rise: the excess is the step. Two keep noise from ratcheting it up: with bootstrapped
#: targets each rise lifts the next targets, and a level that rose with every positive mean
#: ended far above the returns on A2C CartPole (docs/results.md, session 28).
RISE_THRESHOLD = 2.0
#: Ridge of the trend's lines, per point, on the raw second moments of ``[x, 1]``.
_RIDGE = 1e-3


def value(coef: Tensor, x: Tensor) -> Tensor:
    """The trend ``w^T [x, 1]`` with coefficients ``coef : (d + 1,)`` at ``x : (n, d)``,
    shape (n,)."""
    return _with_ones(x) @ coef


def move(kind: str, coef: Tensor, x: Tensor, y: Tensor, error: Tensor | None) -> None:
    """Move the trend ``kind`` of coefficients ``coef : (d + 1,)``, in place, with the batch of
    inputs ``x : (n, d)`` and targets ``y : (n,)``.

    A refitted trend takes the batch's ridge line (``"linear"``), or its intercept alone with
    the slopes held at 0 (``"constant"``). A level moves by the model's errors on the batch
    before it absorbs it, ``error : (n,)`` (``None`` before the model has a basis: then it
    stays): ``"level"`` by their mean, ``"sloped_level"`` by :func:`error_step`,
    ``"rising_level"`` by :func:`rise`. ``"none"`` stays at 0.
    """
    if kind == "none":
        return
    if kind in LEVELS:
        if error is None:
            return
        if kind == "level":
            coef[-1] += error.mean()
        elif kind == "rising_level":
            coef[-1] += rise(error)
        else:
            coef += error_step(_with_ones(x), error)
        return
    fitted = slice(None) if kind == "linear" else slice(-1, None)
    coef.zero_()
    coef[fitted] = ridge_line(_with_ones(x)[:, fitted], y)


def _with_ones(x: Tensor) -> Tensor:
    """``[x, 1]``: ``x : (n, d)`` with a column of ones, shape (n, d + 1)."""
    return torch.cat([x, torch.ones(x.shape[0], 1, dtype=x.dtype, device=x.device)], dim=1)


def error_step(A: Tensor, error: Tensor) -> Tensor:
    """The sloped level's step for a batch's errors ``error : (n,)`` at ``A = [x, 1] : (n,
    d + 1)``, shape (d + 1,): their ridge line where the lines fit on either half of the batch
    predict the other half's errors better than that half's mean error does, else their mean
    alone: a line that does not carry over between the halves of its own batch is the batch's
    noise. A batch of one point has no halves: its mean error alone."""
    level = torch.zeros_like(A[0])
    level[-1] = error.mean()
    half = error.shape[0] // 2
    if half == 0:
        return level
    first, second = slice(None, half), slice(half, None)
    for fit, held in ((first, second), (second, first)):
        line_sse = (error[held] - A[held] @ ridge_line(A[fit], error[fit])).square().sum()
        if line_sse >= (error[held] - error[fit].mean()).square().sum():
            return level
    return ridge_line(A, error)


def rise(error: Tensor) -> Tensor:
    """The rising level's step from a batch's errors ``error : (n,)``: what their mean exceeds
    :data:`RISE_THRESHOLD` standard errors by, or 0; shape ()."""
    n = error.numel()
    se = error.std() / math.sqrt(n) if n > 1 else torch.zeros_like(error[0])
    return (error.mean() - RISE_THRESHOLD * se).clamp(min=0)


def ridge_line(A: Tensor, y: Tensor) -> Tensor:
    """Ridge coefficients of ``y : (n,)`` on the columns of ``A : (n, p)``, shape (p,), with
    the ridge ``1e-3`` per point on the raw second moments."""
    ridge = _RIDGE * y.shape[0] * torch.eye(A.shape[1], dtype=A.dtype, device=A.device)
    return torch.linalg.solve(A.T @ A + ridge, A.T @ y)
