"""The kernel interface of :class:`~sb3_geogp.SparseOnlineGP` and the two forms of kernel rows.

Every kernel of the package is stationary in a distance ``r`` measured in lengthscale units,

.. math::  k(x, x') = \\sigma_f^2 \\, \\rho\\big(r(x, x')\\big),

and the GP talks to it only through :class:`Kernel`'s small interface:

* rows over the basis: :meth:`Kernel.gram` (among basis vectors), :meth:`Kernel.rows`
  (prediction), :meth:`Kernel.novelty_rows` (screening) and
  :meth:`Kernel.insertion_rows` (points about to become basis vectors);
* the basis life cycle: :meth:`Kernel.on_insert`, :meth:`Kernel.on_delete`,
  :meth:`Kernel.start_trajectory`, which a kernel with state of its own over the basis (the
  geodesic kernel's graph) follows, and :meth:`Kernel.rescale` after a lengthscale fit;
* the evidence fit: :meth:`Kernel.correlation_fn`, correlations from points to the basis and
  among basis vectors as functions of log lengthscale factors.

A prediction row is either a dense row ``k(x, b_1..b_m)`` (:class:`DenseRows`) or a mixture of
basis rows, ``k(x, .) = sum_j w_j K_b[idx_j]`` (:class:`MixedRows`); each form computes the
quadratic forms the GP needs in its own cheapest way from the :class:`BasisMatrices` of the
current posterior, so the GP runs one algebra whatever the kernel.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Literal, NamedTuple, Protocol

import torch
from torch import Tensor, nn

from sb3_geogp.graph import BVGraph
from sb3_geogp.options import check_number, check_same_options

#: ``log_factor : (n_factors,) -> (R_xz (n, m), R_zz (m, m))`` (see Kernel.correlation_fn).
CorrelationFn = Callable[[Tensor], tuple[Tensor, Tensor]]


class HasGram(Protocol):
    """Holds the basis Gram matrix ``K : (m, m)`` (all that :meth:`MixedRows.dense` reads)."""

    @property
    def K(self) -> Tensor: ...


class Gram(NamedTuple):
    """A basis Gram matrix on its own, for dense rows outside the GP (checks and plots)."""

    K: Tensor


class BasisMatrices(HasGram, Protocol):
    """What rows need of the GP's posterior over ``m`` basis vectors (computed on demand).

    ``alpha`` (m,), ``Q = (K_b + N)^{-1}`` and ``P = Q + C`` (m, m) of the Csató–Opper
    posterior; ``K`` the basis Gram matrix; ``K_alpha = K alpha``; ``KQK = K Q K``;
    ``KPK = K P K``.
    """

    @property
    def alpha(self) -> Tensor: ...
    @property
    def Q(self) -> Tensor: ...
    @property
    def P(self) -> Tensor: ...
    @property
    def K_alpha(self) -> Tensor: ...
    @property
    def KQK(self) -> Tensor: ...
    @property
    def KPK(self) -> Tensor: ...
    def has(self, name: str) -> bool:
        """Whether ``name`` is already computed (so using it costs nothing)."""
        ...


class DenseRows(NamedTuple):
    """Kernel rows given entry by entry, ``rows : Tensor, shape (n, m)``."""

    rows: Tensor

    def dense(self, basis: HasGram) -> Tensor:
        """The rows, shape (n, m)."""
        return self.rows

    def take(self, index: slice) -> DenseRows:
        """The rows ``index`` of these."""
        return DenseRows(self.rows[index])

    def mean(self, basis: BasisMatrices) -> Tensor:
        """``k_x^T alpha``, shape (n,)."""
        return self.rows @ basis.alpha

    def kqk(self, basis: BasisMatrices) -> Tensor:
        """``k_x^T Q k_x``, shape (n,)."""
        return quad(self.rows, basis.Q)

    def kpk(self, basis: BasisMatrices) -> Tensor:
        """``k_x^T P k_x``, shape (n,)."""
        return quad(self.rows, basis.P)


class MixedRows(NamedTuple):
    """Kernel rows as mixtures of basis rows, ``k(x_i, .) = sum_j w_ij K_b[idx_ij]``.

    The quadratic forms then need only ``(m, m)`` products of the posterior, computed once per
    state, and cost O(n k^2) per batch instead of O(n m^2).

    Attributes
    ----------
    idx : Tensor, shape (n, k), long
        Basis rows mixed.
    w : Tensor, shape (n, k)
        Their weights.
    """

    idx: Tensor
    w: Tensor

    def dense(self, basis: HasGram) -> Tensor:
        """The rows, shape (n, m), from the basis Gram matrix."""
        return torch.einsum("nk,nkm->nm", self.w, basis.K[self.idx])

    def take(self, index: slice) -> MixedRows:
        """The rows ``index`` of these."""
        return MixedRows(self.idx[index], self.w[index])

    def mean(self, basis: BasisMatrices) -> Tensor:
        """``k_x^T alpha = sum_j w_j (K alpha)[idx_j]``, shape (n,)."""
        return (self.w * basis.K_alpha[self.idx]).sum(dim=1)

    def kqk(self, basis: BasisMatrices) -> Tensor:
        """``k_x^T Q k_x = w^T (K Q K)[idx, idx] w``, shape (n,)."""
        return gathered_quad(self.idx, self.w, basis.KQK)

    def kpk(self, basis: BasisMatrices) -> Tensor:
        """``k_x^T P k_x``, shape (n,).

        Through ``K P K`` (O(m^3) once per state) when it exists or the batch is at least as
        large as the basis; for fewer points, O(n m^2) on the dense rows is cheaper.
        """
        if basis.has("KPK") or self.idx.shape[0] >= basis.K.shape[0]:
            return gathered_quad(self.idx, self.w, basis.KPK)
        return quad(self.dense(basis), basis.P)


Rows = DenseRows | MixedRows


#: Names of the correlation profiles of :data:`PROFILES`.
Profile = Literal["laplacian", "matern32", "matern52", "gaussian"]
_SQRT3 = math.sqrt(3.0)
_SQRT5 = math.sqrt(5.0)
#: Correlation profiles ``rho(r)`` of a distance ``r`` in lengthscale units, ``rho(0) = 1``:
#: the Matérn family from ``nu = 1/2`` (``exp(-r)``) through ``3/2`` and ``5/2`` to its limit,
#: the Gaussian ``exp(-r^2 / 2)`` (Rasmussen & Williams 2006, eq. 4.17).
PROFILES: dict[str, Callable[[Tensor], Tensor]] = {
    "laplacian": lambda r: torch.exp(-r),
    "matern32": lambda r: (1.0 + _SQRT3 * r) * torch.exp(-_SQRT3 * r),
    "matern52": lambda r: (1.0 + _SQRT5 * r + (5.0 / 3.0) * r * r) * torch.exp(-_SQRT5 * r),
    "gaussian": lambda r: torch.exp(-0.5 * r * r),
}


def _entries(lengthscale: Any) -> list[Any]:
    """The numbers a ``lengthscale`` option gives (none for ``None``; a tensor's or array's as
    Python numbers, a string as itself, so that it is refused by name)."""
    if lengthscale is None:
        return []
    if hasattr(lengthscale, "tolist"):  # a tensor, an array or a NumPy number
        listed = lengthscale.tolist()
        return listed if isinstance(listed, list) else [listed]
    if isinstance(lengthscale, Sequence) and not isinstance(lengthscale, str):
        return list(lengthscale)
    return [lengthscale]


class Kernel(nn.Module):
    """Stationary kernel ``k = variance * rho(r)`` with per-dimension lengthscales.

    Subclasses define the profile :meth:`profile` and the rows over the basis; a kernel with
    state over the basis (the geodesic kernel's graph) also follows its life cycle.

    Parameters
    ----------
    lengthscale : float, sequence of float or None
        One value for all input dimensions or one per dimension. ``None`` (or NaN for some
        dimensions) leaves the choice to :func:`sb3_geogp.defaults.resolve_lengthscale`: from
        the input bounds where the GP knows them, else when it sees its first batch.
    variance : float
        Signal variance ``sigma_f^2`` in units of the standardised targets.
    """

    lengthscale: Tensor
    variance: Tensor

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # 0.3's one-row method would be silently bypassed: the GP calls insertion_rows.
        if "insertion_row" in cls.__dict__:
            raise TypeError(
                f"{cls.__name__} defines insertion_row(x, z), which the GP no longer calls: "
                "define insertion_rows(x, z) instead, for x of shape (r, d), returning rows "
                "(r, m) and one attachment per row"
            )

    def __init__(
        self, lengthscale: float | Sequence[float] | None = None, variance: float = 1.0
    ) -> None:
        super().__init__()
        check_number("variance", variance)
        for value in _entries(lengthscale):
            check_number("lengthscale", value)
        if variance <= 0 or not math.isfinite(variance):
            raise ValueError(f"variance must be a positive finite number, got {variance}")
        init = None if lengthscale is None else torch.as_tensor(lengthscale, dtype=torch.float64)
        if init is not None and (
            init.ndim > 1 or not torch.all((init > 0) & ~torch.isinf(init) | torch.isnan(init))
        ):
            raise ValueError(
                f"lengthscale must be positive and finite, or NaN for 'choose from the data' "
                f"(scalar or 1-D), got {lengthscale}"
            )
        self._init_lengthscale = init
        # Shape (d,) is fixed by bind(); until then the buffer is empty.
        self.register_buffer("lengthscale", torch.empty(0, dtype=torch.float64))
        self.register_buffer("variance", torch.tensor(float(variance), dtype=torch.float64))

    # -- identity -----------------------------------------------------------------------------
    def options(self) -> dict[str, Any]:
        """Options that define the covariance beyond its hyperparameter buffers.

        They are stored in the kernel's state (``state_dict()["_extra_state"]``), and a state
        saved with other options is refused on load (except in :attr:`update_rules`).
        """
        return {}

    def extra_repr(self) -> str:
        return ", ".join(f"{k}={v!r}" for k, v in self.options().items())

    #: Options that only say how the kernel learns (stored, but free to differ on load).
    update_rules: tuple[str, ...] = ()

    #: The correlation profile (a key of :data:`PROFILES`); ``None`` where a subclass defines
    #: :meth:`profile` itself.
    profile_name: Profile | None = None

    def supports_float32(self) -> bool:
        """Whether a GP with this kernel is numerically safe in float32 (else float64 only):
        with the Laplacian profile. The Gaussian one's basis Gram matrices are too
        ill-conditioned, and on the geodesic kernel's trees it is not even positive definite
        (its posterior covariance loses definiteness and the weights diverge; docs/method.md,
        2.5)."""
        return self.profile_name == "laplacian"

    def state_nbytes(self, capacity: int, input_dim: int, itemsize: int) -> int:
        """Bytes of the state :meth:`bind` allocates beyond the hyperparameters."""
        return 0

    def get_extra_state(self) -> dict[str, Any]:
        return {"kernel": type(self).__name__, **self.options()}

    def set_extra_state(self, state: Any) -> None:
        check_same_options(
            "kernel", state, self.get_extra_state(), self.update_rules, first="kernel"
        )

    # -- set-up -----------------------------------------------------------------------------
    def bind(self, input_dim: int, capacity: int) -> None:
        """Allocate the state for ``input_dim`` inputs and up to ``capacity`` basis vectors.

        The lengthscale buffer holds the requested values, NaN where none was requested.
        """
        ls = torch.full((input_dim,), float("nan"), dtype=torch.float64)
        if self._init_lengthscale is not None:
            if self._init_lengthscale.numel() not in (1, input_dim):
                raise ValueError(
                    f"lengthscale has {self._init_lengthscale.numel()} entries but the input has "
                    f"{input_dim} dimensions; pass one value or one per dimension"
                )
            ls[:] = self._init_lengthscale
        self.lengthscale = ls

    def scale(self, x: Tensor) -> Tensor:
        """Inputs in lengthscale units, ``x / l``; ``x : Tensor, shape (n, d)``."""
        return x / self.lengthscale

    # -- the covariance as a function of distance -----------------------------------------------
    def profile(self, r: Tensor) -> Tensor:
        """Correlation ``rho(r)`` at distance ``r`` (lengthscale units), ``rho(0) = 1``."""
        if self.profile_name is None:
            raise NotImplementedError
        return PROFILES[self.profile_name](r)

    def forward(self, r: Tensor) -> Tensor:
        """Covariance ``variance * rho(r)`` for a tensor of distances ``r``."""
        return self.variance * self.profile(r)

    def novelty_at(self, r: float) -> float:
        """Relative novelty ``1 - rho(r)^2`` of a point at distance ``r`` from a single BV.

        Used to put the default novelty threshold on a distance scale: the same relative
        threshold means very different spacings for a Gaussian profile (``~ r^2``) and a
        Laplacian one (``~ 2 r``).
        """
        return 1.0 - float(self.profile(torch.tensor(float(r), dtype=torch.float64))) ** 2

    # -- rows over the basis ---------------------------------------------------------------------
    def gram(self, z: Tensor) -> Tensor:
        """Covariance among the basis vectors at scaled inputs ``z : (m, d)``, shape (m, m)."""
        raise NotImplementedError

    def cross(self, x: Tensor, z: Tensor) -> Tensor:
        """Prediction rows ``k(x, BV)`` of scaled inputs ``x : (n, d)``, shape (n, m).

        ``z : Tensor, shape (m, d)`` is the basis in scaled inputs.
        """
        raise NotImplementedError

    def rows(self, x: Tensor, z: Tensor) -> Rows:
        """:meth:`cross` in the form the GP computes with (dense unless overridden)."""
        return DenseRows(self.cross(x, z))

    def novelty_rows(self, x: Tensor, z: Tensor) -> Rows:
        """Rows on which a point's novelty is judged (by default its prediction rows)."""
        return self.rows(x, z)

    @property
    def novelty_from_rows(self) -> bool:
        """Whether :meth:`novelty_rows` are :meth:`rows` (the GP then judges the novelty of a
        batch it has just scored from the scoring's rows): where a subclass does not override
        :meth:`novelty_rows`; one that does, with rows equal to its prediction rows, may say
        so by overriding this too."""
        return type(self).novelty_rows is Kernel.novelty_rows

    def insertion_rows(self, x: Tensor, z: Tensor) -> tuple[Tensor, Sequence[Any]]:
        """Rows ``k(x_i, BV)`` that points would get if each became the next basis vector.

        Parameters
        ----------
        x : Tensor, shape (r, d)
            Scaled inputs, each judged alone against the current basis ``z : (m, d)``.

        Returns
        -------
        rows : Tensor, shape (r, m)
        attachments : sequence of length r
            Handed back to :meth:`on_insert` with the point that is inserted (for the geodesic
            kernel, its graph parent).
        """
        return self.cross(x, z), [None] * x.shape[0]

    # -- the basis life cycle (no-ops for a kernel without state over the basis) -----------------
    def on_insert(self, x: Tensor, attachment: Any) -> None:
        """A point at scaled input ``x : (d,)`` became the last basis vector."""

    def on_delete(self, j: int) -> None:
        """Basis vector ``j`` was removed (the later ones move up one place)."""

    def start_trajectory(self) -> None:
        """The next points start a new trajectory."""

    @property
    def graph(self) -> BVGraph | None:
        """The kernel's basis-vector graph, if it has one."""
        return None

    def basis_checkpoint(self) -> Any:
        """What :meth:`restore_basis` needs to undo :meth:`on_insert` and :meth:`on_delete`
        (the kernel's own buffers are saved by the GP); ``None`` without state over the basis.
        """
        return None

    def restore_basis(self, checkpoint: Any) -> None:
        """Undo every basis change since :meth:`basis_checkpoint` returned ``checkpoint``."""

    # -- hyperparameters -----------------------------------------------------------------------
    def correlation_fn(self, x: Tensor, z: Tensor) -> tuple[int, CorrelationFn]:
        """Correlations from points to basis inputs and among them, as functions of log
        lengthscale factors (the evidence fit differentiates through them).

        Parameters
        ----------
        x : Tensor, shape (n, d)
            Points in the user's units.
        z : Tensor, shape (m, d)
            Basis inputs in the user's units.

        Returns
        -------
        n_factors : int
            Number of free factors (one per dimension, or one for all).
        correlations : callable
            ``log_factor : Tensor, shape (n_factors,) -> (R_xz (n, m), R_zz (m, m))``,
            differentiable: the rows ``rho`` of :meth:`cross` and :meth:`gram` (without the
            signal variance) after :meth:`rescale` by ``exp(log_factor)``.
        """
        raise NotImplementedError

    def follows_lengthscale(self, z: Tensor) -> bool:
        """Whether the kernel's state over the basis (basis inputs ``z : (m, d)``) is in its
        lengthscales' units: false once they were changed in place rather than through
        :meth:`rescale`. Always true for a kernel without such state."""
        return True

    def rescale(self, factor: Tensor) -> None:
        """Multiply the lengthscale(s) by ``factor : Tensor, shape (n_factors,)``.

        The GP's posterior does not follow: on a GP that holds data, refit it
        (:meth:`~sb3_geogp.SparseOnlineGP.fit_hyperparameters`) before it predicts again.
        """
        self.lengthscale.mul_(factor)


#: Input dimensions from which :func:`distances` uses the matrix product. Below, the
#: coordinate differences cost little more (n = 2048 points to m = 256 basis vectors, one
#: thread: 1.6 against 1.1 ms at 8 dimensions, 3.6 against 1.7 at 32) and every published
#: result keeps its bits; above, they grow with the dimension (108 against 19 ms at 500, the
#: one-hot codes of Taxi-v4's states, where they took most of the GP critic's time in PPO).
PRODUCT_MIN_DIM = 32


def distances(a: Tensor, b: Tensor) -> Tensor:
    """Euclidean distances between rows, ``a : (n, d)``, ``b : (m, d)`` -> (n, m).

    Below :data:`PRODUCT_MIN_DIM` dimensions, computed from coordinate differences. From it
    on, by the matrix-product formula ``|a|^2 + |b|^2 - 2 a.b`` after both are translated by
    ``b``'s mean. Untranslated, that formula (``torch.cdist``'s default above 25 rows) loses
    the distance between nearby points far from the origin (catastrophic cancellation: with
    coordinates of 1e6 lengthscales, predictions moved by 1-3 % of the target range); the
    translation leaves coordinates of the data's own spread, so the distances keep a
    relative accuracy of about 1e-15, and a point on a basis vector is about 1e-8 of that
    spread from it instead of exactly 0.
    """
    if a.shape[1] < PRODUCT_MIN_DIM or b.shape[0] == 0:
        return torch.cdist(a, b, compute_mode="donot_use_mm_for_euclid_dist")
    centre = b.mean(dim=0, keepdim=True)
    return torch.cdist(a - centre, b - centre, compute_mode="use_mm_for_euclid_dist")


def quad(rows: Tensor, M: Tensor) -> Tensor:
    """Row-wise quadratic forms ``rows_i^T M rows_i``; rows (n, m), M (m, m) -> (n,)."""
    return ((rows @ M) * rows).sum(dim=1)


def gathered_quad(idx: Tensor, w: Tensor, M: Tensor) -> Tensor:
    """``w_i^T M[idx_i][:, idx_i] w_i`` per row; idx, w (n, k), M (m, m) -> (n,)."""
    block = M[idx[:, :, None], idx[:, None, :]]
    return torch.einsum("nk,nkl,nl->n", w, block, w)
