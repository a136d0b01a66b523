"""Kernels: closed forms, definiteness on trees, and the Shepard interpolation weights."""

from __future__ import annotations

import typing

import numpy as np
import pytest
import torch
from scipy.spatial.distance import cdist

from sb3_geogp import SparseOnlineGP
from sb3_geogp.graph import BVGraph
from sb3_geogp.kernels import (
    KERNELS,
    GeodesicKernel,
    Gram,
    KernelName,
    LaplacianKernel,
    MaternKernel,
    RBFKernel,
    make_kernel,
    shepard_weights,
)
from sb3_geogp.kernels.base import PRODUCT_MIN_DIM, DenseRows, Kernel, distances
from tests.test_sparse_gp import assert_same_state, matern, snapshot


# -- independent references ---------------------------------------------------------------------
def random_tree(
    rng: np.random.Generator, n_nodes: int, dim: int = 3
) -> tuple[BVGraph, np.ndarray, np.ndarray]:
    """Tree grown by random leaf attachments with random edge lengths.

    Returns the engine's graph, the node positions and the tree metric accumulated directly
    (``SP[u, .] = length + SP[parent, .]``, which is exact for a leaf).
    """
    graph = BVGraph(n_nodes, dim)
    pos = np.zeros((n_nodes, dim))
    sp = np.zeros((n_nodes, n_nodes))
    slots = [graph.add_node(torch.as_tensor(pos[0]))]
    for u in range(1, n_nodes):
        parent = int(rng.integers(u))
        length = rng.uniform(0.05, 1.5)
        direction = rng.standard_normal(dim)
        pos[u] = pos[parent] + length * direction / np.linalg.norm(direction)
        sp[u, :u] = sp[parent, :u] + length
        sp[:u, u] = sp[u, :u]
        slots.append(graph.add_node(torch.as_tensor(pos[u]), slots[parent]))
    assert slots == list(range(n_nodes))
    return graph, pos, sp


def on_tree(kernel: GeodesicKernel, graph: BVGraph, pos: np.ndarray) -> torch.Tensor:
    """Give ``kernel`` the tree ``graph`` (every node a BV) and return the basis inputs."""
    kernel.bind(pos.shape[1], graph.capacity)
    kernel.tree = graph
    return torch.as_tensor(pos)


def dense_weights(dist: np.ndarray, k: int) -> np.ndarray:
    """The engine's Shepard weights scattered into an (n, m) matrix."""
    idx, w = shepard_weights(torch.as_tensor(dist), k)
    out = torch.zeros(dist.shape, dtype=w.dtype)
    out.scatter_add_(1, idx, w)
    return out.numpy()


def gram_eigmin(kernel: GeodesicKernel, graph: BVGraph, pos: np.ndarray) -> float:
    return float(torch.linalg.eigvalsh(kernel.gram(on_tree(kernel, graph, pos))).min())


# -- RBF ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", [3, PRODUCT_MIN_DIM, 500])
@pytest.mark.parametrize("offset", [0.0, 1e7])
def test_distances_match_coordinate_differences(dim: int, offset: float) -> None:
    """Both formulas of ``distances`` against scipy's coordinate differences, 1e7 from the
    origin too: within 1e-13 of the largest distance, and a point on another within 1e-7 of
    it (the product formula's rounding; the differences give exactly 0)."""
    rng = np.random.default_rng(dim)
    a, b = rng.normal(size=(70, dim)) + offset, rng.normal(size=(40, dim)) + offset
    a[:5] = b[:5]
    got = distances(torch.as_tensor(a), torch.as_tensor(b)).numpy()
    expected = cdist(a, b)
    apart = ~np.eye(70, 40, dtype=bool)
    assert np.abs(got - expected)[apart].max() <= 1e-13 * expected.max()
    on_points = np.diag(got[:5, :5]).max()
    assert on_points <= 1e-7 * expected.max() if dim >= PRODUCT_MIN_DIM else on_points == 0.0


def test_rbf_gram_and_cross_match_closed_form() -> None:
    rng = np.random.default_rng(0)
    ls, variance = np.array([0.5, 2.0, 1.3]), 1.7
    kernel = RBFKernel(lengthscale=ls.tolist(), variance=variance)
    kernel.bind(3, 5)
    x, b = rng.normal(size=(7, 3)), rng.normal(size=(5, 3))

    def expected(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return variance * np.exp(-0.5 * (((u[:, None] - v[None]) / ls) ** 2).sum(-1))

    z = kernel.scale(torch.as_tensor(b))
    cross = kernel.cross(kernel.scale(torch.as_tensor(x)), z).numpy()
    np.testing.assert_allclose(cross, expected(x, b), rtol=1e-12)
    np.testing.assert_allclose(kernel.gram(z).numpy(), expected(b, b), rtol=1e-12)


# -- Matérn ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("nu", [0.5, 1.5, 2.5])
def test_matern_gram_and_cross_match_closed_form(nu: float) -> None:
    rng = np.random.default_rng(0)
    ls, variance = np.array([0.5, 2.0, 1.3]), 1.7
    kernel = make_kernel("matern", nu=nu, lengthscale=ls.tolist(), variance=variance)
    kernel.bind(3, 5)
    x, b = rng.normal(size=(7, 3)), rng.normal(size=(5, 3))
    z = kernel.scale(torch.as_tensor(b))
    cross = kernel.cross(kernel.scale(torch.as_tensor(x)), z).numpy()
    np.testing.assert_allclose(cross, matern(x, b, ls, variance, nu), rtol=1e-12)
    np.testing.assert_allclose(kernel.gram(z).numpy(), matern(b, b, ls, variance, nu), rtol=1e-12)
    assert float(torch.linalg.eigvalsh(kernel.gram(z)).min()) > 0


def test_matern_one_half_is_the_laplacian_kernel_and_allows_float32() -> None:
    x = torch.as_tensor(np.random.default_rng(1).normal(size=(6, 2)))
    half, laplace = MaternKernel(nu=0.5, lengthscale=0.7), LaplacianKernel(lengthscale=0.7)
    for kernel in (half, laplace):
        kernel.bind(2, 6)
    np.testing.assert_array_equal(half.gram(half.scale(x)), laplace.gram(laplace.scale(x)))
    SparseOnlineGP(2, half, dtype=torch.float32)
    with pytest.raises(ValueError, match="not numerically safe in float32"):
        SparseOnlineGP(2, MaternKernel(nu=2.5), dtype=torch.float32)


@pytest.mark.parametrize("nu", [2.0, 0.0, float("nan"), True, "2.5"], ids=str)
def test_matern_rejects_a_smoothness_without_closed_form(nu: object) -> None:
    with pytest.raises(ValueError, match=r"nu must be one of \[0.5, 1.5, 2.5\]"):
        MaternKernel(nu=nu)  # type: ignore[arg-type]


def test_a_state_of_another_matern_smoothness_is_refused_and_the_same_loads_exactly() -> None:
    x = np.random.default_rng(2).normal(size=(60, 2))
    gp = SparseOnlineGP(2, MaternKernel(nu=1.5), max_basis=16, adapt=True)
    gp.update(x, np.sin(x[:, 0]))
    other = SparseOnlineGP(2, MaternKernel(nu=2.5), max_basis=16, adapt=True)
    before = snapshot(other)
    with pytest.raises(ValueError, match="nu"):
        other.load_state_dict(gp.state_dict())
    assert_same_state(before, snapshot(other))
    same = SparseOnlineGP(2, MaternKernel(nu=1.5), max_basis=16, adapt=True)
    same.load_state_dict(gp.state_dict())
    probe = torch.as_tensor(x[:9])
    for got, want in zip(same.predict(probe), gp.predict(probe), strict=True):
        assert torch.equal(got, want)


# -- geodesic kernel: rows ----------------------------------------------------------------------
@pytest.fixture
def small_tree() -> tuple[BVGraph, np.ndarray, np.ndarray]:
    return random_tree(np.random.default_rng(1), 12, dim=2)


def tree_metric(pos: np.ndarray, parents: list[int]) -> np.ndarray:
    """Tree metric of straight edges between ``pos``, node ``u`` a leaf of ``parents[u]``."""
    n = len(pos)
    sp = np.zeros((n, n))
    for u in range(1, n):
        p = parents[u]
        sp[u, :u] = sp[p, :u] + np.linalg.norm(pos[u] - pos[p])
        sp[:u, u] = sp[u, :u]
    return sp


@pytest.mark.parametrize("attach", ["interpolate", "nearest"])
@pytest.mark.parametrize("ard", [True, False])
def test_geodesic_fit_correlations_are_the_rescaled_kernel(attach: str, ard: bool) -> None:
    """What the hyperparameter fit differentiates is the kernel after :meth:`rescale`: a tree
    metric of the edges in the new lengthscale units, attachments recomputed there."""
    rng = np.random.default_rng(3)
    parents = [0] + [int(rng.integers(u)) for u in range(1, 15)]
    pos = np.zeros((15, 3))
    for u in range(1, 15):
        pos[u] = pos[parents[u]] + rng.normal(size=3)
    graph = BVGraph(30, 3)
    for u in range(15):
        graph.add_node(torch.as_tensor(pos[u]), None if u == 0 else parents[u])
    kernel = GeodesicKernel(lengthscale=1.0, attach=attach, ard=ard)
    z = on_tree(kernel, graph, pos)
    x = torch.as_tensor(pos[rng.integers(15, size=40)] + 0.3 * rng.normal(size=(40, 3)))
    n_factors, correlations = kernel.correlation_fn(x, z)
    assert n_factors == (3 if ard else 1)
    log_f = torch.log(torch.tensor([0.6, 2.0, 1.3] if ard else [1.7], dtype=torch.float64))
    log_f.requires_grad_(True)
    R_xz, R_zz = correlations(log_f)
    R_zz.sum().backward()
    assert log_f.grad is not None and torch.isfinite(log_f.grad).all()
    kernel.rescale(log_f.detach().exp())
    scaled = pos / np.exp(log_f.detach().numpy())
    np.testing.assert_allclose(R_zz.detach(), np.exp(-tree_metric(scaled, parents)), rtol=1e-12)
    np.testing.assert_allclose(R_zz.detach(), kernel.gram(z), rtol=1e-12, atol=1e-15)
    rows = kernel.cross(kernel.scale(x), kernel.scale(z))  # the kernel's rows take scaled inputs
    np.testing.assert_allclose(R_xz.detach(), rows, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("profile", ["laplacian", "gaussian"])
def test_geodesic_gram_is_profile_of_tree_metric(small_tree, profile: str) -> None:
    graph, pos, sp = small_tree
    kernel = GeodesicKernel(lengthscale=1.0, variance=0.7, profile=profile)
    rho = np.exp(-sp) if profile == "laplacian" else np.exp(-0.5 * sp**2)
    np.testing.assert_allclose(
        kernel.gram(on_tree(kernel, graph, pos)).numpy(), 0.7 * rho, rtol=1e-12
    )


def test_geodesic_nearest_attach_goes_through_nearest_bv(small_tree) -> None:
    graph, pos, sp = small_tree
    kernel = GeodesicKernel(lengthscale=1.0, attach="nearest")
    x = np.random.default_rng(2).normal(size=(20, 2))
    dist = cdist(x, pos)
    nearest = dist.argmin(axis=1)
    expected = np.exp(-(dist[np.arange(20), nearest][:, None] + sp[nearest]))
    z = on_tree(kernel, graph, pos)
    np.testing.assert_allclose(kernel.cross(torch.as_tensor(x), z).numpy(), expected, rtol=1e-12)
    novelty = kernel.novelty_rows(torch.as_tensor(x), z).dense(Gram(kernel.gram(z))).numpy()
    np.testing.assert_allclose(novelty, expected, rtol=1e-12)


@pytest.mark.parametrize("n_neighbors", [1, 4, 30])
def test_geodesic_interpolate_is_shepard_mix_of_bv_rows(
    small_tree, shepard_dense, n_neighbors: int
) -> None:
    graph, pos, sp = small_tree
    kernel = GeodesicKernel(lengthscale=1.0, attach="interpolate", n_neighbors=n_neighbors)
    x = np.random.default_rng(3).normal(size=(20, 2))
    expected = shepard_dense(cdist(x, pos), n_neighbors) @ np.exp(-sp)
    got = kernel.cross(torch.as_tensor(x), on_tree(kernel, graph, pos)).numpy()
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("attach", ["interpolate", "nearest"])
def test_geodesic_row_at_a_bv_is_its_gram_row(small_tree, attach: str) -> None:
    graph, pos, sp = small_tree
    kernel = GeodesicKernel(lengthscale=1.0, attach=attach)
    got = kernel.cross(torch.as_tensor(pos), on_tree(kernel, graph, pos)).numpy()
    np.testing.assert_allclose(got, np.exp(-sp), rtol=1e-12)


def test_geodesic_node_row_is_leaf_of_parent(small_tree) -> None:
    graph, pos, sp = small_tree
    kernel = GeodesicKernel(lengthscale=1.0)
    x, parent = np.array([0.3, -0.2]), 5
    expected = np.exp(-(np.linalg.norm(x - pos[parent]) + sp[parent]))
    z = on_tree(kernel, graph, pos)
    kernel.traj_node.fill_(parent)  # the trajectory's last BV is the parent
    rows, attachments = kernel.insertion_rows(torch.as_tensor(x)[None], z)
    assert list(attachments) == [parent]
    np.testing.assert_allclose(rows[0].numpy(), expected, rtol=1e-12)


def test_geodesic_rows_without_trajectory_hang_on_nearest_bv(small_tree) -> None:
    """Batched: with no trajectory predecessor each point is a leaf of its own nearest BV."""
    graph, pos, sp = small_tree
    kernel = GeodesicKernel(lengthscale=1.0)
    z = on_tree(kernel, graph, pos)
    x = np.random.default_rng(3).normal(size=(7, 2))
    nearest = np.linalg.norm(x[:, None] - pos[None], axis=2).argmin(axis=1)
    expected = np.exp(-(np.linalg.norm(x - pos[nearest], axis=1)[:, None] + sp[nearest]))
    rows, attachments = kernel.insertion_rows(torch.as_tensor(x), z)
    assert list(attachments) == nearest.tolist()
    np.testing.assert_allclose(rows.numpy(), expected, rtol=1e-12)


@pytest.mark.parametrize(
    ("kernel", "novelty"),
    [
        (RBFKernel(variance=2.0), lambda r: 1 - np.exp(-(r**2))),
        (GeodesicKernel(variance=2.0), lambda r: 1 - np.exp(-2 * r)),
        (GeodesicKernel(variance=2.0, profile="gaussian"), lambda r: 1 - np.exp(-(r**2))),
        (
            MaternKernel(nu=2.5, variance=2.0),
            lambda r: 1 - ((1 + 5**0.5 * r + 5 * r**2 / 3) * np.exp(-(5**0.5) * r)) ** 2,
        ),
    ],
)
def test_novelty_at_distance_from_a_single_bv(kernel, novelty) -> None:
    """``1 - k(r)^2 / k(0)^2``: the residual variance of a point given one BV at distance r."""
    for r in (0.0, 0.1, 0.25, 1.0, 3.0):
        assert kernel.novelty_at(r) == pytest.approx(novelty(r), rel=1e-12, abs=1e-15)


# -- definiteness on trees ----------------------------------------------------------------------
def test_laplacian_tree_kernel_is_positive_definite() -> None:
    rng = np.random.default_rng(4)
    kernel = GeodesicKernel(lengthscale=1.0, profile="laplacian")
    worst = min(
        gram_eigmin(kernel, *random_tree(rng, int(rng.integers(2, 40)))[:2]) for _ in range(200)
    )
    assert worst >= -1e-10


def test_gaussian_tree_kernel_is_not_positive_definite() -> None:
    """Why the Laplacian profile is the default: the paper's Gaussian one fails on trees."""
    rng = np.random.default_rng(5)
    kernel = GeodesicKernel(lengthscale=1.0, profile="gaussian")
    eig = [gram_eigmin(kernel, *random_tree(rng, int(rng.integers(5, 40)))[:2]) for _ in range(150)]
    assert min(eig) < -1e-2


# -- Shepard weights ----------------------------------------------------------------------------
@pytest.mark.parametrize("k", [1, 3, 10, 14])
def test_shepard_weights_match_formula_and_sum_to_one(shepard_dense, k: int) -> None:
    rng = np.random.default_rng(6)
    dist = cdist(rng.uniform(size=(40, 2)), rng.uniform(size=(10, 2)))
    got = dense_weights(dist, k)
    np.testing.assert_allclose(got, shepard_dense(dist, k), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(got.sum(axis=1), 1.0, rtol=1e-14)
    assert (got >= 0).all()
    assert ((got > 0).sum(axis=1) <= min(k, 10)).all()


def test_shepard_weights_are_one_hot_on_a_bv() -> None:
    bv = np.random.default_rng(7).uniform(size=(9, 2))
    np.testing.assert_allclose(dense_weights(cdist(bv, bv), 4), np.eye(9), rtol=0, atol=1e-15)


def test_shepard_weights_are_finite_where_more_than_k_basis_vectors_are_on_the_point() -> None:
    """k + 1 basis vectors (or more) on the point: equal weights on its k nearest, all on it
    (the radius, the (k+1)-th distance, was 0 too: the weights were 0 / 0)."""
    for k, on in ((1, 2), (2, 3), (4, 7)):
        dist = torch.tensor([[0.0] * on + [1.0, 2.0]], dtype=torch.float64)
        idx, w = shepard_weights(dist, k)
        assert bool(torch.isfinite(w).all())
        np.testing.assert_allclose(w.numpy(), np.full((1, k), 1.0 / k), rtol=1e-12)
        assert set(idx[0].tolist()) <= set(range(on))


def test_a_gp_predicts_on_coincident_basis_vectors() -> None:
    """Duplicates made basis vectors (novelty 0 judged a hair above 0 by rounding): the mean
    at the duplicated point is finite and the next batch there is absorbed (before: NaN, then
    every such batch refused)."""
    kernel = GeodesicKernel(lengthscale=1.0, profile="gaussian", n_neighbors=1)
    gp = SparseOnlineGP(1, kernel, max_basis=10, novelty_tol=0.0)
    x = np.array([[0.0], [1.0], [2.0], [0.0]])
    gp.update(x, np.sin(x[:, 0]), np.zeros(4, bool))
    assert gp.n_basis == 4  # the duplicate of 0 became a basis vector
    mean, var = gp.predict(np.zeros((1, 1)))
    assert bool(torch.isfinite(mean).all() and torch.isfinite(var).all())
    gp.update(np.array([[0.0], [0.5], [0.0]]), np.zeros(3))
    assert bool(torch.isfinite(gp.predict(np.zeros((1, 1)))[0]).all())


def test_shepard_weights_are_continuous_where_the_neighbour_set_changes() -> None:
    """Scan a line finely: where the k nearest change, the weights must barely move.

    Plain inverse-distance weights over the k nearest jump there; the modified weights vanish at
    the radius, so their change over one step is of the order of the step.
    """
    rng = np.random.default_rng(8)
    bv, k, step = rng.uniform(size=(15, 2)), 4, 1e-5
    t = np.arange(0.0, 1.0, step)[:, None]
    line = np.array([-0.1, 0.2]) + t * np.array([1.2, 0.5])
    dist = cdist(line, bv)
    nbrs = np.sort(np.argsort(dist, axis=1)[:, :k], axis=1)
    changes = np.flatnonzero((nbrs[1:] != nbrs[:-1]).any(axis=1))
    assert changes.size >= 5
    jump = np.abs(np.diff(dense_weights(dist, k), axis=0)).max(axis=1)
    assert jump[changes].max() < 1e-3
    naive = np.zeros_like(dist)
    np.put_along_axis(naive, nbrs, np.take_along_axis(dist, nbrs, axis=1) ** -2.0, axis=1)
    naive /= naive.sum(axis=1, keepdims=True)
    assert np.abs(np.diff(naive, axis=0)).max(axis=1)[changes].max() > 1e-2


# -- argument checking --------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"lengthscale": -1.0}, "lengthscale"),
        ({"lengthscale": [1.0, float("inf")]}, "lengthscale"),
        ({"variance": 0.0}, "variance"),
        ({"profile": "cauchy"}, "profile"),
        ({"attach": "far"}, "attach"),
        ({"edges": "all"}, "edges"),
        ({"n_neighbors": 0}, "n_neighbors"),
    ],
)
def test_geodesic_kernel_rejects_bad_options(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        GeodesicKernel(**kwargs)


@pytest.mark.parametrize("kernel", [RBFKernel, LaplacianKernel, MaternKernel, GeodesicKernel])
@pytest.mark.parametrize(
    "kwargs",
    [
        {"variance": True},
        {"variance": "1"},
        {"variance": None},
        {"variance": [1.0]},
        {"lengthscale": True},
        {"lengthscale": [0.5, True]},
        {"lengthscale": "0.5"},
        {"lengthscale": torch.tensor([True, False])},
    ],
    ids=str,
)
def test_a_hyperparameter_that_is_not_a_number_is_named(
    kernel: type[Kernel], kwargs: dict[str, typing.Any]
) -> None:
    """A bool is no 1.0, and a string no number: a TypeError names the option (as a command
    line or YAML file could give either)."""
    (name,) = kwargs
    with pytest.raises(TypeError, match=f"^{name} must be a number, got "):
        kernel(**kwargs)
    kernel(lengthscale=torch.tensor([0.5, 2.0]), variance=np.float32(2.0))  # numbers pass


def test_a_state_of_another_kernel_class_names_the_class() -> None:
    """An RBF state into a geodesic GP differs in options the RBF kernel does not have; the
    refusal names the class first, not an option the user could not give."""
    x = np.random.default_rng(0).normal(size=(40, 2))
    rbf = SparseOnlineGP(2, "rbf", max_basis=8)
    rbf.update(x, x[:, 0])
    with pytest.raises(ValueError, match=r"kernel option kernel='RBFKernel'.*'GeodesicKernel'"):
        SparseOnlineGP(2, "geodesic", max_basis=8).load_state_dict(rbf.state_dict())


def test_bind_rejects_lengthscale_of_wrong_length() -> None:
    with pytest.raises(ValueError, match="lengthscale has 2 entries"):
        RBFKernel(lengthscale=[1.0, 2.0]).bind(3, 8)


def test_kernel_with_the_one_row_insertion_method_is_refused() -> None:
    """0.3's ``insertion_row`` would be bypassed silently: the GP calls ``insertion_rows``."""
    with pytest.raises(TypeError, match="insertion_rows"):

        class OldKernel(RBFKernel):
            def insertion_row(self, x: torch.Tensor, z: torch.Tensor) -> object:
                return self.cross(x[None], z)[0], None


def test_kernel_names_are_the_kernels_make_kernel_builds() -> None:
    """The typed names and the registry are two lists: they must not drift apart."""
    assert set(typing.get_args(KernelName)) == set(KERNELS)
    for name in typing.get_args(KernelName):
        assert type(make_kernel(name)) is KERNELS[name]


def test_novelty_from_rows_only_where_the_screening_rows_are_the_prediction_rows() -> None:
    """An adapting GP screens a scored batch from its prediction rows only where the kernel's
    novelty rows are those rows: by default, not for a kernel that overrides ``novelty_rows``
    (its own screening is kept), and for the geodesic kernel only with ``attach="nearest"``
    (its ``rows`` are then its ``novelty_rows``; the GP's bit-for-bit check of the shared rows
    runs both geodesic settings, tests/test_sparse_gp.py)."""

    class OwnScreening(RBFKernel):
        def novelty_rows(self, x: torch.Tensor, z: torch.Tensor) -> DenseRows:
            return DenseRows(self.cross(x, z) ** 2)

    assert RBFKernel().novelty_from_rows and LaplacianKernel().novelty_from_rows
    assert not OwnScreening().novelty_from_rows
    assert not GeodesicKernel().novelty_from_rows
    assert GeodesicKernel(attach="nearest").novelty_from_rows


# -- geodesic kernel: blocked attachments -------------------------------------------------------
CUT = 1.2  # splits ``small_tree``'s 12 nodes 6 / 6


class HalfPlanes(GeodesicKernel):
    """Blocks every pair on opposite sides of the line ``x_0 = CUT`` (scaled inputs)."""

    def blocked(self, x: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        return (x[:, :1] > CUT) != (z[:, 0] > CUT)[None, :]


def test_blocked_pairs_are_never_attached(small_tree, shepard_dense) -> None:
    """Against the unblocked kernel's definitions applied to each point's own side only:
    Shepard rows over the visible basis vectors, the nearest visible one for a leaf and for a
    parent."""
    graph, pos, sp = small_tree
    x = np.random.default_rng(4).normal(size=(30, 2))
    same = (x[:, :1] > CUT) == (pos[:, 0] > CUT)[None, :]
    assert same.sum(axis=1).min() >= 5  # every point sees more than its 4 neighbours
    dist = np.where(same, cdist(x, pos), np.inf)
    nearest = dist.argmin(axis=1)
    xt = torch.as_tensor(x)

    kernel = HalfPlanes(lengthscale=1.0)
    z = on_tree(kernel, graph, pos)
    expected = np.stack(
        [shepard_dense(d[s][None], 4)[0] @ np.exp(-sp[s]) for d, s in zip(dist, same, strict=True)]
    )
    np.testing.assert_allclose(kernel.cross(xt, z).numpy(), expected, rtol=1e-10, atol=1e-14)
    leaf = np.exp(-(dist[np.arange(len(x)), nearest][:, None] + sp[nearest]))
    got = kernel.novelty_rows(xt, z).dense(Gram(kernel.gram(z))).numpy()
    np.testing.assert_allclose(got, leaf, rtol=1e-12)
    rows, parents = kernel.insertion_rows(xt, z)
    assert list(parents) == nearest.tolist()
    np.testing.assert_allclose(rows.numpy(), leaf, rtol=1e-12)


def test_a_point_that_sees_no_basis_vector_is_uncorrelated() -> None:
    """Every pair blocked: the leaf row vanishes (the point is as novel as without a basis)."""
    graph, pos, _ = random_tree(np.random.default_rng(5), 6, dim=2)
    pos[:, 0] = np.abs(pos[:, 0]) + CUT + 0.1  # every basis vector right of the line
    kernel = HalfPlanes(lengthscale=1.0)
    z = on_tree(kernel, graph, pos)
    left = torch.tensor([[-0.5, 0.0], [-2.0, 1.0]], dtype=torch.float64)
    novelty = kernel.novelty_rows(left, z).dense(Gram(kernel.gram(z)))
    assert bool((novelty == 0).all())
    # As a new basis vector it joins no one: a component of its own, uncorrelated with the
    # basis (before, every blocked row tied and it joined basis vector 0 across the line).
    rows, parents = kernel.insertion_rows(left, z)
    assert list(parents) == [None, None]
    assert bool((rows == 0).all())


def test_a_new_basis_vector_that_sees_none_starts_its_own_component() -> None:
    """Through the GP: a walk's first basis vector left of the line, all basis vectors right of
    it, has no edge; a later one beside it joins it, not the other side."""
    gp = SparseOnlineGP(2, HalfPlanes(lengthscale=1.0), max_basis=10, novelty_tol=0.1)
    gp.update(np.array([[3.0, 0.0], [2.0, 0.0]]), np.zeros(2), np.array([True, False]))
    gp.update(np.array([[-1.0, 0.0], [-1.5, 0.0]]), np.ones(2), np.array([True, False]))
    adjacency = gp.adjacency.numpy()
    assert adjacency.shape == (4, 4)
    # nodes 0-1 right of the line (one edge), 2-3 left of it (one edge), nothing between
    np.testing.assert_array_equal(adjacency[:2, 2:], 0)
    assert adjacency[0, 1] > 0 and adjacency[2, 3] > 0
    np.testing.assert_array_equal(gp.shortest_paths.numpy()[:2, 2:], np.inf)
