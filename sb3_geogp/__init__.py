"""sb3_geogp: geodesic-kernel sparse on-line Gaussian-process critics for Stable-Baselines3.

``import sb3_geogp`` loads the GP engine only (torch, numpy): :class:`SparseOnlineGP`, the
kernels and the BV graph. The SB3 adapter (:class:`GPActorCriticPolicy`,
:class:`GPValueCallback`), the policy for sb3-contrib's MaskablePPO
(:class:`MaskableGPActorCriticPolicy`, which needs sb3-contrib) and the environments
(:mod:`sb3_geogp.envs`, whose import registers ``sb3_geogp/PaperPendulum-v0`` and the
``sb3_geogp/WallMaze*-v0`` tasks with gymnasium) load on first
use, so the engine works where stable-baselines3, sb3-contrib and gymnasium are not
installed.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import TYPE_CHECKING, Any

from sb3_geogp.adaptation import CHEAP_ADAPTATION, Adaptation
from sb3_geogp.graph import BVGraph
from sb3_geogp.kernels import GeodesicKernel, Kernel, LaplacianKernel, MaternKernel, RBFKernel
from sb3_geogp.sparse_gp import SparseOnlineGP
from sb3_geogp.user_warnings import GPCriticWarning

if TYPE_CHECKING:
    from sb3_geogp import envs
    from sb3_geogp.callbacks import GPValueCallback
    from sb3_geogp.contrib import MaskableGPActorCriticPolicy
    from sb3_geogp.policies import LAGGED_ADAPTATION, GPActorCriticPolicy

__version__ = "0.45.0"

#: Names loaded on first access (PEP 562): they import stable-baselines3, sb3-contrib or
#: gymnasium.
_LAZY = {
    "GPActorCriticPolicy": "sb3_geogp.policies",
    "GPValueCallback": "sb3_geogp.callbacks",
    "LAGGED_ADAPTATION": "sb3_geogp.policies",
    "MaskableGPActorCriticPolicy": "sb3_geogp.contrib",
    "envs": "sb3_geogp.envs",
}


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'sb3_geogp' has no attribute {name!r}")
    module = importlib.import_module(_LAZY[name])
    return module if name == "envs" else getattr(module, name)


def __dir__() -> list[str]:
    # The public names, the lazy ones included, and the engine's modules the docs refer to
    # (sb3_geogp.defaults, .kernels, .adaptation, ...), which importing the engine loaded.
    modules = {name for name, value in globals().items() if isinstance(value, ModuleType)}
    return sorted({*__all__, *(modules - {"importlib"})})


__all__ = [
    "CHEAP_ADAPTATION",
    "LAGGED_ADAPTATION",
    "Adaptation",
    "BVGraph",
    "GPActorCriticPolicy",
    "GPCriticWarning",
    "GPValueCallback",
    "GeodesicKernel",
    "Kernel",
    "LaplacianKernel",
    "MaskableGPActorCriticPolicy",
    "MaternKernel",
    "RBFKernel",
    "SparseOnlineGP",
    "__version__",
    "envs",
]
