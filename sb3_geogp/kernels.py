"""Covariance functions of the sparse GP: Euclidean (RBF) and geodesic (BV-graph) kernels.

Both kernels are stationary in a distance ``r`` measured in lengthscale units,

.. math::  k(x, x') = \\sigma_f^2 \\, \\rho\\big(r(x, x')\\big),

and differ only in the distance ``r`` and the profile ``rho``:

* :class:`RBFKernel`: ``r`` is the Euclidean distance of ``x / l`` and ``x' / l``,
  ``rho(r) = exp(-r^2 / 2)``.
* :class:`GeodesicKernel`: ``r`` is the shortest-path distance over the basis-vector graph
  (:class:`sb3_geogp.graph.BVGraph`), whose edges have the lengths of the same scaled Euclidean
  distance; ``rho`` is the Laplacian ``exp(-r)`` (default, positive definite on trees) or the
  paper's Gaussian ``exp(-r^2 / 2)`` (not positive definite, kept for comparison).

A kernel holds only hyperparameters (as buffers, so that SB3's optimiser never sees them) and
computes kernel rows from a :class:`BasisView`: the basis vectors in scaled coordinates plus,
for the geodesic kernel, the graph that owns their shortest-path table.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal, NamedTuple

import torch
from torch import Tensor, nn

from sb3_geogp.graph import BVGraph

Profile = Literal["laplacian", "gaussian"]
Attach = Literal["interpolate", "nearest"]
Edges = Literal["trajectory", "nearest"]


class BasisView(NamedTuple):
    """The current basis vectors as a kernel sees them.

    Attributes
    ----------
    z : Tensor, shape (m, d)
        Basis-vector inputs divided by the lengthscale.
    nodes : Tensor, shape (m,), long
        Graph node of each basis vector (unused by the RBF kernel).
    graph : BVGraph or None
        The BV graph (geodesic kernel only).
    """

    z: Tensor
    nodes: Tensor
    graph: BVGraph | None


class Kernel(nn.Module):
    """Stationary kernel ``k = variance * rho(r)`` with per-dimension lengthscales.

    Parameters
    ----------
    lengthscale : float, sequence of float or None
        One value for all input dimensions or one per dimension. ``None`` (or NaN for some
        dimensions) lets :class:`~sb3_geogp.SparseOnlineGP` choose it (those) from the first
        batch: the standard deviation of each dimension.
    variance : float
        Signal variance ``sigma_f^2`` in units of the standardised targets.
    """

    geodesic: bool = False
    lengthscale: Tensor
    variance: Tensor

    def __init__(
        self, lengthscale: float | Sequence[float] | None = None, variance: float = 1.0
    ) -> None:
        super().__init__()
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

    # -- set-up -----------------------------------------------------------------------------
    def bind(self, input_dim: int) -> None:
        """Allocate the lengthscale buffer for ``input_dim`` inputs (NaN = not chosen yet)."""
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
        raise NotImplementedError

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
    def gram(self, view: BasisView) -> Tensor:
        """Covariance among the basis vectors, shape (m, m)."""
        raise NotImplementedError

    def cross(self, x: Tensor, view: BasisView) -> Tensor:
        """Prediction rows ``k(x, BV)`` for scaled inputs ``x : (n, d)``, shape (n, m)."""
        raise NotImplementedError

    def cross_factors(self, x: Tensor, view: BasisView) -> tuple[Tensor, Tensor] | None:
        """Prediction rows as combinations of BV rows, when the kernel has that form.

        Returns ``(idx, w)`` of shapes (n, k) with ``k(x_i, BV) = sum_j w_ij K_b[idx_ij]``, which
        lets the GP predict in O(n k^2) from a few (m, m) products, or ``None``.
        """
        return None

    def novelty_rows(self, x: Tensor, view: BasisView) -> Tensor:
        """Rows on which a point's novelty is judged, shape (n, m)."""
        return self.cross(x, view)

    def novelty_factors(self, x: Tensor, view: BasisView) -> tuple[Tensor, Tensor] | None:
        """:meth:`novelty_rows` as combinations of BV rows (see :meth:`cross_factors`), or None."""
        return None

    def node_row(self, x: Tensor, parent: int | None, view: BasisView) -> Tensor:
        """Row ``k(x, BV)`` the point gets once it is itself a basis vector, shape (m,).

        ``x : Tensor, shape (d,)`` scaled; ``parent`` is its graph parent node (geodesic only).
        """
        return self.cross(x[None], view)[0]


class EuclideanKernel(Kernel):
    """A profile of the Euclidean distance ``r = ||(x - x') / l||`` (rows are direct)."""

    def gram(self, view: BasisView) -> Tensor:
        return self(torch.cdist(view.z, view.z))

    def cross(self, x: Tensor, view: BasisView) -> Tensor:
        return self(torch.cdist(x, view.z))


class RBFKernel(EuclideanKernel):
    """Gaussian kernel on Euclidean distance.

    .. math::  k(x, x') = \\sigma_f^2 \\exp\\Big(-\\tfrac12 \\sum_j (x_j - x'_j)^2 / l_j^2\\Big)

    Parameters
    ----------
    lengthscale : float, sequence of float or None
        ``l``: scalar or one per input dimension; ``None`` = chosen from the first batch.
    variance : float
        ``sigma_f^2`` (standardised target units).
    """

    def profile(self, r: Tensor) -> Tensor:
        return torch.exp(-0.5 * r * r)


class LaplacianKernel(EuclideanKernel):
    """Laplacian (exponential) kernel on Euclidean distance.

    .. math::  k(x, x') = \\sigma_f^2 \\exp\\big(-\\|(x - x') / l\\|\\big)

    The geodesic kernel's default profile without the graph: the control that separates the
    effect of the graph distance from that of the profile (docs/wall_experiment.md,
    docs/reproduction.md).

    Parameters
    ----------
    lengthscale : float, sequence of float or None
        ``l``: scalar or one per input dimension; ``None`` = chosen from the first batch.
    variance : float
        ``sigma_f^2`` (standardised target units).
    """

    def profile(self, r: Tensor) -> Tensor:
        return torch.exp(-r)


class GeodesicKernel(Kernel):
    """Kernel on shortest-path distances over the basis-vector graph (paper eq. 6, sign fixed).

    Between basis vectors ``b_i, b_j`` the distance is the graph's shortest path
    ``SP(b_i, b_j)``; each edge is a scaled Euclidean distance ``||(b - b') / l||``.

    .. math::  k(b_i, b_j) = \\sigma_f^2 \\rho\\big(SP(b_i, b_j)\\big),\\quad
               \\rho(r) = e^{-r} \\text{ (laplacian)} \\text{ or } e^{-r^2/2} \\text{ (gaussian)}

    The graph is a tree (see :mod:`sb3_geogp.graph`). Tree metrics embed isometrically in
    L1, so the Laplacian profile is positive definite; the Gaussian one is not
    (Sugiyama et al. 2008) and relies on the sparse GP's nugget repair.

    A point ``x`` that is not a basis vector is attached to the graph in one of two ways:

    * ``attach="nearest"`` (the paper): through its nearest basis vector ``b_i``,
      ``r(x, b_j) = ||x - b_i|| + SP(b_i, b_j)``.
    * ``attach="interpolate"`` (default): ``k(x, .) = sum_i w_i(x) k(b_i, .)`` over the
      ``n_neighbors`` nearest basis vectors, with modified Shepard weights
      ``w_i ∝ ((R - d_i) / (R d_i))^2`` (``d_i`` Euclidean, ``R`` the distance to the next
      neighbour), normalised to sum 1. The weights are continuous in ``x`` and one-hot on a
      basis vector, so the kernel is the BV kernel seen through a feature map: positive
      definite whenever the BV Gram matrix is.

    Novelty is always judged on the row the point would have as a leaf of its nearest basis
    vector (an interpolated row lies in the span of the BV rows and is never novel).

    Parameters
    ----------
    lengthscale : float, sequence of float or None
        Scales the inputs before Euclidean edge lengths are taken.
    variance : float
        ``sigma_f^2`` (standardised target units).
    profile : {"laplacian", "gaussian"}
        Correlation as a function of graph distance.
    attach : {"interpolate", "nearest"}
        How prediction points are attached to the graph.
    n_neighbors : int
        Basis vectors interpolated over with ``attach="interpolate"``.
    edges : {"trajectory", "nearest"}
        How a new basis vector joins the tree: to the previous basis vector of its own
        trajectory when there is one, else to its nearest (``"trajectory"``, paper footnote 3),
        or always to its nearest (``"nearest"``, paper eq. 5 literally).
    """

    geodesic = True

    def __init__(
        self,
        lengthscale: float | Sequence[float] | None = None,
        variance: float = 1.0,
        profile: Profile = "laplacian",
        attach: Attach = "interpolate",
        n_neighbors: int = 4,
        edges: Edges = "trajectory",
    ) -> None:
        super().__init__(lengthscale, variance)
        for name, value, allowed in (
            ("profile", profile, ("laplacian", "gaussian")),
            ("attach", attach, ("interpolate", "nearest")),
            ("edges", edges, ("trajectory", "nearest")),
        ):
            if value not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
        if n_neighbors < 1:
            raise ValueError(f"n_neighbors must be >= 1, got {n_neighbors}")
        self.profile_name: Profile = profile
        self.attach: Attach = attach
        self.n_neighbors = int(n_neighbors)
        self.edges: Edges = edges

    def extra_repr(self) -> str:
        return (
            f"profile={self.profile_name!r}, attach={self.attach!r}, "
            f"n_neighbors={self.n_neighbors}, edges={self.edges!r}"
        )

    def profile(self, r: Tensor) -> Tensor:
        if self.profile_name == "laplacian":
            return torch.exp(-r)
        return torch.exp(-0.5 * r * r)

    @staticmethod
    def _graph(view: BasisView) -> BVGraph:
        if view.graph is None:
            raise RuntimeError("GeodesicKernel needs the BV graph of its SparseOnlineGP")
        return view.graph

    def gram(self, view: BasisView) -> Tensor:
        sp = self._graph(view).shortest_paths
        return self(sp[view.nodes][:, view.nodes])

    def novelty_rows(self, x: Tensor, view: BasisView) -> Tensor:
        # Leaf of the nearest BV: r(x, b_j) = ||x - b_i|| + SP(b_i, b_j).
        dist = torch.cdist(x, view.z)
        w, i = dist.min(dim=1)
        sp = self._graph(view).shortest_paths[view.nodes[i]][:, view.nodes]
        return self(w[:, None] + sp)

    def novelty_factors(self, x: Tensor, view: BasisView) -> tuple[Tensor, Tensor] | None:
        if self.profile_name != "laplacian":
            return None
        # variance * exp(-(w + SP(b_i, .))) = exp(-w) * K_b[i]: a scaled copy of one BV row.
        w, i = torch.cdist(x, view.z).min(dim=1)
        return i[:, None], torch.exp(-w)[:, None]

    def cross_factors(self, x: Tensor, view: BasisView) -> tuple[Tensor, Tensor] | None:
        if self.attach == "interpolate":
            return shepard_weights(torch.cdist(x, view.z), self.n_neighbors)
        return self.novelty_factors(x, view)

    def cross(self, x: Tensor, view: BasisView) -> Tensor:
        factors = self.cross_factors(x, view)
        if factors is None:
            return self.novelty_rows(x, view)
        idx, w = factors
        return torch.einsum("nk,nkm->nm", w, self.gram(view)[idx])

    def node_row(self, x: Tensor, parent: int | None, view: BasisView) -> Tensor:
        if parent is None:
            raise ValueError("a new BV of the geodesic kernel needs a parent node")
        graph = self._graph(view)
        w = torch.linalg.vector_norm(x - graph.pos[parent])
        return self(w + graph.shortest_paths[parent, view.nodes])


def shepard_weights(dist: Tensor, k: int) -> tuple[Tensor, Tensor]:
    """Modified Shepard interpolation weights over the ``k`` nearest basis vectors.

    Parameters
    ----------
    dist : Tensor, shape (n, m)
        Distances from ``n`` points to ``m`` basis vectors.
    k : int
        Number of neighbours that get weight (capped at ``m``).

    Returns
    -------
    idx : Tensor, shape (n, k), long
        The nearest basis vectors of each point.
    weights : Tensor, shape (n, k)
        ``w_i ∝ ((R - d_i)_+ / (R d_i))^2``, summing to 1, ``R`` the distance to the
        ``(k+1)``-th nearest basis vector (infinite if there is none), so a weight vanishes
        continuously as its basis vector leaves the neighbour set; a point on a basis vector
        gets weight 1 on it.
    """
    m = dist.shape[1]
    k = min(k, m)
    d, idx = torch.topk(dist, min(k + 1, m), dim=1, largest=False)
    # A point on a BV gets weight 1 there: clamping its distance keeps the formula finite and
    # the mask zeroes the others.
    floor = torch.finfo(d.dtype).tiny ** 0.25
    d_near = d[:, :k].clamp_min(floor)
    if m > k:
        radius = d[:, k:]
        raw = ((radius - d_near).clamp_min(0) / (radius * d_near)).square()
    else:
        raw = d_near.reciprocal().square()
    raw[:, 1:] *= d[:, :1] > floor
    # A row of neighbours all tied at the radius is all zero: the tiny offset weighs them
    # equally there and vanishes (underflows) next to any real weight.
    raw = raw + torch.finfo(raw.dtype).tiny
    return idx[:, :k], raw / raw.sum(dim=1, keepdim=True)
