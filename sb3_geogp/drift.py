"""How far an SB3 policy's actor moved between two feeds of its GP critic: the drift that the
GP's ``drift_forgetting`` turns into forgetting (:meth:`sb3_geogp.SparseOnlineGP.update`).

The returns a GP critic has absorbed are those of earlier policies. How stale they are depends
on how far the policy has moved since, which a fixed forgetting rate cannot know: the same rate
that keeps PPO's critic up with a moving policy discards a fixed policy's returns for nothing
(docs/results.md, session 73). :class:`PolicyDrift` measures the movement as the mean
Kullback-Leibler divergence

.. math::  \\delta = \\frac{1}{|S|} \\sum_{s \\in S}
           \\mathrm{KL}\\big(\\pi_{\\mathrm{old}}(\\cdot \\mid s) \\,\\|\\,
           \\pi_{\\mathrm{new}}(\\cdot \\mid s)\\big)

over states ``S`` of the previous rollout (at most ``max_states``, evenly spaced), ``pi_old``
the actor at the previous feed, ``pi_new`` the actor now: exactly 0 for an actor that has
not changed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.policies import ActorCriticPolicy

from sb3_geogp.adaptation import thinned

#: States of a rollout on which the divergence is measured (an evenly spaced subsample).
DRIFT_STATES = 256


class PolicyDrift:
    """The actor's movement between calls of :meth:`measure` (module docstring).

    Parameters
    ----------
    max_states : int
        Most states of a rollout on which the next call measures the divergence.
    """

    def __init__(self, max_states: int = DRIFT_STATES) -> None:
        self.max_states = int(max_states)
        self._states: th.Tensor | None = None
        self._masks: np.ndarray | None = None
        self._before: Any = None

    @th.no_grad()
    def measure(
        self,
        policy: ActorCriticPolicy,
        observations: np.ndarray,
        action_masks: np.ndarray | None = None,
    ) -> float:
        """The mean divergence from the actor at the previous call to the actor now, on the
        previous call's states (0 at the first call); then remember ``observations``' states
        and the actor's distribution there for the next call.

        Parameters
        ----------
        policy : ActorCriticPolicy
            The policy whose actor is measured (any SB3 actor-critic policy).
        observations : ndarray, shape (n, *obs_shape)
            This rollout's observations as the rollout buffer holds them (flattened over
            steps and environments).
        action_masks : ndarray, shape (n, mask_dims), optional
            MaskablePPO's masks of those observations: the distributions compared are the
            masked ones.

        Returns
        -------
        float
            The mean KL divergence, in nats, >= 0.
        """
        drift = 0.0
        if self._states is not None:
            after = self._distribution(policy, self._states, self._masks)
            drift = float(kl_per_state(self._before, after).mean().clamp_min(0.0))
        index, _ = thinned(len(observations), self.max_states)
        picked = index.numpy()
        # As SB3's rollout buffer hands observations to the policy in train().
        states = th.as_tensor(observations[picked], device=policy.device)
        self._states = states
        self._masks = None if action_masks is None else action_masks[picked]
        self._before = self._distribution(policy, states, self._masks)
        return drift

    @staticmethod
    def _distribution(
        policy: ActorCriticPolicy, states: th.Tensor, masks: np.ndarray | None
    ) -> Any:
        """torch distribution(s) of the actor at ``states`` (a list for MultiDiscrete)."""
        extra = {} if masks is None else {"action_masks": masks}
        return policy.get_distribution(states, **extra).distribution


def drift_keyword(drift: float) -> dict[str, Any]:
    """The keyword argument that passes ``drift`` to an update (``update_critic`` or the GP's
    ``update``): ``{"drift": drift}`` where the policy moved, else none, so that wrappers of
    those updates written before drift (recorders of their batches) keep working wherever the
    policy stands still."""
    return {"drift": drift} if drift else {}


def kl_per_state(before: Any, after: Any) -> th.Tensor:
    """``KL(before || after)`` per state, summed over action dimensions.

    Parameters
    ----------
    before, after : torch.distributions.Distribution, or lists of them (MultiDiscrete)
        Batched over ``n`` states; a Normal or Bernoulli has one column per action dimension.

    Returns
    -------
    Tensor, shape (n,)
    """
    if isinstance(before, list):
        parts = [kl_per_state(b, a) for b, a in zip(before, after, strict=True)]
        return th.stack(parts).sum(dim=0)
    kl = th.distributions.kl_divergence(before, after)
    return kl.reshape(kl.shape[0], -1).sum(dim=1)
