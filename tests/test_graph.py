"""BV graph: exact shortest paths (vs scipy), tree shape and size under insertions and deletions."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.sparse.csgraph import connected_components, csgraph_from_masked, shortest_path

from sb3_geogp import GeodesicKernel, SparseOnlineGP
from sb3_geogp.graph import BVGraph


# -- independent reference ----------------------------------------------------------------------
def scipy_metric(graph: BVGraph) -> tuple[np.ndarray, np.ndarray, int]:
    """Alive slots, their all-pairs shortest paths and component count, computed by scipy.

    The graph is built from the boolean adjacency mask, so zero-length edges stay edges.
    """
    nodes = np.flatnonzero(graph.alive.numpy())
    mask = graph.adjacency.numpy()[np.ix_(nodes, nodes)]
    lengths = graph.edge_length.numpy()[np.ix_(nodes, nodes)]
    cs = csgraph_from_masked(np.ma.masked_array(lengths, mask=~mask))
    n_comp = connected_components(cs, directed=False)[0] if nodes.size else 0
    return nodes, shortest_path(cs, directed=False), n_comp


def assert_valid_forest(graph: BVGraph) -> None:
    """Exact distances, forest shape, routing degrees and the 2 x (#BV) size bound."""
    adj, alive, is_bv = graph.adjacency.numpy(), graph.alive.numpy(), graph.is_bv.numpy()
    sp = graph.shortest_paths.numpy()
    assert (adj == adj.T).all() and not adj.diagonal().any()
    assert not adj[~alive].any() and not (is_bv & ~alive).any()
    assert np.isinf(sp[~alive]).all() and np.isinf(sp[:, ~alive]).all()
    nodes, ref_sp, n_comp = scipy_metric(graph)
    np.testing.assert_allclose(sp[np.ix_(nodes, nodes)], ref_sp, rtol=1e-12, atol=1e-12)
    n_edges = int(adj.sum()) // 2
    assert graph.n_components == n_comp == nodes.size - n_edges
    assert (adj.sum(axis=1)[alive & ~is_bv] >= 3).all()
    assert graph.n_nodes <= 2 * int(is_bv.sum())


# -- random sequences on the bare graph -----------------------------------------------------------
def random_operation(graph: BVGraph, rng: np.random.Generator, max_bv: int) -> None:
    """Add a leaf (random parent among alive nodes, sometimes at distance 0) or remove a BV."""
    bvs = np.flatnonzero(graph.is_bv.numpy())
    if bvs.size < max_bv and (bvs.size == 0 or rng.random() < 0.55):
        alive = np.flatnonzero(graph.alive.numpy())
        parent = None if alive.size == 0 or rng.random() < 0.1 else int(rng.choice(alive))
        base = torch.zeros(2, dtype=torch.float64) if parent is None else graph.pos[parent]
        offset = 0.0 if rng.random() < 0.15 else rng.normal(size=2)
        graph.add_node(base + torch.as_tensor(offset), parent)
        return
    before = graph.alive.clone()
    freed = graph.remove_bv(int(rng.choice(bvs)))
    assert sorted(freed) == (before & ~graph.alive).nonzero().squeeze(1).tolist()


@pytest.mark.parametrize("seed", range(6))
def test_random_insertions_and_deletions_keep_exact_forest(seed: int) -> None:
    rng = np.random.default_rng(seed)
    max_bv = 20
    graph = BVGraph(2 * (max_bv + 1), 2)
    saw_routing = False
    for _ in range(400):
        random_operation(graph, rng, max_bv)
        assert_valid_forest(graph)
        saw_routing |= bool((graph.alive & ~graph.is_bv).any())
    assert saw_routing


def test_remove_of_non_bv_and_overfull_insert_raise() -> None:
    graph = BVGraph(2, 1)
    a = graph.add_node(torch.zeros(1, dtype=torch.float64))
    graph.add_node(torch.ones(1, dtype=torch.float64), a)
    with pytest.raises(RuntimeError, match="full"):
        graph.add_node(torch.ones(1, dtype=torch.float64), a)
    graph.remove_bv(a)  # a leaf: freed
    with pytest.raises(ValueError, match="not a basis vector"):
        graph.remove_bv(a)


# -- the graph as the GP maintains it -----------------------------------------------------------
@pytest.mark.parametrize("edges", ["trajectory", "nearest"])
def test_gp_graph_stays_exact_forest_under_deletions(pendulum, edges: str) -> None:
    obs, returns, starts = pendulum(3000, 11)
    max_basis = 16
    gp = SparseOnlineGP(
        3, GeodesicKernel(edges=edges), max_basis=max_basis, novelty_tol=0.02, noise_var=0.05
    )
    for i in range(0, len(obs), 100):
        gp.update(obs[i : i + 100], returns[i : i + 100], starts[i : i + 100])
        graph, m = gp.graph, gp.n_basis
        assert graph is not None
        assert_valid_forest(graph)
        assert graph.n_nodes <= 2 * (max_basis + 1)
        bv_nodes = graph.basis_nodes[:m]
        assert sorted(bv_nodes.tolist()) == graph.is_bv.nonzero().squeeze(1).tolist()
        scaled = (gp.basis_inputs / gp.lengthscale).numpy()
        np.testing.assert_allclose(graph.pos[bv_nodes].numpy(), scaled, rtol=1e-12)
        # A path is never shorter than the straight line between its ends.
        euclid = np.linalg.norm(scaled[:, None] - scaled[None], axis=-1)
        assert (gp.shortest_paths.numpy() >= euclid - 1e-12).all()
    assert int(gp.n_deleted) > 0


def test_without_episode_starts_every_bv_joins_its_nearest(pendulum) -> None:
    """No trajectory information: ``edges="trajectory"`` builds the ``edges="nearest"`` tree."""
    obs, returns, starts = pendulum(3000, 11)
    blind = SparseOnlineGP(3, GeodesicKernel(edges="trajectory"), max_basis=30)
    nearest = SparseOnlineGP(3, GeodesicKernel(edges="nearest"), max_basis=30)
    with_starts = SparseOnlineGP(3, GeodesicKernel(edges="trajectory"), max_basis=30)
    for i in range(0, len(obs), 500):
        blind.update(obs[i : i + 500], returns[i : i + 500])
        for gp in (nearest, with_starts):
            gp.update(obs[i : i + 500], returns[i : i + 500], starts[i : i + 500])
    assert torch.equal(blind.graph.adjacency, nearest.graph.adjacency)
    assert torch.equal(blind.graph.shortest_paths, nearest.graph.shortest_paths)
    # ... while trajectory information does change the tree.
    assert not torch.equal(with_starts.graph.adjacency, nearest.graph.adjacency)


@pytest.mark.parametrize("seed", range(4))
def test_restore_undoes_any_changes_since_the_checkpoint(seed: int) -> None:
    """A checkpoint copies only the slots in use; restoring gives every buffer back exactly."""
    rng = np.random.default_rng(100 + seed)
    graph = BVGraph(40, 2)
    for _ in range(25):
        random_operation(graph, rng, max_bv=15)
    before = {k: v.clone() for k, v in graph.state_dict().items()}
    saved = graph.checkpoint()
    for _ in range(30):
        random_operation(graph, rng, max_bv=18)
    graph.restore(saved)
    for key, value in graph.state_dict().items():
        assert torch.equal(value, before[key]), key
    assert_valid_forest(graph)


# -- per-dimension rescaling ---------------------------------------------------------------------
def straight_edges(graph: BVGraph) -> np.ndarray:
    """Edges (slot pairs, upper triangle) as long as the distance between their ends."""
    adj, length, pos = graph.adjacency.numpy(), graph.edge_length.numpy(), graph.pos.numpy()
    a, b = np.nonzero(np.triu(adj))
    chord = np.linalg.norm(pos[a] - pos[b], axis=1)
    straight = np.isclose(length[a, b], chord, rtol=1e-12, atol=1e-12)
    return np.stack([a[straight], b[straight]], axis=1)


@pytest.mark.parametrize("seed", range(4))
def test_per_dimension_rescale_keeps_the_forest_exact(seed: int) -> None:
    """After random insertions and deletions (contracted chains among them), per-dimension
    factors leave an exact forest (vs scipy), straight edges as long as their new chords, and
    every contracted edge stretched as its chord."""
    rng = np.random.default_rng(seed)
    graph = BVGraph(42, 2)
    for _ in range(300):
        random_operation(graph, rng, 20)
    straight = straight_edges(graph)
    adj = graph.adjacency.numpy()
    a, b = np.nonzero(np.triu(adj))
    pos, length = graph.pos.numpy().copy(), graph.edge_length.numpy().copy()
    factor = torch.tensor([0.5, 3.0], dtype=torch.float64)
    graph.rescale(factor)
    assert_valid_forest(graph)
    new_pos = graph.pos.numpy()
    np.testing.assert_allclose(new_pos[graph.alive.numpy()], pos[graph.alive.numpy()] / [0.5, 3.0])
    new_length = graph.edge_length.numpy()
    i, j = straight.T
    np.testing.assert_allclose(
        new_length[i, j], np.linalg.norm(new_pos[i] - new_pos[j], axis=1), rtol=1e-12, atol=1e-12
    )
    chord, new_chord = (np.linalg.norm(p[a] - p[b], axis=1) for p in (pos, new_pos))
    moved = chord > 0
    np.testing.assert_allclose(
        new_length[a, b][moved], length[a, b][moved] * new_chord[moved] / chord[moved], rtol=1e-12
    )
    np.testing.assert_allclose(new_length[a, b][~moved], length[a, b][~moved] / np.sqrt(1.5))


def test_equal_factors_rescale_as_one_factor() -> None:
    graphs = [BVGraph(42, 2) for _ in range(2)]
    for graph in graphs:
        rng = np.random.default_rng(7)
        for _ in range(200):
            random_operation(graph, rng, 20)
    graphs[0].rescale(torch.tensor([2.0, 2.0], dtype=torch.float64))
    graphs[1].rescale(torch.tensor([2.0], dtype=torch.float64))
    for name, buffer in graphs[0].named_buffers():
        assert torch.equal(buffer, dict(graphs[1].named_buffers())[name]), name
