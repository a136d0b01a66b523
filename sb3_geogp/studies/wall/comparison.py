"""Geodesic vs Euclidean kernels on the two-room value function, across basis-set sizes.

Every model is a :class:`~sb3_geogp.SparseOnlineGP` fitted in one pass over the same walks
(:func:`sb3_geogp.studies.wall.rooms.goal_walks`, with their episode starts) and the same
:class:`FitSettings`; only the kernel (and, for one control, the prediction rule) differs.
Errors are measured against the exact value on a dense grid of the whole box and on the band
``|x - wall_x| < band`` around the wall.

Models (:data:`MODELS`):

* ``rbf``: :class:`~sb3_geogp.RBFKernel`, ``exp(-r^2/2)`` on Euclidean distance;
* ``euclid_laplacian``: :class:`LaplacianKernel`, ``exp(-r)`` on Euclidean distance,
  the control that separates the effect of the geodesic distance from that of the profile;
* ``euclid_lap_shepard``: the same kernel, predicting by the geodesic kernel's Shepard
  interpolation of the basis-vector posterior means (the ``"shepard"`` prediction rule of
  :mod:`sb3_geogp.toolbox.shepard`): a control for the attachment as well;
* ``geo_*``: :class:`~sb3_geogp.GeodesicKernel` variants, ``geo_default`` being its defaults
  (Laplacian profile, Shepard interpolation, trajectory edges);
* the oracle (:mod:`~sb3_geogp.studies.wall.oracle`): ``geo_wall_aware``, ``geo_default``
  whose attachments never cross the wall, and its Euclidean control ``euclid_lap_shepard_wall``,
  ``euclid_lap_shepard`` predicting from the basis vectors on its own side of the wall.
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, NamedTuple

import numpy as np

from sb3_geogp import GeodesicKernel, RBFKernel, SparseOnlineGP
from sb3_geogp.kernels import Kernel, LaplacianKernel
from sb3_geogp.studies.wall.oracle import WallAwareGeodesicKernel, blocked_pairs
from sb3_geogp.studies.wall.rooms import TwoRooms, WalkData, goal_walks
from sb3_geogp.toolbox.shepard import PredictionRule, predict_mean
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.streams import fit_online
from sb3_geogp.toolbox.tables import (
    MIN_SAMPLES_FOR_INTERVAL,
    NO_INTERVAL,
    estimate_cell,
    markdown_table,
)

#: Grid points predicted at a time (bounds the memory of the Shepard interpolation).
PREDICT_CHUNK = 2048


class ModelSpec(NamedTuple):
    """How to build and query one compared model: a kernel factory (taking the lengthscale and
    the rooms), the prediction rule, and whether that rule's Shepard neighbours may not cross
    the wall (the oracle)."""

    kernel: Callable[[float, TwoRooms], Kernel]
    rule: PredictionRule = "gp"
    wall_aware: bool = False


def _blind(factory: Callable[[float], Kernel]) -> Callable[[float, TwoRooms], Kernel]:
    """A kernel factory that does not know the rooms (every model but the oracle's)."""
    return lambda lengthscale, rooms: factory(lengthscale)


#: Model name -> specification.
MODELS: dict[str, ModelSpec] = {
    "rbf": ModelSpec(_blind(RBFKernel)),
    "euclid_laplacian": ModelSpec(_blind(LaplacianKernel)),
    "euclid_lap_shepard": ModelSpec(_blind(LaplacianKernel), "shepard"),
    "geo_default": ModelSpec(_blind(GeodesicKernel)),
    "geo_lap_nearest": ModelSpec(_blind(functools.partial(GeodesicKernel, attach="nearest"))),
    "geo_gauss_interp": ModelSpec(_blind(functools.partial(GeodesicKernel, profile="gaussian"))),
    "geo_gauss_nearest": ModelSpec(
        _blind(functools.partial(GeodesicKernel, profile="gaussian", attach="nearest"))
    ),
    "geo_nn_edges": ModelSpec(_blind(functools.partial(GeodesicKernel, edges="nearest"))),
    "geo_wall_aware": ModelSpec(WallAwareGeodesicKernel),
    "euclid_lap_shepard_wall": ModelSpec(_blind(LaplacianKernel), "shepard", wall_aware=True),
}

METRICS = (
    "mse",
    "mse_wall",
    "wall_across_frac",
    "wall_across_err_share",
    "shortcut_frac",
    "n_basis",
    "seconds",
)


@dataclass(frozen=True)
class FitSettings:
    """Hyperparameters shared by every model (fixed, not fitted).

    Attributes
    ----------
    lengthscale : float
        Kernel lengthscale in state units (both coordinates).
    noise_var : float
        Observation-noise variance in standardised target units.
    novelty_tol : float or None
        Relative novelty for a point to become a basis vector; ``None`` is the library default,
        the novelty of a point a quarter lengthscale from one basis vector (the same spacing
        for every profile).
    """

    lengthscale: float = 0.2
    noise_var: float = 0.01
    novelty_tol: float | None = None


@dataclass(frozen=True)
class WalkSettings:
    """Data of one seed: :func:`goal_walks` arguments other than the seed."""

    n_episodes: int = 100
    step_size: float = 0.05
    step_noise: float = 0.03
    target_noise: float = 0.05

    def generate(self, rooms: TwoRooms, seed: int) -> WalkData:
        """The walks of ``seed``."""
        return goal_walks(rooms, seed=seed, **asdict(self))


@dataclass
class ComparisonResult:
    """Raw per-seed results of :func:`run_comparison`.

    Attributes
    ----------
    max_basis : list of int
    seeds : list of int
    values : dict
        ``values[model][metric]`` is a list (one per ``max_basis``) of lists (one per seed).
    config : dict
        Settings used (for the JSON record).
    """

    max_basis: list[int]
    seeds: list[int]
    values: dict[str, dict[str, list[list[float]]]] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)

    def array(self, model: str, metric: str) -> np.ndarray:
        """Results of one model and metric, shape (len(max_basis), len(seeds))."""
        return np.asarray(self.values[model][metric], dtype=np.float64)


def fit_gp(
    model: str,
    data: WalkData,
    max_basis: int,
    settings: FitSettings,
    episodes_per_batch: int | None = None,
    rooms: TwoRooms | None = None,
) -> SparseOnlineGP:
    """Fit one model to the walks in a single on-line pass (with episode starts).

    Parameters
    ----------
    model : str
        Key of :data:`MODELS`.
    data : WalkData
    max_basis : int
        Basis capacity.
    settings : FitSettings
    episodes_per_batch : int, optional
        Walks per ``update`` call (as an RL critic would see rollouts); ``None`` = one call.
    rooms : TwoRooms, optional
        The geometry the walks ran in (the oracle's wall); ``TwoRooms()`` if ``None``.

    Returns
    -------
    SparseOnlineGP
        Query it as :func:`evaluate` does, with the model's prediction rule.
    """
    return fit_online(
        MODELS[model].kernel(settings.lengthscale, rooms or TwoRooms()),
        data.states,
        data.targets,
        data.episode_starts,
        max_basis=max_basis,
        noise_var=settings.noise_var,
        novelty_tol=settings.novelty_tol,
        episodes_per_batch=episodes_per_batch,
    )


def shortcut_fraction(gp: SparseOnlineGP, rooms: TwoRooms) -> float:
    """Fraction of basis-vector pairs whose graph distance undercuts the true geodesic.

    A graph path shorter than the shortest wall-avoiding path must use an edge through the
    wall. 0 for a kernel without a graph (NaN with fewer than 2 basis vectors).
    """
    if gp.graph is None:
        return 0.0
    m = gp.n_basis
    if m < 2:
        return math.nan
    bv = gp.basis_inputs.cpu().numpy()
    graph = (gp.shortest_paths * gp.lengthscale[0]).cpu().numpy()
    true = rooms.geodesic(bv[:, None, :], bv[None, :, :])
    iu = np.triu_indices(m, 1)
    return float(np.mean(graph[iu] < true[iu] * (1 - 1e-9) - 1e-12))


def evaluate(
    gp: SparseOnlineGP,
    rooms: TwoRooms,
    grid: np.ndarray,
    band: float,
    rule: PredictionRule = "gp",
    wall_aware: bool = False,
) -> dict[str, float]:
    """Error metrics of a fitted GP on the grid (all of :data:`METRICS` but ``seconds``).

    ``mse`` and ``mse_wall`` are the squared errors of its predictions under ``rule`` (its
    Shepard neighbours kept on the query's side of the wall if ``wall_aware``) against
    the exact value over the grid and over its near-wall band. ``wall_across_frac`` is the
    fraction of band points whose nearest basis vector lies across the wall,
    ``wall_across_err_share`` their share of the band's summed squared error;
    ``shortcut_frac`` is :func:`shortcut_fraction`.
    """
    blocked = functools.partial(blocked_pairs, rooms) if wall_aware else None
    err2 = (predict_mean(gp, grid, rule, PREDICT_CHUNK, blocked) - rooms.value(grid)) ** 2
    near = rooms.near_wall(grid, band)
    band_pts, band_err2 = grid[near], err2[near]
    bv = gp.basis_inputs.cpu().numpy()
    nearest = bv[np.linalg.norm(band_pts[:, None] - bv[None], axis=-1).argmin(axis=1)]
    across = rooms.crosses_wall(band_pts, nearest)
    return {
        "mse": float(err2.mean()),
        "mse_wall": float(band_err2.mean()),
        "wall_across_frac": float(across.mean()),
        "wall_across_err_share": float(band_err2[across].sum() / max(band_err2.sum(), 1e-300)),
        "shortcut_frac": shortcut_fraction(gp, rooms),
        "n_basis": float(gp.n_basis),
    }


def run_comparison(
    max_basis: Sequence[int] = (10, 20, 40, 80, 160),
    seeds: Sequence[int] = (0, 1, 2, 3, 4),
    models: Sequence[str] = tuple(MODELS),
    rooms: TwoRooms | None = None,
    fit: FitSettings | None = None,
    walks: WalkSettings | None = None,
    grid_nx: int = 120,
    band: float = 0.1,
    episodes_per_batch: int | None = None,
    progress: Callable[[Iterable[Any]], Iterable[Any]] | None = None,
) -> ComparisonResult:
    """Fit every model at every basis size on the walks of every seed; record grid errors.

    Parameters
    ----------
    max_basis : sequence of int
        Basis capacities swept.
    seeds : sequence of int
        One data set per seed, shared by all models and capacities.
    models : sequence of str
        Keys of :data:`MODELS`.
    rooms, fit, walks : optional
        Domain, shared hyperparameters and data settings (defaults if ``None``).
    grid_nx : int
        Columns of the evaluation grid (square cells over the whole box).
    band : float
        Half-width of the near-wall band, ``|x - wall_x| < band``.
    episodes_per_batch : int, optional
        Walks per ``update`` call (see :func:`fit_gp`); ``None`` = all in one call.
    progress : callable, optional
        Wraps the iterable of jobs (e.g. ``tqdm.tqdm``) to show progress.

    Returns
    -------
    ComparisonResult
        Metrics :data:`METRICS` per model, capacity and seed.
    """
    rooms, fit, walks = rooms or TwoRooms(), fit or FitSettings(), walks or WalkSettings()
    grid, _ = rooms.grid(grid_nx)
    result = ComparisonResult(list(max_basis), list(seeds))
    result.values = {m: {k: [[] for _ in max_basis] for k in METRICS} for m in models}
    result.config = {
        "rooms": asdict(rooms),
        "fit": asdict(fit),
        "walks": asdict(walks),
        "grid_nx": grid_nx,
        "band": band,
        "episodes_per_batch": episodes_per_batch,
        "models": list(models),
    }
    jobs = [(s, i, m) for s in seeds for i in range(len(max_basis)) for m in models]
    data: dict[int, WalkData] = {}
    for seed, i, model in progress(jobs) if progress else jobs:
        if seed not in data:
            data[seed] = walks.generate(rooms, seed)
        start = time.perf_counter()
        spec = MODELS[model]
        gp = fit_gp(model, data[seed], max_basis[i], fit, episodes_per_batch, rooms)
        metrics = evaluate(gp, rooms, grid, band, spec.rule, spec.wall_aware)
        metrics["seconds"] = time.perf_counter() - start
        for key in METRICS:
            result.values[model][key][i].append(metrics[key])
    return result


def summarize(result: ComparisonResult) -> dict[str, dict[str, dict[str, list[float]]]]:
    """``summary[model][metric] = {"mean": [...], "ci95": [...]}`` over seeds, per capacity."""
    out: dict[str, dict[str, dict[str, list[float]]]] = {}
    for model in result.values:
        out[model] = {}
        for metric in METRICS:
            mean, ci = mean_ci(result.array(model, metric), nan_policy="propagate")
            out[model][metric] = {"mean": mean.tolist(), "ci95": ci.tolist()}
    return out


def paired_ratio(result: ComparisonResult, model: str, reference: str, metric: str) -> np.ndarray:
    """Per-seed error ratio ``model / reference``, shape (len(max_basis), len(seeds))."""
    return result.array(model, metric) / result.array(reference, metric)


def paired_table(
    result: ComparisonResult,
    model: str = "geo_default",
    references: Sequence[str] = (
        "rbf",
        "euclid_laplacian",
        "euclid_lap_shepard",
        "geo_lap_nearest",
    ),
) -> str:
    """Same-seed MSE ratios of ``model`` to each reference, overall and near the wall.

    Each cell: geometric mean of the per-seed ratios, their range, and in how many seeds
    ``model`` had the smaller error (ratio < 1 means ``model`` is better).
    """
    refs = [r for r in references if r in result.values and r != model]
    rows = []
    for ref, metric in itertools.product(refs, ("mse", "mse_wall")):
        ratio = paired_ratio(result, model, ref, metric)
        cells = [
            f"{np.exp(np.log(r).mean()):.2f} [{r.min():.2f}, {r.max():.2f}] "
            f"{(r < 1).sum()}/{r.size}"
            for r in ratio
        ]
        rows.append([ref, metric, *cells])
    caps = result.max_basis
    header = [f"{model} / reference", "metric", *(f"max_basis {m}" for m in caps)]
    return markdown_table(header, rows, align="ll" + "r" * len(caps))


def summary_table(result: ComparisonResult) -> str:
    """One row per model and capacity: mean ± 95% CI half-width over seeds of the errors,
    then the means of the diagnostics (see :func:`evaluate`).

    With fewer than :data:`~sb3_geogp.toolbox.tables.MIN_SAMPLES_FOR_INTERVAL` seeds the error
    cells give the mean alone (:func:`~sb3_geogp.toolbox.tables.estimate_cell`), and a note
    under the table says so.
    """
    rows = []
    for model in result.values:
        cell = {k: mean_ci(result.array(model, k), nan_policy="propagate") for k in METRICS}
        n = result.array(model, "mse").shape[-1]  # seeds per capacity
        for i, m in enumerate(result.max_basis):
            mean = {k: float(v[0][i]) for k, v in cell.items()}
            rows.append(
                [
                    model,
                    str(m),
                    *(
                        estimate_cell(f"{mean[k]:.4f}", f"± {cell[k][1][i]:.4f}", n)
                        for k in ("mse", "mse_wall")
                    ),
                    f"{mean['n_basis']:.0f}",
                    f"{mean['wall_across_frac']:.0%} ({mean['wall_across_err_share']:.0%})",
                    f"{mean['shortcut_frac']:.2%}",
                    f"{mean['seconds']:.2f}",
                ]
            )
    header = [
        "model", "max_basis", "MSE", "MSE near wall", "BVs",
        "band pts w/ nearest BV across wall (share of band error)", "shortcut BV pairs", "s/fit",
    ]  # fmt: skip
    table = markdown_table(header, rows, align="lrrrrrrr")
    if NO_INTERVAL not in table:
        return table
    return (
        f"{table}\n\nWith fewer than {MIN_SAMPLES_FOR_INTERVAL} seeds the MSE cells give the mean "
        f'alone ("{NO_INTERVAL}").'
    )
