"""The basis-vector graph: a tree over the BVs with an exact all-pairs shortest-path table.

Every new basis vector joins the tree by exactly one edge (paper eq. 5 and footnote 3), whose
length is the scaled Euclidean distance to its parent. A new leaf creates no shortcut, so the
distances among existing nodes never change and the new row of the shortest-path table is
``SP[u, :] = w + SP[parent, :]``: O(N) per insertion, vectorised.

Deleting a basis vector keeps every remaining distance exact without re-running Dijkstra:

* a node of degree >= 3 (a branch point) stays as a *routing* node: it keeps its position
  and its edges but has no kernel row;
* a node of degree 2 is contracted: its two neighbours are joined by one edge whose length is
  the sum of the two it replaces (every path through it used both);
* a leaf is dropped, and a routing neighbour that is left with degree <= 2 is pruned in turn.

Routing nodes therefore always have degree >= 3, so a tree with ``m`` basis vectors has fewer
than ``m`` routing nodes: ``2 m`` node slots always suffice.

A lengthscale change rescales the tree (:meth:`BVGraph.rescale`). In a tree the path between two
nodes is unique whatever the edge lengths, so per-dimension lengthscales change the lengths of
the paths, never which paths they are: each edge is stretched (:func:`edge_stretch`) and every
distance is summed again along the same paths (:func:`tree_distances`).

The graph knows nothing of kernels or GPs. It keeps its basis vectors in insertion order
(:attr:`BVGraph.basis_nodes`), the order in which a sparse GP stores them, so that the
:class:`~sb3_geogp.GeodesicKernel` that owns it reads the kernel's distance table from it
directly.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import torch
from torch import Tensor, nn


class BVGraph(nn.Module):
    """Tree over basis vectors with fixed-capacity tensor state.

    Parameters
    ----------
    capacity : int
        Maximum number of nodes (basis vectors plus routing nodes).
    dim : int
        Dimension of node positions (scaled inputs).
    dtype, device
        Storage of positions, edge lengths and distances.

    Attributes
    ----------
    pos : Tensor, shape (capacity, dim)
        Node positions in lengthscale units.
    adjacency : Tensor, shape (capacity, capacity), bool
        Symmetric edge indicator.
    edge_length : Tensor, shape (capacity, capacity)
        Edge lengths (0 where there is no edge).
    shortest_paths : Tensor, shape (capacity, capacity)
        Exact shortest-path distances between alive nodes (``inf`` between components and for
        free slots).
    alive : Tensor, shape (capacity,), bool
        Slot in use.
    is_bv : Tensor, shape (capacity,), bool
        Node is a basis vector (otherwise a routing node).
    basis_nodes : Tensor, shape (capacity,), long
        Node of the ``i``-th basis vector, in insertion order with removals closed up
        (``-1`` past :attr:`n_basis`).
    """

    pos: Tensor
    adjacency: Tensor
    edge_length: Tensor
    shortest_paths: Tensor
    alive: Tensor
    is_bv: Tensor
    basis_nodes: Tensor

    def __init__(
        self,
        capacity: int,
        dim: int,
        dtype: torch.dtype = torch.float64,
        device: torch.device | str | None = None,
    ) -> None:
        super().__init__()
        self.capacity = int(capacity)
        n = self.capacity
        kw: dict[str, Any] = {"dtype": dtype, "device": device}
        self.register_buffer("pos", torch.zeros(n, dim, **kw))
        self.register_buffer("adjacency", torch.zeros(n, n, dtype=torch.bool, device=device))
        self.register_buffer("edge_length", torch.zeros(n, n, **kw))
        self.register_buffer("shortest_paths", torch.full((n, n), float("inf"), **kw))
        self.register_buffer("alive", torch.zeros(n, dtype=torch.bool, device=device))
        self.register_buffer("is_bv", torch.zeros(n, dtype=torch.bool, device=device))
        self.register_buffer("basis_nodes", torch.full((n,), -1, dtype=torch.long, device=device))

    # -- reading -----------------------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        """Number of nodes in use (basis vectors and routing nodes)."""
        return int(self.alive.sum())

    @property
    def n_basis(self) -> int:
        """Number of basis-vector nodes."""
        return int(self.is_bv.sum())

    def basis_distances(self) -> Tensor:
        """Shortest paths among the basis vectors in :attr:`basis_nodes` order, shape (m, m)."""
        nodes = self.basis_nodes[: self.n_basis]
        return self.shortest_paths[nodes][:, nodes]

    @property
    def n_components(self) -> int:
        """Connected components (a forest has ``nodes - edges`` of them)."""
        return self.n_nodes - int(self.adjacency.sum()) // 2

    def dense_adjacency(self) -> Tensor:
        """Weighted adjacency of the alive nodes for plotting or checking, shape (N, N).

        Rows follow the order of ``alive.nonzero()``; 0 means no edge.
        """
        nodes = self.alive.nonzero().squeeze(1)
        return self.edge_length[nodes][:, nodes]

    # -- mutation ----------------------------------------------------------------------------
    def add_node(self, pos: Tensor, parent: int | None = None) -> int:
        """Add a basis-vector node, as a leaf of ``parent`` (or as a new component).

        Parameters
        ----------
        pos : Tensor, shape (dim,)
            Position in lengthscale units.
        parent : int or None
            Node to join; the edge length is the Euclidean distance between the positions.

        Returns
        -------
        int
            The new node's slot.
        """
        free = (~self.alive).nonzero()
        if free.numel() == 0:
            raise RuntimeError(f"BVGraph is full ({self.capacity} nodes)")
        u = int(free[0])
        self.basis_nodes[self.n_basis] = u
        self.pos[u] = pos
        self.alive[u] = True
        self.is_bv[u] = True
        row = torch.full_like(self.shortest_paths[u], float("inf"))
        if parent is not None:
            length = torch.linalg.vector_norm(pos - self.pos[parent])
            self._link(u, parent, length)
            row = torch.where(self.alive, self.shortest_paths[parent] + length, row)
        row[u] = 0.0
        self.shortest_paths[u] = row
        self.shortest_paths[:, u] = row
        return u

    def remove_bv(self, node: int) -> list[int]:
        """Take ``node`` out of the basis; prune the tree where it no longer needs the node.

        Returns
        -------
        list of int
            Slots freed (the node itself if it was not kept as a routing node, and any
            routing nodes pruned after it).
        """
        if not bool(self.is_bv[node]):
            raise ValueError(f"node {node} is not a basis vector")
        m = self.n_basis
        keep = self.basis_nodes[:m][self.basis_nodes[:m] != node]
        self.basis_nodes[: m - 1] = keep
        self.basis_nodes[m - 1] = -1
        self.is_bv[node] = False
        freed: list[int] = []
        self._prune(node, freed)
        return freed

    def checkpoint(self) -> dict[str, Tensor]:
        """Copies of the node slots in use, for :meth:`restore` (slots past them are free)."""
        alive = self.alive.nonzero()
        hi = int(alive.max()) + 1 if alive.numel() else 0
        saved = {name: _slots(name, b, hi).clone() for name, b in self.named_buffers()}
        return saved | {"slots": torch.tensor(hi)}

    def restore(self, saved: dict[str, Tensor]) -> None:
        """Put the graph back as :meth:`checkpoint` saw it."""
        hi = int(saved["slots"])
        for name, b in self.named_buffers():
            b.fill_(_FREE[name])
            _slots(name, b, hi).copy_(saved[name])

    def rescale(self, factor: Tensor) -> None:
        """Follow the lengthscales multiplied by ``factor : Tensor, shape (1,) or (dim,)``.

        Positions are divided by it. One factor divides every edge and distance exactly.
        Per-dimension factors stretch each edge by :func:`edge_stretch` and sum the distances
        again along the tree's paths (:func:`tree_distances`): exact for an edge that is a
        straight segment, the chord's stretch for one contracted from a chain.
        """
        factor = factor.to(self.pos)
        if factor.numel() == 1 or bool((factor == factor[0]).all()):
            f = float(factor[0])
            self.pos /= f
            self.edge_length /= f
            self.shortest_paths /= f
            return
        paths = self.paths()
        length = paths.length * edge_stretch(paths.delta, factor.log())
        a, b = paths.edges.unbind(1)
        self.edge_length[a, b] = self.edge_length[b, a] = length
        self.pos[paths.nodes] /= factor
        table = tree_distances(paths.root_edges, paths.root_edges, length)
        same = paths.component[:, None] == paths.component[None, :]
        table = torch.where(same, table, torch.full_like(table, float("inf")))
        self.shortest_paths[paths.nodes[:, None], paths.nodes[None, :]] = table

    def paths(self) -> TreePaths:
        """The tree's paths as root-path incidences (see :class:`TreePaths`)."""
        nodes = self.alive.nonzero().squeeze(1)
        adjacency = self.adjacency[nodes][:, nodes].cpu().numpy()
        a, b = np.nonzero(np.triu(adjacency))
        edge_id = np.full(adjacency.shape, -1)
        edge_id[a, b] = edge_id[b, a] = np.arange(len(a))
        n = len(nodes)
        root_edges = np.zeros((n, len(a)))
        component = np.full(n, -1)
        for root in range(n):
            if component[root] >= 0:
                continue
            component[root] = root
            frontier = [root]
            # A node's row is its parent's plus their edge; the parent's is final once reached.
            while frontier:
                u = frontier.pop()
                for v in np.nonzero(adjacency[u] & (component < 0))[0].tolist():
                    component[v] = root
                    root_edges[v] = root_edges[u]
                    root_edges[v, edge_id[u, v]] = 1.0
                    frontier.append(v)
        kw: dict[str, Any] = {"device": self.pos.device}
        ends = torch.as_tensor(np.stack([a, b], axis=1), dtype=torch.long, **kw)
        slots = nodes[ends]
        return TreePaths(
            nodes=nodes,
            edges=slots,
            length=self.edge_length[slots[:, 0], slots[:, 1]],
            delta=self.pos[slots[:, 0]] - self.pos[slots[:, 1]],
            root_edges=torch.as_tensor(root_edges, dtype=self.pos.dtype, **kw),
            component=torch.as_tensor(component, dtype=torch.long, **kw),
        )

    # -- internals ---------------------------------------------------------------------------
    def _link(self, a: int, b: int, length: Tensor) -> None:
        self.adjacency[a, b] = self.adjacency[b, a] = True
        self.edge_length[a, b] = self.edge_length[b, a] = length

    def _prune(self, node: int, freed: list[int]) -> None:
        """Drop or contract a routing node of degree <= 2, cascading to its neighbour."""
        neighbours = self.adjacency[node].nonzero().squeeze(1).tolist()
        if len(neighbours) >= 3:
            return
        if len(neighbours) == 2:
            a, b = neighbours
            self._link(a, b, self.edge_length[a, node] + self.edge_length[node, b])
        self._free(node)
        freed.append(node)
        if len(neighbours) == 1 and not bool(self.is_bv[neighbours[0]]):
            self._prune(neighbours[0], freed)

    def _free(self, node: int) -> None:
        self.alive[node] = False
        self.is_bv[node] = False
        self.adjacency[node] = False
        self.adjacency[:, node] = False
        self.edge_length[node] = 0.0
        self.edge_length[:, node] = 0.0
        self.shortest_paths[node] = float("inf")
        self.shortest_paths[:, node] = float("inf")
        self.pos[node] = 0.0


class TreePaths(NamedTuple):
    """The paths of a forest, for distances as functions of its edge lengths.

    Attributes
    ----------
    nodes : Tensor, shape (N,), long
        The alive node slots; rows below follow this order.
    edges : Tensor, shape (E, 2), long
        Node slots at the ends of each edge.
    length : Tensor, shape (E,)
        Edge lengths.
    delta : Tensor, shape (E, dim)
        Position differences along each edge (the chord of a contracted edge).
    root_edges : Tensor, shape (N, E)
        1 where the edge lies on the path from the node to the root of its component.
    component : Tensor, shape (N,), long
        The root's row, one per component.
    """

    nodes: Tensor
    edges: Tensor
    length: Tensor
    delta: Tensor
    root_edges: Tensor
    component: Tensor


def tree_distances(rows: Tensor, cols: Tensor, length: Tensor) -> Tensor:
    """Path lengths in a tree between nodes given by root-path incidences.

    The path from ``i`` to ``j`` is the edges on exactly one of their root paths, so

    .. math::  d_{ij} = \\sum_e L_e \\big(R_{ie} (1 - R_{je}) + (1 - R_{ie}) R_{je}\\big):

    a sum of positive terms (no cancellation of root depths), linear and differentiable in
    the lengths.

    Parameters
    ----------
    rows : Tensor, shape (a, E)
    cols : Tensor, shape (b, E)
        Root-path incidences (:attr:`TreePaths.root_edges`) of nodes in one component.
    length : Tensor, shape (E,)

    Returns
    -------
    Tensor, shape (a, b)
    """
    return (rows * length) @ (1 - cols).T + ((1 - rows) * length) @ cols.T


def edge_stretch(delta: Tensor, log_factor: Tensor) -> Tensor:
    """How much each edge lengthens when the lengthscales are multiplied by ``exp(log_factor)``.

    ``||delta / f|| / ||delta||`` for ``delta : (E, dim)`` and ``log_factor : (1,) or (dim,)``;
    an edge whose chord is zero (a contracted chain that came back) takes the geometric mean,
    ``exp(-mean(log_factor))``.

    Returns
    -------
    Tensor, shape (E,)
    """
    chord = torch.linalg.vector_norm(delta, dim=1)
    stretched = torch.linalg.vector_norm(delta * torch.exp(-log_factor), dim=1)
    mean = torch.exp(-log_factor.mean()).expand_as(chord)
    return torch.where(chord > 0, stretched / chord.clamp_min(torch.finfo(chord.dtype).tiny), mean)


#: Contents of a free slot, per buffer.
_FREE: dict[str, float | bool] = {
    "pos": 0.0,
    "adjacency": False,
    "edge_length": 0.0,
    "shortest_paths": float("inf"),
    "alive": False,
    "is_bv": False,
    "basis_nodes": -1,
}


def _slots(name: str, buffer: Tensor, hi: int) -> Tensor:
    """The part of a graph buffer that covers node slots ``:hi`` (a view)."""
    return (
        buffer[:hi, :hi] if name in ("adjacency", "edge_length", "shortest_paths") else buffer[:hi]
    )
