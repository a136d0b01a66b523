"""Shared fixtures of the test suite."""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np
import pytest
import torch

from sb3_geogp.toolbox.streams import pendulum_rollouts

# The engine works on small tensors: one intra-op thread is an order of magnitude faster than
# several on a busy machine.
torch.set_num_threads(1)

Rollouts = tuple[np.ndarray, np.ndarray, np.ndarray]


@functools.cache
def _pendulum_cached(n: int, seed: int) -> Rollouts:
    return pendulum_rollouts(n, seed)


@pytest.fixture(scope="session")
def pendulum() -> Callable[[int, int], Rollouts]:
    """``pendulum(n, seed) -> (obs (n, 3), returns (n,), starts (n,))``, copies of cached runs."""

    def make(n: int, seed: int) -> Rollouts:
        obs, returns, starts = _pendulum_cached(n, seed)
        return obs.copy(), returns.copy(), starts.copy()

    return make


def _shepard_dense(dist: np.ndarray, k: int) -> np.ndarray:
    """Modified Shepard weights as a dense (n, m) matrix, straight from the documented formula.

    ``w_i ∝ ((R - d_i)_+ / (R d_i))^2`` over the ``k`` nearest, ``R`` the distance to the next
    one (``w_i ∝ d_i^-2`` when there is none); one-hot on a basis vector at distance 0.
    """
    n, m = dist.shape
    k = min(k, m)
    order = np.argsort(dist, axis=1, kind="stable")
    near = np.take_along_axis(dist, order[:, :k], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        if m > k:
            radius = np.take_along_axis(dist, order[:, k : k + 1], axis=1)
            raw = (np.maximum(radius - near, 0.0) / (radius * near)) ** 2
        else:
            raw = near**-2.0
    raw[near[:, 0] <= 1e-12] = np.eye(k)[0]
    out = np.zeros((n, m))
    np.put_along_axis(out, order[:, :k], raw / raw.sum(axis=1, keepdims=True), axis=1)
    return out


@pytest.fixture(scope="session")
def shepard_dense() -> Callable[[np.ndarray, int], np.ndarray]:
    """Reference Shepard weights ``shepard_dense(dist (n, m), k) -> (n, m)``."""
    return _shepard_dense
