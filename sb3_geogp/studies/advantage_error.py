"""How far a critic's advantages are from the advantages of the exact value function.

PPO's actor learns from GAE advantages (Schulman et al. 2016), in which a critic ``V`` enters
through the TD errors

.. math::  \\delta_t = r_t + \\gamma V(s_{t+1}) (1 - d_{t+1}) - V(s_t), \\qquad
           A_t = \\delta_t + \\gamma \\lambda (1 - d_{t+1}) A_{t+1},

``d_{t+1} = 1`` where a new episode starts at ``t + 1`` (:func:`gae`, SB3's recursion). A critic
that fits the returns well on average can still give advantages that order the actions of a
rollout badly. The reference here is the advantage that the rollout's rewards give with the
*policy's true value function* ``V^pi`` in place of ``V``, estimated by Monte Carlo
(:func:`~sb3_geogp.studies.value_ceiling.policy_returns`): the paper's pendulum
(:mod:`sb3_geogp.envs.pendulum`) and the wall mazes have deterministic dynamics and
observations that are their states, so every rollout state can be restarted exactly; only the
policy's noise is sampled.

:func:`advantage_scores` compares a critic's advantages with the reference on one rollout:
the correlation (PPO standardises advantages per minibatch, so their scale does not reach the
actor), and the root-mean-square error of the critic's values at the rollout's states. It also
takes both apart (since 0.35.5), to say why two critics whose values are equally near ``V^pi``
can give advantages that are not:

- the value error ``e = V - V^pi`` splits into its mean over the rollout (a constant shift,
  which moves every advantage alike) and its spread, ``rmse^2 = bias^2 + spread^2``;
- regressed on the reference, ``A = b A^pi + eta`` with ``eta`` uncorrelated with ``A^pi``, the
  critic's advantages keep a share ``b`` (the slope) of the reference and add a residual of
  relative size ``rho = sd(eta) / sd(A^pi)``; their correlation is ``b / sqrt(b^2 + rho^2)``;
- GAE is linear in ``V``, so ``A - A^pi`` is the advantage of the error ``e`` alone; its size
  over the error's spread, the *gain*, says how much of ``e`` reaches the advantages. For
  ``gamma = 0.9`` and ``lambda = 0.95`` it is ``(1 - gamma) / (1 - gamma lambda) = 0.69`` for an
  error that changes only from trajectory to trajectory (far from their ends) and
  ``sqrt(1 + gamma^2 (1 - lambda)^2 / (1 - gamma^2 lambda^2)) = 1.004`` for one drawn
  independently at every step.
"""

from __future__ import annotations

import numpy as np

from sb3_geogp.toolbox.stats import correlation


def gae(
    rewards: np.ndarray,
    values: np.ndarray,
    episode_starts: np.ndarray,
    last_values: np.ndarray,
    last_dones: np.ndarray,
    gamma: float,
    gae_lambda: float,
) -> np.ndarray:
    """GAE advantages of a rollout, with SB3's recursion
    (``RolloutBuffer.compute_returns_and_advantage``).

    Parameters
    ----------
    rewards, values, episode_starts : ndarray, shape (T, n_envs)
        Step ``t``'s reward, the critic's value of its state, and whether an episode starts
        at it.
    last_values : ndarray, shape (n_envs,)
        The critic's value of the state after the rollout's last step.
    last_dones : ndarray, shape (n_envs,)
        Whether an episode starts at that state.
    gamma, gae_lambda : float

    Returns
    -------
    ndarray, shape (T, n_envs)
    """
    rewards, values = np.asarray(rewards, np.float64), np.asarray(values, np.float64)
    starts = np.asarray(episode_starts, np.float64)
    advantages = np.zeros_like(values)
    running = np.zeros(values.shape[1])
    next_values = np.asarray(last_values, np.float64)
    next_alive = 1.0 - np.asarray(last_dones, np.float64)
    for t in reversed(range(values.shape[0])):
        delta = rewards[t] + gamma * next_values * next_alive - values[t]
        running = delta + gamma * gae_lambda * next_alive * running
        advantages[t] = running
        next_values, next_alive = values[t], 1.0 - starts[t]
    return advantages


def advantage_scores(
    reference: np.ndarray, advantages: np.ndarray, true_values: np.ndarray, values: np.ndarray
) -> dict[str, float]:
    """How close a critic's advantages and values are to the reference ones on one rollout,
    and the parts of the difference (the module's docstring).

    Parameters
    ----------
    reference, advantages : ndarray, shape (n,)
        :func:`gae` with ``V^pi`` and with the critic, on the same rollout.
    true_values, values : ndarray, shape (n,)
        ``V^pi`` and the critic's values at the rollout's states.

    Returns
    -------
    dict
        - ``correlation`` of the advantages (Pearson's; NaN if either is constant: after PPO's
          standardisation the two differ by ``sqrt(2 (1 - correlation))`` in root mean square);
        - ``value_rmse``, ``value_bias`` (the error's mean) and ``value_spread`` (its standard
          deviation);
        - ``advantage_slope`` ``b`` and ``advantage_residual`` ``rho`` (NaN where the
          reference is constant), so that ``correlation = b / sqrt(b^2 + rho^2)``;
        - ``error_gain``: ``sd(A - A^pi) / value_spread`` (NaN where the error is constant).
    """
    reference, advantages = np.asarray(reference, float), np.asarray(advantages, float)
    error = np.asarray(values, float) - np.asarray(true_values, float)
    miss = advantages - reference
    spread, signal = float(error.std()), float(reference.std())
    slope = residual = gain = float("nan")
    if signal > 0:
        centred = reference - reference.mean()
        slope = float(np.mean(centred * (advantages - advantages.mean()))) / signal**2
        residual = float(np.std(advantages - slope * reference)) / signal
    if spread > 0:
        gain = float(miss.std()) / spread
    return dict(
        correlation=correlation(reference, advantages),
        value_rmse=float(np.sqrt(np.mean(error**2))),
        value_bias=float(error.mean()),
        value_spread=spread,
        advantage_slope=slope,
        advantage_residual=residual,
        error_gain=gain,
    )
