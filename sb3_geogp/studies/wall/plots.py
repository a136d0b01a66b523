"""Matplotlib figures of the wall study (value maps with basis vectors and graph, MSE curves).

Needs matplotlib (``pip install sb3_geogp[plot]``); callers choose the backend (e.g. Agg).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from sb3_geogp import SparseOnlineGP
from sb3_geogp.studies.wall.comparison import PREDICT_CHUNK, ComparisonResult
from sb3_geogp.studies.wall.rooms import TwoRooms, WalkData
from sb3_geogp.toolbox.shepard import PredictionRule, predict_mean
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.tables import MIN_SAMPLES_FOR_INTERVAL


def draw_walls(ax: Axes, rooms: TwoRooms) -> None:
    """Draw the box outline, the wall segments and the goal."""
    lo, hi = rooms.door
    w, h = rooms.width, rooms.height
    ax.plot([0, w, w, 0, 0], [0, 0, h, h, 0], color="k", lw=1)
    for y0, y1 in ((0.0, lo), (hi, h)):
        if y1 > y0:
            ax.plot([rooms.wall_x, rooms.wall_x], [y0, y1], color="k", lw=3)
    ax.plot(*rooms.goal, marker="*", color="gold", ms=14, mec="k")
    ax.set_xlim(-0.02, w + 0.02)
    ax.set_ylim(-0.02, h + 0.02)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def draw_map(
    ax: Axes, rooms: TwoRooms, values: np.ndarray, shape: tuple[int, int], title: str, **kw: Any
) -> Any:
    """Image of grid ``values`` (row-major ``shape``) over the box, with the walls."""
    image = ax.imshow(
        values.reshape(shape),
        origin="lower",
        extent=(0, rooms.width, 0, rooms.height),
        interpolation="nearest",
        **kw,
    )
    draw_walls(ax, rooms)
    ax.set_title(title, fontsize=10)
    return image


def draw_basis(ax: Axes, gp: SparseOnlineGP) -> None:
    """Basis vectors as dots and, for a geodesic GP, the BV graph's edges as lines."""
    if gp.graph is not None:
        nodes = gp.graph_nodes.cpu().numpy()
        i, j = np.triu(gp.adjacency.cpu().numpy() > 0).nonzero()
        segments = list(np.stack([nodes[i], nodes[j]], axis=1))
        ax.add_collection(LineCollection(segments, colors="w", linewidths=0.8, alpha=0.9))
    bv = gp.basis_inputs.cpu().numpy()
    ax.scatter(bv[:, 0], bv[:, 1], s=9, c="k", edgecolors="w", linewidths=0.5, zorder=3)


def draw_walks(ax: Axes, rooms: TwoRooms, data: WalkData, max_walks: int = 40) -> None:
    """The first ``max_walks`` training walks as lines (start marked)."""
    bounds = [*np.flatnonzero(data.episode_starts), len(data.states)]
    for a, b in list(itertools.pairwise(bounds))[:max_walks]:
        ax.plot(*data.states[a:b].T, lw=0.7, alpha=0.8)
        ax.plot(*data.states[a], "k.", ms=3)
    draw_walls(ax, rooms)


def value_maps(
    rooms: TwoRooms,
    data: WalkData,
    gps: dict[str, SparseOnlineGP],
    grid_nx: int = 160,
    band: float = 0.1,
    rules: Mapping[str, PredictionRule] | None = None,
) -> Figure:
    """Truth and each GP's mean (top row); the walks and each GP's abs. error (bottom row).

    Parameters
    ----------
    rooms : TwoRooms
    data : WalkData
        Training walks (bottom-left panel).
    gps : dict
        Title -> fitted GP; BVs (and graph edges) are drawn over its value map.
    grid_nx : int
        Columns of the plotted grid.
    band : float
        Half-width of the near-wall band whose MSE goes in the titles.
    rules : mapping, optional
        Title -> prediction rule of that GP (default ``"gp"``; ``"shepard"`` for the Shepard
        control, see :data:`~sb3_geogp.studies.wall.comparison.MODELS`).
    """
    grid, shape = rooms.grid(grid_nx)
    truth = rooms.value(grid)
    near = rooms.near_wall(grid, band)
    ncol = 1 + len(gps)
    fig = Figure(figsize=(4.2 * ncol, 4.6), layout="constrained")
    axes = fig.subplots(2, ncol)
    scale = {"vmin": float(truth.min()), "vmax": float(truth.max()), "cmap": "viridis"}
    image = draw_map(axes[0, 0], rooms, truth, shape, "truth V(s)", **scale)
    draw_walks(axes[1, 0], rooms, data)
    axes[1, 0].set_title(f"{int(data.episode_starts.sum())} walks (first 40 shown)", fontsize=10)
    err_image = None
    for col, (name, gp) in enumerate(gps.items(), start=1):
        mean = predict_mean(gp, grid, (rules or {}).get(name, "gp"), PREDICT_CHUNK)
        err = np.abs(mean - truth)
        mse, mse_wall = float((err**2).mean()), float((err[near] ** 2).mean())
        draw_map(axes[0, col], rooms, mean, shape, f"{name} ({gp.n_basis} BVs)", **scale)
        draw_basis(axes[0, col], gp)
        title = f"|error|: MSE {mse:.4f}, near wall {mse_wall:.4f}"
        err_image = draw_map(axes[1, col], rooms, err, shape, title, cmap="magma", vmin=0, vmax=1)
    fig.colorbar(image, ax=axes[0, :].tolist(), shrink=0.8, label="value")
    if err_image is not None:
        fig.colorbar(err_image, ax=axes[1, :].tolist(), shrink=0.8, label="|error|")
    return fig


def mse_curves(result: ComparisonResult, models: Sequence[str] | None = None) -> Figure:
    """MSE vs ``max_basis`` overall and near the wall: mean over seeds with 95% CI bands (from
    :data:`~sb3_geogp.toolbox.tables.MIN_SAMPLES_FOR_INTERVAL` seeds, as the tables; the mean
    alone below)."""
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    x = np.asarray(result.max_basis)
    bands = len(result.seeds) >= MIN_SAMPLES_FOR_INTERVAL
    what = "95% CI" if bands else f"mean alone: fewer than {MIN_SAMPLES_FOR_INTERVAL}"
    for ax, metric, title in zip(
        axes, ("mse", "mse_wall"), ("whole state space", "near the wall"), strict=True
    ):
        for model in models or list(result.values):
            mean, ci = mean_ci(result.array(model, metric), nan_policy="propagate")
            style = "-" if model.startswith("geo") else "--"
            (line,) = ax.plot(x, mean, style, marker="o", ms=3, label=model)
            if bands:
                ax.fill_between(x, mean - ci, mean + ci, color=line.get_color(), alpha=0.15)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xticks(x, [str(v) for v in x])
        ax.set_xlabel("max_basis")
        ax.set_title(f"MSE, {title} ({len(result.seeds)} seeds, {what})", fontsize=10)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("MSE vs exact V")
    axes[1].legend(fontsize=8, loc="upper right")
    return fig
