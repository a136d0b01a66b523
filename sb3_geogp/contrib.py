"""GP critic policies for sb3-contrib's algorithms (needs ``pip install sb3_geogp[contrib]``).

sb3-contrib's TRPO takes :class:`~sb3_geogp.GPActorCriticPolicy` itself; MaskablePPO needs a
policy built on its ``MaskableActorCriticPolicy``: :class:`MaskableGPActorCriticPolicy`.
"""

from __future__ import annotations

from sb3_contrib import MaskablePPO
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from stable_baselines3.common.base_class import BaseAlgorithm

from sb3_geogp.policies import GPCriticMixin


# mypy sees the mixin as an ActorCriticPolicy, whose distribution methods differ from the
# maskable policy's; at run time the mixin defines none of them.
class MaskableGPActorCriticPolicy(GPCriticMixin, MaskableActorCriticPolicy):  # type: ignore[misc]
    """MaskablePPO's actor-critic policy with a sparse on-line (geodesic) GP as the critic.

    Use it as ``MaskablePPO(MaskableGPActorCriticPolicy, env,
    policy_kwargs=dict(gp_kwargs=...))`` and pass ``callback=GPValueCallback()`` to ``learn``.
    Everything about the critic (parameters, ``net_arch``, errors, attributes) is as for
    :class:`~sb3_geogp.GPActorCriticPolicy`; the actor is sb3-contrib's maskable actor
    (Discrete, MultiDiscrete or MultiBinary actions), and ``forward`` and ``evaluate_actions``
    take its ``action_masks``.
    """

    @classmethod
    def supported_algorithms(cls) -> tuple[type[BaseAlgorithm], ...]:
        """sb3-contrib's MaskablePPO."""
        return (MaskablePPO,)
