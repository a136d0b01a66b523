"""The basis matrices of a sparse GP's current state, each formed on first use and kept while
the state leaves it valid.

A batch of a few points changes ``alpha`` and ``P`` but seldom the basis, so products such as
``K P K`` or ``P``'s Cholesky factor are worth keeping between the steps of an update; one
that changes the basis changes the Gram matrix by one row, in O(m). The GP reports each change
of its state and the cache drops exactly the products that change invalidates.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import torch
from torch import Tensor

from sb3_geogp.adaptation import posterior_cholesky, whitened_prior

if TYPE_CHECKING:
    from sb3_geogp.sparse_gp import SparseOnlineGP


class PosteriorMatrices:
    """:class:`~sb3_geogp.kernels.BasisMatrices` of a GP's current state, each formed on first
    use.

    The GP keeps one and reports every change of its state; each report drops exactly the
    products that it invalidates.
    """

    def __init__(self, gp: SparseOnlineGP) -> None:
        self._gp = gp
        self._values: dict[str, Tensor] = {}

    @property
    def _m(self) -> int:
        return self._gp.n_basis

    def _get(self, name: str, compute: Callable[[], Tensor]) -> Tensor:
        if name not in self._values:
            self._values[name] = compute()
        return self._values[name]

    def has(self, name: str) -> bool:
        return name in self._values

    def posterior_changed(self) -> None:
        """``alpha`` and ``P`` changed."""
        for name in ("K_alpha", "KPK", "P_cholesky", "S"):
            self._values.pop(name, None)

    def Q_changed(self) -> None:
        """``Q`` (or the nuggets) changed."""
        for name in ("KQK", "least_novelty", "S", "K_nugget"):
            self._values.pop(name, None)

    def basis_grew(self, k: Tensor, variance: Tensor) -> None:
        """A BV with Gram row ``k : (m,)`` was appended (call before the count grows)."""
        K = self._values.get("K")
        self._values = {}
        if K is not None:
            m = K.shape[0]
            grown = K.new_empty(m + 1, m + 1)
            grown[:m, :m] = K
            grown[m, :m] = grown[:m, m] = k
            grown[m, m] = variance
            self._values["K"] = grown

    def basis_shrank(self, keep: Tensor) -> None:
        """Only the BVs ``keep`` (indices, in order) remain (call before the count drops)."""
        K = self._values.get("K")
        self._values = {}
        if K is not None:
            self._values["K"] = K[keep[:, None], keep]

    @property
    def alpha(self) -> Tensor:
        return self._gp.alpha[: self._m]

    @property
    def Q(self) -> Tensor:
        return self._gp.Q[: self._m, : self._m]

    @property
    def P(self) -> Tensor:
        return self._gp.P[: self._m, : self._m]

    @property
    def z(self) -> Tensor:
        """Basis inputs in lengthscale units, shape (m, d)."""
        return self._get("z", lambda: self._gp.kernel.scale(self._gp.bv_x[: self._m]))

    @property
    def K(self) -> Tensor:
        return self._get("K", lambda: self._gp.kernel.gram(self.z))

    @property
    def K_nugget(self) -> Tensor:
        """``K`` with the nuggets on its diagonal, ``K_zz`` of the posterior."""
        return self._get("K_nugget", lambda: self.K + torch.diag(self._gp.nugget[: self._m]))

    @property
    def K_alpha(self) -> Tensor:
        return self._get("K_alpha", lambda: self.K @ self.alpha)

    @property
    def KQK(self) -> Tensor:
        return self._get("KQK", lambda: kqk(self.K, self.Q, self._gp.nugget[: self._m]))

    @property
    def KPK(self) -> Tensor:
        return self._get("KPK", lambda: self.K @ self.P @ self.K)

    @property
    def P_cholesky(self) -> Tensor:
        """:func:`~sb3_geogp.adaptation.posterior_cholesky` of ``P``, in float64 whatever the
        state's dtype, shape (m, m): one factorisation per state serves the snapshot, the
        lagged scores and the lagged forgetting of a batch."""
        # Row-major, as LAPACK's column-major factor is not: the solves then round as they did
        # before the factor was shared (0.13), and training runs repeat bit for bit.
        return self._get("P_cholesky", lambda: posterior_cholesky(self.P.double()).contiguous())

    @property
    def P_factor(self) -> tuple[Tensor, Tensor]:
        """:attr:`P_cholesky` ``L`` and ``S = L^T K L`` (:func:`~sb3_geogp.adaptation.
        whitened_prior`, ``K`` with the nuggets), float64, shapes (m, m)."""
        L = self.P_cholesky

        def whitened() -> Tensor:
            return whitened_prior(L, self.K_nugget.double())

        return L, self._get("S", whitened)

    @property
    def least_novelty(self) -> Tensor:
        """Smallest relative novelty of a BV given the others, ``min_i 1 / (Q_ii k_ii)``."""

        def least() -> Tensor:
            prior = self._gp.kernel.variance + self._gp.nugget[: self._m]
            return (1.0 / (torch.diagonal(self.Q) * prior)).min()

        return self._get("least_novelty", least)


def kqk(K: Tensor, Q: Tensor, nugget: Tensor) -> Tensor:
    """``K Q K`` for ``Q = (K + N)^{-1}``, ``N = diag(nugget)``: ``K - N + N Q N``, in O(m^2).

    Nuggets are rare (a near-duplicate BV), and without any ``K Q K = K``.
    """
    if not bool(nugget.any()):
        return K
    return K - torch.diag(nugget) + nugget[:, None] * Q * nugget
