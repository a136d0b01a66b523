"""sb3_geogp: geodesic-kernel sparse on-line Gaussian-process critics for Stable-Baselines3.

Importing the package also registers its gymnasium environments (``sb3_geogp/PaperPendulum-v0``,
``sb3_geogp/WallMaze-v0``, ``sb3_geogp/WallMazeDiscrete-v0``).
"""

from __future__ import annotations

from sb3_geogp import envs
from sb3_geogp.callbacks import GPValueCallback
from sb3_geogp.graph import BVGraph
from sb3_geogp.kernels import GeodesicKernel, Kernel, LaplacianKernel, RBFKernel
from sb3_geogp.policies import GPActorCriticPolicy
from sb3_geogp.sparse_gp import SparseOnlineGP

__version__ = "0.1.0"

__all__ = [
    "BVGraph",
    "GPActorCriticPolicy",
    "GPValueCallback",
    "GeodesicKernel",
    "Kernel",
    "LaplacianKernel",
    "RBFKernel",
    "SparseOnlineGP",
    "__version__",
    "envs",
]
