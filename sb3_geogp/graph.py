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

The graph knows nothing of kernels or GPs. It keeps its basis vectors in insertion order
(:attr:`BVGraph.basis_nodes`), the order in which a sparse GP stores them, so that the
:class:`~sb3_geogp.GeodesicKernel` that owns it reads the kernel's distance table from it
directly.
"""

from __future__ import annotations

from typing import Any

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

    def rescale(self, factor: float) -> None:
        """Divide every position, edge and distance by ``factor`` (lengthscale times factor)."""
        self.pos /= factor
        self.edge_length /= factor
        self.shortest_paths /= factor

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
