"""Kernels of the Euclidean distance ``r = ||(x - x') / l||``: RBF, Laplacian and Matérn."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

from torch import Tensor

from sb3_geogp.kernels.base import CorrelationFn, Kernel, Profile, distances


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


class MaternKernel(EuclideanKernel):
    """Matérn kernel on Euclidean distance, of smoothness ``nu`` in {1/2, 3/2, 5/2}.

    .. math::

        k(x, x') = \\sigma_f^2 \\rho_\\nu(r), \\quad r = \\|(x - x') / l\\|, \\qquad
        \\rho_{1/2} = e^{-r}, \\quad
        \\rho_{3/2} = (1 + \\sqrt3 r) e^{-\\sqrt3 r}, \\quad
        \\rho_{5/2} = (1 + \\sqrt5 r + \\tfrac53 r^2) e^{-\\sqrt5 r}

    (Rasmussen & Williams 2006, eq. 4.17). Its sample paths are ``ceil(nu) - 1`` times
    differentiable: between :class:`LaplacianKernel` (``nu = 1/2``, the same covariance) and
    :class:`RBFKernel` (the limit ``nu -> inf``). As in GPyTorch's ``MaternKernel`` the
    lengthscale divides the distance, so ``l`` means the same for every ``nu``.

    Parameters
    ----------
    nu : {0.5, 1.5, 2.5}
        Smoothness.
    lengthscale : float, sequence of float or None
        ``l``: scalar or one per input dimension; ``None`` = from the input bounds where the
        GP is given them, else chosen from the first batch.
    variance : float
        ``sigma_f^2`` (standardised target units).
    """

    #: ``nu`` -> profile (a key of :data:`~sb3_geogp.kernels.base.PROFILES`).
    NU: ClassVar[dict[float, Profile]] = {0.5: "laplacian", 1.5: "matern32", 2.5: "matern52"}

    def __init__(
        self,
        nu: float = 2.5,
        lengthscale: float | Sequence[float] | None = None,
        variance: float = 1.0,
    ) -> None:
        if isinstance(nu, bool) or nu not in self.NU:
            raise ValueError(
                f"nu must be one of {sorted(self.NU)} (the Matérn smoothnesses with a closed "
                f"form), got {nu!r}"
            )
        super().__init__(lengthscale, variance)
        self.nu = float(nu)
        self.profile_name = self.NU[self.nu]

    def options(self) -> dict[str, Any]:
        return {"nu": self.nu}
