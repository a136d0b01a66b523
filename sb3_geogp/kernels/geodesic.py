"""The geodesic kernel: covariance of shortest-path distances over a basis-vector graph.

The kernel owns the graph (:class:`~sb3_geogp.graph.BVGraph`) that it grows on-line: the rule by
which a new basis vector joins it (along its trajectory, or to its nearest), the trajectory
being followed, its shortest-path table as the kernel's distance, and its rescaling after a
lengthscale fit. The sparse GP only tells it of each insertion and deletion.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import torch
from torch import Tensor

from sb3_geogp.graph import BVGraph, edge_stretch, tree_distances
from sb3_geogp.kernels.base import (
    CorrelationFn,
    DenseRows,
    Gram,
    Kernel,
    MixedRows,
    Profile,
    Rows,
    distances,
)

#: Distance given to the pairs :meth:`GeodesicKernel.blocked` forbids, in lengthscale units:
#: every profile vanishes there (``exp(-1e4)`` underflows to 0) while Shepard weights stay finite.
BLOCKED_DISTANCE = 1e4

Attach = Literal["interpolate", "nearest"]
Edges = Literal["trajectory", "nearest"]


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
      basis vector; the cross-covariances are the BV kernel's seen through them, while a
      point's own prior variance stays ``sigma_f^2`` (docs/method.md, section 3). Because the
      weights sum to 1 however far ``x`` is, a point far from every basis vector is predicted
      as its nearest ones are: the mean does not revert to the prior, and the variance does
      not grow back to it (``attach="nearest"`` and the Euclidean kernels do both).

    Novelty is always judged on the row the point would have as a leaf of its nearest basis
    vector (an interpolated row lies in the span of the BV rows and is never novel).

    Every "nearest" above is Euclidean, so a point beside an obstacle can be attached to basis
    vectors on its far side. :meth:`blocked` names pairs that may not be attached (none by
    default); a subclass that knows the obstacles (an oracle, as in the wall study) makes every
    attachment, parent and novelty judgement respect them.

    A new basis vector joins the tree as a leaf of its parent (:meth:`insertion_rows`): the
    previous basis vector of its own trajectory with ``edges="trajectory"`` when there is one
    (paper footnote 3), else its nearest basis vector (paper eq. 5).

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
    ard : bool
        What a hyperparameter fit (:meth:`correlation_fn`) may change: one lengthscale factor
        per input dimension (automatic relevance determination; the default since 0.4) or
        one on all of them (``False``, 0.3's rule). An update rule, not part of the
        covariance: a state saved with either loads into a kernel with either.

    Attributes
    ----------
    graph : BVGraph
        The tree over the basis vectors (allocated by :meth:`bind`), positions in lengthscale
        units.
    traj_node : Tensor, shape (), long
        Graph node of the current trajectory's last basis vector (``-1``: none yet).
    """

    traj_node: Tensor
    update_rules = ("ard",)

    def __init__(
        self,
        lengthscale: float | Sequence[float] | None = None,
        variance: float = 1.0,
        profile: Profile = "laplacian",
        attach: Attach = "interpolate",
        n_neighbors: int = 4,
        edges: Edges = "trajectory",
        ard: bool = True,
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
        self.ard = bool(ard)
        self.tree = BVGraph(0, 1)
        self.register_buffer("traj_node", torch.full((), -1, dtype=torch.long))

    def options(self) -> dict[str, Any]:
        return {
            "profile": self.profile_name,
            "attach": self.attach,
            "n_neighbors": self.n_neighbors,
            "edges": self.edges,
            "ard": self.ard,
        }

    # -- set-up and the graph ------------------------------------------------------------------
    def bind(self, input_dim: int, capacity: int) -> None:
        """Also allocate the graph: ``2 * capacity`` nodes always suffice (see BVGraph)."""
        super().bind(input_dim, capacity)
        self.tree = BVGraph(2 * capacity, input_dim)
        self.traj_node.fill_(-1)

    @property
    def graph(self) -> BVGraph:
        return self.tree

    def state_nbytes(self, capacity: int, input_dim: int, itemsize: int) -> int:
        nodes = 2 * capacity
        return nodes * nodes * (2 * itemsize + 1) + nodes * (input_dim * itemsize + 20)

    # -- rows over the basis ---------------------------------------------------------------------
    def gram(self, z: Tensor) -> Tensor:
        return self(self.tree.basis_distances())

    def _leaf_factors(self, x: Tensor, z: Tensor) -> MixedRows:
        # As a leaf of the nearest BV b_i at distance w, the Laplacian row is
        # variance * exp(-(w + SP(b_i, .))) = exp(-w) * K_b[i]: a scaled copy of one BV row.
        w, i = self.attach_distances(x, z).min(dim=1)
        return MixedRows(i[:, None], torch.exp(-w)[:, None])

    def novelty_rows(self, x: Tensor, z: Tensor) -> Rows:
        if self.profile_name == "laplacian":
            return self._leaf_factors(x, z)
        # Leaf of the nearest BV: r(x, b_j) = ||x - b_i|| + SP(b_i, b_j).
        w, i = self.attach_distances(x, z).min(dim=1)
        return DenseRows(self(w[:, None] + self.tree.basis_distances()[i]))

    @property
    def novelty_from_rows(self) -> bool:
        return self.attach != "interpolate"

    def rows(self, x: Tensor, z: Tensor) -> Rows:
        if self.attach == "interpolate":
            return MixedRows(*shepard_weights(self.attach_distances(x, z), self.n_neighbors))
        return self.novelty_rows(x, z)

    def cross(self, x: Tensor, z: Tensor) -> Tensor:
        return self.rows(x, z).dense(Gram(self.gram(z)))

    def insertion_rows(self, x: Tensor, z: Tensor) -> tuple[Tensor, Sequence[Any]]:
        """The rows of ``x : (r, d)`` as leaves of their parents; the parent nodes are the
        attachments (``None``: the new BV starts a component of its own, correlated with no
        other: the first BV, or one that sees no BV, :meth:`blocked`)."""
        parents = self._parents(x, z)
        if parents is None:
            return x.new_zeros(x.shape[0], 0), [None] * x.shape[0]
        joined, nodes_of = parents >= 0, parents.clamp_min(0)
        w = torch.linalg.vector_norm(x - self.tree.pos[nodes_of], dim=1)
        nodes = self.tree.basis_nodes[: z.shape[0]]
        rows = self(w[:, None] + self.tree.shortest_paths[nodes_of][:, nodes])
        rows = torch.where(joined[:, None], rows, torch.zeros_like(rows))
        return rows, [
            p if ok else None for p, ok in zip(parents.tolist(), joined.tolist(), strict=True)
        ]

    def _parents(self, x: Tensor, z: Tensor) -> Tensor | None:
        """Graph nodes new BVs at scaled inputs ``x : (r, d)`` would be joined to, shape (r,):
        -1 where a point sees no BV (every pair :meth:`blocked`), None where there is no basis
        yet."""
        if z.shape[0] == 0:
            return None
        if self.edges == "trajectory" and int(self.traj_node) >= 0:
            return self.traj_node.expand(x.shape[0])
        parents = self.tree.basis_nodes[self.attach_distances(x, z).argmin(dim=1)]
        mask = self.blocked(x, z)
        if mask is None:
            return parents
        return torch.where(mask.all(dim=1), torch.full_like(parents, -1), parents)

    def blocked(self, x: Tensor, z: Tensor) -> Tensor | None:
        """Pairs that may not be attached to each other (none by default).

        Parameters
        ----------
        x : Tensor, shape (n, d)
            Points, scaled by the lengthscale.
        z : Tensor, shape (m, d)
            Basis vectors, scaled by the lengthscale.

        Returns
        -------
        Tensor of bool, shape (n, m), or None
            ``True`` where ``x_i`` may not see ``z_j``; ``None``: every pair may.
        """
        return None

    def attach_distances(self, x: Tensor, z: Tensor, stretch: Tensor | None = None) -> Tensor:
        """Euclidean distances by which points are attached, shape (n, m): those of
        :meth:`blocked` pairs set to :data:`BLOCKED_DISTANCE`.

        ``x : (n, d)`` and ``z : (m, d)`` are scaled by the lengthscale; ``stretch : (d,)``
        rescales them further (a lengthscale fit's trial factors) for the distances, not for
        :meth:`blocked`.
        """
        d = distances(x, z) if stretch is None else distances(x * stretch, z * stretch)
        mask = self.blocked(x, z)
        return d if mask is None else d.masked_fill(mask, BLOCKED_DISTANCE)

    # -- the basis life cycle ------------------------------------------------------------------
    def on_insert(self, x: Tensor, attachment: Any) -> None:
        self.traj_node.fill_(self.tree.add_node(x, attachment))

    def on_delete(self, j: int) -> None:
        freed = self.tree.remove_bv(int(self.tree.basis_nodes[j]))
        if int(self.traj_node) in freed:
            self.traj_node.fill_(-1)

    def start_trajectory(self) -> None:
        self.traj_node.fill_(-1)

    def basis_checkpoint(self) -> Any:
        return self.tree.checkpoint()

    def restore_basis(self, checkpoint: Any) -> None:
        self.tree.restore(checkpoint)

    # -- hyperparameters -----------------------------------------------------------------------
    def correlation_fn(self, x: Tensor, z: Tensor) -> tuple[int, CorrelationFn]:
        """One factor per dimension with ``ard=True``, else one on all lengthscales.

        The tree's paths do not depend on the edge lengths, so the basis distances are sums
        of stretched edges along fixed paths (:func:`~sb3_geogp.graph.tree_distances`,
        :func:`~sb3_geogp.graph.edge_stretch`), exactly what :meth:`rescale` then stores.
        Attachments are recomputed in the stretched coordinates (the nearest basis vectors
        may change with per-dimension factors).
        """
        paths = self.tree.paths()
        slot = torch.full((self.tree.capacity,), -1, dtype=torch.long, device=x.device)
        slot[paths.nodes] = torch.arange(len(paths.nodes), device=x.device)
        basis = slot[self.tree.basis_nodes[: z.shape[0]]]
        R = paths.root_edges[basis]
        same = paths.component[basis][:, None] == paths.component[basis][None, :]
        xs, zs = self.scale(x), self.scale(z)
        n_factors = x.shape[1] if self.ard else 1

        def correlations(log_factor: Tensor) -> tuple[Tensor, Tensor]:
            stretch = torch.exp(-log_factor)
            length = paths.length * edge_stretch(paths.delta, log_factor)
            base = tree_distances(R, R, length)
            near = self.attach_distances(xs, zs, stretch)
            R_zz = torch.where(same, self.profile(base), torch.zeros_like(base))
            if self.attach == "interpolate":
                idx, w = shepard_weights(near, self.n_neighbors)
                return torch.einsum("nk,nkm->nm", w, R_zz[idx]), R_zz
            dist, i = near.min(dim=1)
            leaf = self.profile(dist[:, None] + base[i])
            return torch.where(same[i], leaf, torch.zeros_like(leaf)), R_zz

        return n_factors, correlations

    def follows_lengthscale(self, z: Tensor) -> bool:
        # The tree holds its nodes in lengthscale units, and rescale() moves them with the
        # lengthscales; a change in place leaves them where they were.
        if z.shape[0] == 0:
            return True
        pos = self.tree.pos[self.tree.basis_nodes[: z.shape[0]]]
        scaled = self.scale(z)
        # Each rescale rounds both sides apart by an ulp or two: room for thousands of refits.
        tol = 1e4 * torch.finfo(scaled.dtype).eps
        return bool(torch.allclose(pos, scaled, rtol=tol, atol=tol * float(scaled.abs().max())))

    def rescale(self, factor: Tensor) -> None:
        super().rescale(factor)
        self.tree.rescale(factor)


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
        gets weight 1 on it (equal weights on its ``k`` nearest where more than ``k``
        coincide with it).
    """
    m = dist.shape[1]
    k = min(k, m)
    d, idx = torch.topk(dist, min(k + 1, m), dim=1, largest=False)
    # A point on a BV gets weight 1 there: clamping its distance keeps the formula finite and
    # the mask zeroes the others.
    floor = torch.finfo(d.dtype).tiny ** 0.25
    d_near = d[:, :k].clamp_min(floor)
    if m > k:
        # Clamped too: with more than k BVs on the point the ratio would be 0 / 0.
        radius = d[:, k:].clamp_min(floor)
        raw = ((radius - d_near).clamp_min(0) / (radius * d_near)).square()
    else:
        raw = d_near.reciprocal().square()
    raw[:, 1:] *= d[:, :1] > floor
    # A row of neighbours all tied at the radius is all zero: the tiny offset weighs them
    # equally there and vanishes (underflows) next to any real weight.
    raw = raw + torch.finfo(raw.dtype).tiny
    return idx[:, :k], raw / raw.sum(dim=1, keepdim=True)
