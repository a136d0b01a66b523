"""Figures 1-4 of the pendulum reproduction (matplotlib; the caller picks the backend).

* :func:`figure_value_maps` (Figure 1): MC truth, its standard error, the TD baseline and the
  GP value maps at one capacity.
* :func:`figure_graph` (Figure 2): the geodesic GP's basis-vector graph over the state space
  and its value map.
* :func:`figure_errors` (Figure 3): MSE against the MC truth and normalised variance versus
  ``max_basis``, mean and 95% interval over seeds, for every hyperparameter setting.
* :func:`figure_controls` (Figure 4): paired error ratios of the geodesic GP against its
  controls, and the error at the discontinuities.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.ticker import FixedFormatter, FixedLocator, NullLocator

from sb3_geogp import SparseOnlineGP
from sb3_geogp.studies.pendulum.reproduction import (
    CORE_MODELS,
    MODELS,
    ReproductionResult,
    paired_log_ratio,
    predict,
)
from sb3_geogp.studies.pendulum.task import Task
from sb3_geogp.toolbox.stats import mean_ci

#: Line style per model (colour, label).
STYLE: dict[str, tuple[str, str]] = {
    "rbf": ("tab:blue", "RBF (Euclidean, Gaussian)"),
    "euclid_laplacian": ("tab:cyan", "Euclidean, Laplacian"),
    "euclid_lap_shepard": ("tab:green", "Euclidean, Laplacian, Shepard attach"),
    "geodesic": ("tab:red", "geodesic (Laplacian, Shepard, traj. edges)"),
    "geo_paper": ("tab:purple", "geodesic as in paper (Gauss, nearest)"),
    "geo_gaussian": ("tab:pink", "geodesic, Gaussian, Shepard"),
    "geo_lap_nearest": ("tab:brown", "geodesic, Laplacian, nearest"),
    "geo_nn_edges": ("tab:orange", "geodesic, nearest-BV edges"),
    "mlp": ("k", "MLP (64, 64) tanh"),
    "shepard_oracle": ("0.3", "Shepard interp. of true values at geodesic BVs (floor)"),
}


def _image(ax: Axes, task: Task, values: np.ndarray, n: int, title: str, **kw: Any) -> Any:
    image = ax.imshow(
        values.reshape(n, n),
        origin="lower",
        extent=(-math.pi, math.pi, -task.speed_limit, task.speed_limit),
        aspect="auto",
        interpolation="nearest",
        **kw,
    )
    ax.set_title(title, fontsize=9)
    ax.set_xlim(-math.pi, math.pi)
    ax.set_ylim(-task.speed_limit, task.speed_limit)
    ax.set_xlabel(r"$\theta$ (rad)", fontsize=8)
    ax.set_ylabel(r"$\omega$ (rad/s)", fontsize=8)
    ax.tick_params(labelsize=7)
    return image


def draw_graph(ax: Axes, gp: SparseOnlineGP, color: str = "w") -> None:
    """The BV graph's edges and the basis vectors.

    Each edge is drawn as the kernel measures it, a straight segment in ``(theta, omega)``: no
    GP here treats ``theta`` as periodic, so an edge of a trajectory that wrapped across
    ``theta = +-pi`` spans the box, about ``2 pi`` long (uncorrelated at the lengthscales used).
    """
    if gp.graph is not None:
        nodes = gp.graph_nodes.cpu().numpy()
        i, j = np.triu(gp.adjacency.cpu().numpy() > 0).nonzero()
        segments = list(np.stack([nodes[i], nodes[j]], axis=1))
        ax.add_collection(LineCollection(segments, colors=color, linewidths=0.7, alpha=0.9))
    bv = gp.basis_inputs.cpu().numpy()
    ax.scatter(bv[:, 0], bv[:, 1], s=7, c="k", edgecolors=color, linewidths=0.4, zorder=3)


def figure_value_maps(
    result: ReproductionResult, gps: dict[str, SparseOnlineGP], max_basis: int
) -> Figure:
    """Figure 1: truth, standard error, TD, and the GP value maps (fixed setting).

    Parameters
    ----------
    result : ReproductionResult
        Supplies the grid, the MC truth and the TD baseline.
    gps : dict
        Model name (key of :data:`MODELS`) -> GP fitted at ``max_basis``; three are drawn.
    max_basis : int
        For the titles.
    """
    truth, task, n = result.truth, result.task, result.config.grid_n
    fig = Figure(figsize=(13, 7.5), layout="constrained")
    axes = fig.subplots(2, 3)
    lim = {"vmin": float(truth.mc.value.min()), "vmax": float(truth.mc.value.max())}
    im = _image(axes[0, 0], task, truth.mc.value, n, "(a) Monte Carlo truth $V^\\pi$", **lim)
    mse_td = float(np.mean((truth.td.value - truth.mc.value) ** 2))
    td_shown = np.where(truth.td.visits > 0, truth.td.value, np.nan)  # unvisited: grey
    cmap = matplotlib.colormaps["viridis"].with_extremes(bad="0.6")
    _image(
        axes[0, 1],
        task,
        td_shown,
        n,
        f"(b) tabular TD, {result.config.td_episodes} episodes (MSE {mse_td:.1f}; "
        f"grey: {1 - truth.td.coverage:.0%} unvisited, value 0)",
        cmap=cmap,
        **lim,
    )
    se = _image(axes[0, 2], task, truth.mc.stderr, n, "(c) MC standard error", cmap="magma")
    fig.colorbar(se, ax=axes[0, 2], shrink=0.8)
    for ax, (name, gp) in zip(axes[1], list(gps.items())[:3], strict=False):
        mean, _ = predict(gp, MODELS[name][1], truth.states)
        mse = float(np.mean((mean - truth.mc.value) ** 2))
        title = f"{STYLE[name][1]}\nmax BV {max_basis}, MSE {mse:.1f}"
        _image(ax, task, mean, n, title, **lim)
        bv = gp.basis_inputs.cpu().numpy()
        ax.scatter(bv[:, 0], bv[:, 1], s=5, c="w", edgecolors="k", linewidths=0.3)
        ax.set_xlim(-math.pi, math.pi)
        ax.set_ylim(-task.speed_limit, task.speed_limit)
    fig.colorbar(im, ax=axes[:, :2], shrink=0.6, label="value")
    fig.suptitle("Figure 1 - value of the fixed policy: truth, TD baseline and GP estimates")
    return fig


def figure_graph(result: ReproductionResult, gp: SparseOnlineGP, max_basis: int) -> Figure:
    """Figure 2: (a) the geodesic GP's BV graph over the MC truth, (b) its value map."""
    truth, task, n = result.truth, result.task, result.config.grid_n
    fig = Figure(figsize=(12, 5), layout="constrained")
    ax0, ax1 = fig.subplots(1, 2)
    lim = {"vmin": float(truth.mc.value.min()), "vmax": float(truth.mc.value.max())}
    _image(ax0, task, truth.mc.value, n, "(a) BV graph over the MC truth", alpha=0.55, **lim)
    draw_graph(ax0, gp, color="k")
    ax0.set_xlim(-math.pi, math.pi)
    ax0.set_ylim(-task.speed_limit, task.speed_limit)
    mean, _ = predict(gp, "gp", truth.states)
    mse = float(np.mean((mean - truth.mc.value) ** 2))
    im = _image(ax1, task, mean, n, f"(b) geodesic GP, max BV {max_basis}, MSE {mse:.1f}", **lim)
    draw_graph(ax1, gp)
    ax1.set_xlim(-math.pi, math.pi)
    ax1.set_ylim(-task.speed_limit, task.speed_limit)
    fig.colorbar(im, ax=[ax0, ax1], shrink=0.8, label="value")
    fig.suptitle(
        f"Figure 2 - basis-vector graph ({gp.n_basis} BVs, "
        f"{int(gp.adjacency.gt(0).sum()) // 2} edges) and the geodesic GP's value map"
    )
    return fig


def _band(
    ax: Axes, x: Sequence[float], samples: np.ndarray, color: str, label: str, **kw: Any
) -> None:
    mean, half = mean_ci(samples, nan_policy="omit")
    ax.plot(x, mean, "o-", color=color, label=label, ms=3, lw=1.3, **kw)
    if np.isfinite(half).any():
        ax.fill_between(x, mean - half, mean + half, color=color, alpha=0.1, lw=0)


def _reference_lines(ax: Axes, result: ReproductionResult, metric: str) -> None:
    x = result.config.max_basis
    mean, half = mean_ci(result.mlp_values(metric)[None], nan_policy="omit")
    color, label = STYLE["mlp"]
    ax.axhline(mean[0], color=color, ls="--", lw=1, label=label)
    if np.isfinite(half[0]):
        ax.fill_between(
            [x[0], x[-1]], mean[0] - half[0], mean[0] + half[0], color=color, alpha=0.08
        )
    key = {"mse": "td_mse", "mse_jump": "td_mse_jump", "mse_smooth": "td_mse_smooth"}[metric]
    ax.axhline(result.truth.summary()[key], color="0.5", ls=":", lw=1, label="tabular TD")


def _errors_panel(
    ax: Axes,
    result: ReproductionResult,
    setting: str,
    models: Sequence[str],
    metric: str,
    title: str,
) -> None:
    x = list(result.config.max_basis)
    for model in models:
        color, label = STYLE[model]
        _band(ax, x, result.values(model, setting, metric), color, label)
    _reference_lines(ax, result, metric)
    ax.set_title(title, fontsize=10)
    ax.set_yscale("log")
    ax.set_xlabel("max number of basis vectors")
    ax.set_ylabel(f"{metric.upper().replace('_', ' ')} vs MC truth")
    ax.grid(alpha=0.3, which="both")


def _legend_below(fig: Figure, axes: Sequence[Axes], ncol: int = 4) -> None:
    handles: dict[str, Any] = {}
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, h)
    fig.legend(handles.values(), handles.keys(), loc="outside lower center", ncol=ncol, fontsize=8)


def figure_errors(result: ReproductionResult) -> Figure:
    """Figure 3: MSE vs max BV under each setting, and the normalised variance.

    (a) shared fixed hyperparameters, (b) normalised variance (fixed setting),
    (c) marginal-likelihood hyperparameters, (d) validation-chosen lengthscale, for the RBF
    GP, the two Euclidean-Laplacian controls and the geodesic GP (plus, in (a) and (b), the
    paper's literal geodesic variant), against the MLP and the TD baseline.
    Lines: mean over seeds; bands: 95% Student-t intervals.
    """
    cfg = result.config
    x = list(cfg.max_basis)
    fig = Figure(figsize=(13, 10), layout="constrained")
    axes = fig.subplots(2, 2)
    paper = [m for m in ("geo_paper",) if m in cfg.variants]
    fixed = [*CORE_MODELS, *paper]
    _errors_panel(
        axes[0, 0],
        result,
        "fixed",
        fixed,
        "mse",
        "(a) MSE, shared fixed hyperparameters (as in the paper)",
    )
    _errors_panel(
        axes[1, 0],
        result,
        "ml",
        CORE_MODELS,
        "mse",
        "(c) MSE, hyperparameters by marginal likelihood",
    )
    _errors_panel(
        axes[1, 1], result, "val", CORE_MODELS, "mse", "(d) MSE, lengthscale by held-out validation"
    )
    ax = axes[0, 1]
    for model in [m for m in fixed if MODELS[m][1] == "gp"]:
        color, label = STYLE[model]
        _band(ax, x, result.values(model, "fixed", "nvar"), color, label)
    ax.set_title(
        "(b) normalised variance: grid mean of posterior / prior variance (fixed)", fontsize=10
    )
    ax.set_xlabel("max number of basis vectors")
    ax.set_ylabel("normalised variance")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3)
    _legend_below(fig, [axes[0, 0]])
    fig.suptitle(
        f"Figure 3 - approximation error and normalised variance vs max BV "
        f"({len(cfg.seeds)} seeds, mean and 95% CI)"
    )
    return fig


def _oracle(result: ReproductionResult) -> list[str]:
    return ["shepard_oracle"] if any(r["model"] == "shepard_oracle" for r in result.rows) else []


def figure_controls(result: ReproductionResult) -> Figure:
    """Figure 4: geodesic / control MSE ratios, geodesic variants, error at discontinuities.

    (a) paired geometric-mean ratio ``MSE(geodesic) / MSE(control)`` with 95% CI, against
    ``rbf`` and against ``euclid_lap_shepard`` (same profile and attachment, Euclidean
    distance) under the three settings; below 1 the geodesic GP is better.
    (b) MSE of the geodesic variants (fixed setting) with the default geodesic GP and its
    Euclidean control. (c) MSE on the discontinuity cells, fixed setting.
    """
    cfg = result.config
    x = list(cfg.max_basis)
    fig = Figure(figsize=(16, 5.5), layout="constrained")
    ax0, ax1, ax2 = fig.subplots(1, 3)
    styles = {"fixed": "-", "ml": "--", "val": ":"}
    for reference, color in (("rbf", "tab:blue"), ("euclid_lap_shepard", "tab:green")):
        for setting, ls in styles.items():
            ratio, low, high = paired_log_ratio(result, "geodesic", reference, setting)
            ax0.plot(
                x, ratio, ls, color=color, marker="o", ms=3, label=f"vs {reference}, {setting}"
            )
            if np.isfinite(low).any():
                ax0.fill_between(x, low, high, color=color, alpha=0.06, lw=0)
    ax0.axhline(1.0, color="k", lw=0.8)
    ax0.set_yscale("log")
    ticks = [0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0]
    ax0.yaxis.set_major_locator(FixedLocator(ticks))
    ax0.yaxis.set_major_formatter(FixedFormatter([f"{t:g}" for t in ticks]))
    ax0.yaxis.set_minor_locator(NullLocator())
    ax0.set_title("(a) MSE(geodesic) / MSE(control), paired\n(< 1: geodesic better)", fontsize=10)
    ax0.set_xlabel("max number of basis vectors")
    ax0.grid(alpha=0.3, which="both")
    ax0.legend(fontsize=7, ncol=2)
    variants = ["geodesic", *cfg.variants, "euclid_lap_shepard", *_oracle(result)]
    _errors_panel(ax1, result, "fixed", variants, "mse", "(b) geodesic variants, fixed setting")
    _errors_panel(
        ax2,
        result,
        "fixed",
        [*CORE_MODELS, *[m for m in ("geo_paper",) if m in cfg.variants], *_oracle(result)],
        "mse_jump",
        f"(c) MSE on the {cfg.jump_fraction:.0%} discontinuity cells, fixed setting",
    )
    _legend_below(fig, [ax1, ax2], ncol=5)
    fig.suptitle("Figure 4 - controls: is the gain due to the graph distance?")
    return fig
