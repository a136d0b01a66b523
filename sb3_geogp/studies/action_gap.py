"""Does a critic rank the actions? True action gaps on CartPole against a critic's estimate.

An actor-critic's actor learns from advantages, and a critic ``V`` enters them through the TD
error ``delta = r + gamma V(s') - V(s)``. Between the two actions of a state ``s`` it therefore
contributes the *one-step gap*

.. math::  \\hat g(s) = \\gamma \\big(V(s'_1) - V(s'_0)\\big),
           \\qquad V(s') = 0 \\text{ where } s' \\text{ is terminal},

to the advantage difference (CartPole's reward is 1 for either action). The explained
variance of the critic on its value targets does not measure this: a critic can fit returns
well yet order the two successor states of a state wrongly, if its value varies across them
less than its error does.

The reference is the *true gap* ``g(s) = Q(s, 1) - Q(s, 0)`` under the current stochastic
policy, ``Q(s, a) = r + gamma E[G(s'_a)]``, with ``G`` the discounted return of the policy from
``s'_a`` (:func:`action_gaps`): CartPole's dynamics are deterministic and its observation is its
state, so ``s'_a`` is exact and ``G`` is estimated by rollouts of :func:`cartpole_step` (vectorised
numpy, the gymnasium equations), ``n_rollouts`` per successor with common random numbers (the
same uniforms drive the policy's draws after either action) and cut after ``horizon`` steps,
without a time limit, as the critic's targets bootstrap at truncation.

:func:`gap_scores` compares ``g`` and ``\\hat g``: the share of *decisive* states (``|g|`` above
two standard errors) whose sign the critic gets right (0.5 is chance), the same share weighted
by ``|g|``, and the correlation.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sb3_geogp.toolbox.stats import correlation

#: CartPole-v1's constants (gymnasium ``CartPoleEnv``).
GRAVITY, MASS_CART, MASS_POLE, HALF_LENGTH, FORCE, TAU = 9.8, 1.0, 0.1, 0.5, 10.0, 0.02
X_LIMIT, THETA_LIMIT = 2.4, 12 * 2 * math.pi / 360

#: ``p(s) -> P(action = 1 | s)`` for a batch of states, shape (n, 4) -> (n,).
ActionProbability = Callable[[np.ndarray], np.ndarray]
#: ``V(s)`` for a batch of states, shape (n, 4) -> (n,).
ValueFn = Callable[[np.ndarray], np.ndarray]


def cartpole_step(state: np.ndarray, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One CartPole-v1 step (explicit Euler, as gymnasium) for a batch of states.

    Parameters
    ----------
    state : ndarray, shape (n, 4)
        ``(x, x_dot, theta, theta_dot)``.
    action : ndarray of int, shape (n,)
        0 pushes left, 1 right.

    Returns
    -------
    next_state : ndarray, shape (n, 4), float64
    terminated : ndarray of bool, shape (n,)
        The cart left the track or the pole fell past 12 degrees.
    """
    x, x_dot, theta, theta_dot = np.asarray(state, dtype=np.float64).T
    force = np.where(np.asarray(action) == 1, FORCE, -FORCE)
    cos, sin = np.cos(theta), np.sin(theta)
    total = MASS_CART + MASS_POLE
    pole_moment = MASS_POLE * HALF_LENGTH
    temp = (force + pole_moment * theta_dot**2 * sin) / total
    theta_acc = (GRAVITY * sin - cos * temp) / (
        HALF_LENGTH * (4.0 / 3.0 - MASS_POLE * cos**2 / total)
    )
    x_acc = temp - pole_moment * theta_acc * cos / total
    nxt = np.stack(
        [
            x + TAU * x_dot,
            x_dot + TAU * x_acc,
            theta + TAU * theta_dot,
            theta_dot + TAU * theta_acc,
        ],
        axis=1,
    )
    terminated = (np.abs(nxt[:, 0]) > X_LIMIT) | (np.abs(nxt[:, 2]) > THETA_LIMIT)
    return nxt, terminated


def policy_returns(
    p_right: ActionProbability,
    states: np.ndarray,
    alive: np.ndarray,
    gamma: float,
    horizon: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """Discounted returns of the stochastic policy from each state, cut after ``horizon`` steps.

    Parameters
    ----------
    p_right : callable
        Probability of action 1 for a batch of states.
    states : ndarray, shape (n, 4)
    alive : ndarray of bool, shape (n,)
        ``False`` for a terminal state: its return is 0.
    gamma : float
    horizon : int
    rng : numpy Generator
        Draws one uniform per state and step: the ``k``-th state of two calls with equally
        seeded generators sees the same uniforms (common random numbers).

    Returns
    -------
    ndarray, shape (n,)
        ``sum_t gamma^t r_t`` with ``r_t = 1`` while the episode lasts.
    """
    s, alive = np.array(states, dtype=np.float64), np.array(alive, dtype=bool)
    total, discount = np.zeros(len(s)), 1.0
    for _ in range(horizon):
        if not alive.any():
            break
        action = (rng.random(len(s)) < p_right(s)).astype(np.int64)
        s, terminated = cartpole_step(s, action)
        total += discount * alive
        discount *= gamma
        alive &= ~terminated
    return total


@dataclass(frozen=True)
class GapEstimate:
    """Monte Carlo action gaps at a batch of states (:func:`action_gaps`).

    Attributes
    ----------
    successors : ndarray, shape (2, n, 4)
        ``s'_a`` for ``a = 0, 1``.
    terminal : ndarray of bool, shape (2, n)
    gap : ndarray, shape (n,)
        Estimated ``Q(s, 1) - Q(s, 0)``.
    stderr : ndarray, shape (n,)
        Its standard error over the rollouts.
    """

    successors: np.ndarray
    terminal: np.ndarray
    gap: np.ndarray
    stderr: np.ndarray

    def critic_gap(self, value: ValueFn, gamma: float) -> np.ndarray:
        """``gamma (V(s'_1) - V(s'_0))``, with ``V = 0`` at terminal successors; shape (n,)."""
        v = [np.where(self.terminal[a], 0.0, value(self.successors[a])) for a in (0, 1)]
        return gamma * (v[1] - v[0])


def action_gaps(
    p_right: ActionProbability,
    states: np.ndarray,
    gamma: float,
    n_rollouts: int = 16,
    horizon: int = 250,
    seed: int = 0,
) -> GapEstimate:
    """True action gaps ``Q(s, 1) - Q(s, 0)`` under the policy, by Monte Carlo.

    Parameters
    ----------
    p_right : callable
        The policy: probability of action 1 for a batch of states.
    states : ndarray, shape (n, 4)
    gamma : float
    n_rollouts : int
        Rollouts per successor state (at least 2, for the standard error).
    horizon : int
        Steps per rollout (the tail ``gamma^horizon / (1 - gamma)`` is left out of both ``Q``).
    seed : int
        Seed of the uniforms, shared by the two actions' rollouts.

    Returns
    -------
    GapEstimate
    """
    if n_rollouts < 2:
        raise ValueError(f"n_rollouts must be >= 2 for a standard error, got {n_rollouts}")
    states = np.asarray(states, dtype=np.float64)
    n = len(states)
    successors, terminal, q = [], [], []
    for action in (0, 1):
        nxt, done = cartpole_step(states, np.full(n, action))
        rng = np.random.default_rng(seed)
        g = policy_returns(
            p_right,
            np.repeat(nxt, n_rollouts, axis=0),
            ~np.repeat(done, n_rollouts),
            gamma,
            horizon,
            rng,
        )
        successors.append(nxt)
        terminal.append(done)
        q.append(1.0 + gamma * g.reshape(n, n_rollouts))
    diff = q[1] - q[0]
    return GapEstimate(
        successors=np.stack(successors),
        terminal=np.stack(terminal),
        gap=diff.mean(axis=1),
        stderr=diff.std(axis=1, ddof=1) / math.sqrt(n_rollouts),
    )


def gap_scores(gap: np.ndarray, stderr: np.ndarray, estimate: np.ndarray) -> dict[str, float]:
    """How well ``estimate`` orders the actions that ``gap`` orders.

    Parameters
    ----------
    gap, stderr : ndarray, shape (n,)
        True gaps and their standard errors (:class:`GapEstimate`).
    estimate : ndarray, shape (n,)
        A critic's gaps (:meth:`GapEstimate.critic_gap`).

    Returns
    -------
    dict
        ``sign_accuracy``: share of the decisive states (``|gap| > 2 stderr``) where the signs
        agree (NaN if none is decisive); ``weighted_sign_accuracy``: the share of ``sum |gap|``
        on states where they agree (NaN if every gap is 0); ``correlation``: Pearson's (NaN if
        either is constant); ``n_decisive``.
    """
    gap, stderr, estimate = (np.asarray(a, dtype=np.float64) for a in (gap, stderr, estimate))
    agree = np.sign(estimate) == np.sign(gap)
    decisive = np.abs(gap) > 2 * stderr
    weight = np.abs(gap)
    return dict(
        sign_accuracy=float(agree[decisive].mean()) if decisive.any() else math.nan,
        weighted_sign_accuracy=float((weight * agree).sum() / weight.sum())
        if weight.sum() > 0
        else math.nan,
        correlation=correlation(gap, estimate),
        n_decisive=int(decisive.sum()),
    )
