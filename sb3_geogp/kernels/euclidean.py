"""Kernels of the Euclidean distance ``r = ||(x - x') / l||``: RBF and Laplacian."""

from __future__ import annotations

from torch import Tensor

from sb3_geogp.kernels.base import CorrelationFn, Kernel, distances


class EuclideanKernel(Kernel):
    """A profile of the Euclidean distance ``r = ||(x - x') / l||`` (rows are direct).

    The evidence fit has one lengthscale factor per input dimension.
    """

    def gram(self, z: Tensor) -> Tensor:
        return self(distances(z, z))

    def cross(self, x: Tensor, z: Tensor) -> Tensor:
        return self(distances(x, z))

    def correlation_fn(self, x: Tensor, z: Tensor) -> tuple[int, CorrelationFn]:
        def correlations(log_factor: Tensor) -> tuple[Tensor, Tensor]:
            ls = self.lengthscale * log_factor.exp()
            zs = z / ls
            return self.profile(distances(x / ls, zs)), self.profile(distances(zs, zs))

        return x.shape[1], correlations


class RBFKernel(EuclideanKernel):
    """Gaussian kernel on Euclidean distance.

    .. math::  k(x, x') = \\sigma_f^2 \\exp\\Big(-\\tfrac12 \\sum_j (x_j - x'_j)^2 / l_j^2\\Big)

    Parameters
    ----------
    lengthscale : float, sequence of float or None
        ``l``: scalar or one per input dimension; ``None`` = from the input bounds where the
        GP is given them, else chosen from the first batch.
    variance : float
        ``sigma_f^2`` (standardised target units).
    """

    profile_name = "gaussian"


class LaplacianKernel(EuclideanKernel):
    """Laplacian (exponential) kernel on Euclidean distance.

    .. math::  k(x, x') = \\sigma_f^2 \\exp\\big(-\\|(x - x') / l\\|\\big)

    The geodesic kernel's default profile without the graph: the control that separates the
    effect of the graph distance from that of the profile (docs/wall_experiment.md,
    docs/reproduction.md). With ``novelty_tol=0.1`` it is
    :class:`~sb3_geogp.GPActorCriticPolicy`'s default critic under PPO since 0.6
    (:data:`sb3_geogp.policies.DEFAULT_KERNEL`).

    Parameters
    ----------
    lengthscale : float, sequence of float or None
        ``l``: scalar or one per input dimension; ``None`` = from the input bounds where the
        GP is given them, else chosen from the first batch.
    variance : float
        ``sigma_f^2`` (standardised target units).
    """

    profile_name = "laplacian"
