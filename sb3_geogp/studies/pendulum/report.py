"""Writing the pendulum reproduction's outputs: figures 1-4, CSV / JSON / markdown tables.

:func:`write_figures` and :func:`write_tables` are what ``examples/reproduce_paper.py`` calls
after :func:`~sb3_geogp.studies.pendulum.reproduction.run_reproduction`.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.studies.pendulum.plots import (
    figure_controls,
    figure_errors,
    figure_graph,
    figure_value_maps,
)
from sb3_geogp.studies.pendulum.reproduction import (
    CORE_MODELS,
    METRICS,
    MODELS,
    SETTINGS,
    ReproductionResult,
    example_fits,
    paired_log_ratio,
)
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.tables import (
    MIN_SAMPLES_FOR_INTERVAL,
    NO_INTERVAL,
    estimate_cell,
    markdown_table,
)

#: Figure files written by :func:`write_figures`.
FIGURES = ("fig1_value_maps.png", "fig2_bv_graph.png", "fig3_mse_variance.png", "fig4_controls.png")
#: Table files written by :func:`write_tables`.
TABLES = ("results.csv", "results.json", "results.md", "ground_truth.npz")


def write_figures(result: ReproductionResult, out: Path, map_basis: int, graph_basis: int) -> None:
    """Figures 1-4 as PNG in ``out`` (Figure 1 at ``map_basis``, Figure 2 at ``graph_basis``).

    The GPs drawn are refitted on seed 0's data with the shared fixed hyperparameters.
    """
    fits = example_fits(result.task, result.config, map_basis)
    figure_value_maps(result, fits, map_basis).savefig(out / FIGURES[0], dpi=110)
    graph_gp = example_fits(result.task, result.config, graph_basis)["geodesic"]
    figure_graph(result, graph_gp, graph_basis).savefig(out / FIGURES[1], dpi=110)
    figure_errors(result).savefig(out / FIGURES[2], dpi=110)
    figure_controls(result).savefig(out / FIGURES[3], dpi=110)


def _clean(value: Any) -> Any:
    """JSON-safe value (NaN -> None)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def write_tables(result: ReproductionResult, out: Path, minutes: float) -> str:
    """Write results.csv, results.json, results.md and ground_truth.npz; return the markdown."""
    columns: list[str] = []
    for row in result.rows:
        columns += [k for k in row if k not in columns]
    with (out / "results.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        writer.writerows(result.rows)
    truth = result.truth.summary()
    record = {
        **config_dict(result),
        "ground_truth": truth,
        "summary": summary_records(result),
        "minutes": minutes,
    }
    (out / "results.json").write_text(json.dumps(_clean(record), indent=1))
    np.savez_compressed(
        out / "ground_truth.npz",
        states=result.truth.states,
        mc_value=result.truth.mc.value,
        mc_stderr=result.truth.mc.stderr,
        td_value=result.truth.td.value,
        td_visits=result.truth.td.visits,
        jump=result.truth.jump,
    )
    cfg = result.config
    variants = tuple(cfg.variants)
    caps = cfg.max_basis
    small_and_large = sorted({*caps[:3], *caps[-2:]})
    fixed_models = (*CORE_MODELS, *variants, "shepard_oracle")
    md = [
        "# Pendulum reproduction: results",
        "",
        f"{len(cfg.seeds)} seeds, max_basis {list(cfg.max_basis)}, {cfg.n_episodes} training "
        f"episodes (every {cfg.stride}th state), {cfg.grid_n}x{cfg.grid_n} grid, "
        f"{cfg.mc_rollouts} MC rollouts per cell; {minutes:.1f} min.",
        "",
        "Ground truth: value in [{value_min:.2f}, {value_max:.2f}], variance over the grid "
        "{value_var:.2f}; MC standard error mean {mc_stderr_mean:.3f} (max {mc_stderr_max:.2f}), "
        "MC noise floor of the MSE {mc_noise_floor_mse:.4f}. TD baseline: coverage "
        "{td_coverage:.1%}, MSE {td_mse:.2f} (visited cells {td_mse_visited:.2f}).".format(**truth),
        "",
        "## MSE at small and large max BV (mean ± 95% CI over seeds)",
        "",
        metric_table(result, max_basis=small_and_large),
        "",
        "## MSE against the Monte Carlo truth, every max BV (mean ± 95% CI over seeds)",
        "",
        metric_table(result),
        "",
        "Geodesic variants (fixed setting):",
        "",
        metric_table(result, models=(*variants, "shepard_oracle"), settings=("fixed",)),
        "",
        "`shepard_oracle`: Shepard interpolation of Monte Carlo values at the geodesic GP's "
        "basis vectors, the error floor of that prediction rule on that basis.",
        "",
        f"## MSE on the {cfg.jump_fraction:.0%} discontinuity cells",
        "",
        metric_table(
            result,
            models=fixed_models,
            settings=("fixed",),
            metric="mse_jump",
        ),
        "",
        "## MSE on the other cells",
        "",
        metric_table(
            result,
            models=fixed_models,
            settings=("fixed",),
            metric="mse_smooth",
        ),
        "",
        "## Normalised variance (grid mean of posterior / prior variance), fixed setting",
        "",
        metric_table(
            result,
            models=[m for m in (*CORE_MODELS, *variants) if MODELS[m][1] == "gp"],
            settings=("fixed",),
            metric="nvar",
        ),
        "",
        "## Paired MSE ratio geodesic / control (geometric mean over seeds, 95% CI)",
        "",
        ratio_table(result),
        "",
    ]
    text = "\n".join(md)
    (out / "results.md").write_text(text)
    return text


def summary_records(result: ReproductionResult) -> list[dict[str, Any]]:
    """Mean and 95% CI half-width over seeds per (model, setting, max_basis) and metric."""
    cfg = result.config
    out: list[dict[str, Any]] = []
    pairs = sorted({(r["model"], r["setting"]) for r in result.rows if r["model"] != "mlp"})
    for model, setting in pairs:
        cells = {k: mean_ci(result.values(model, setting, k), nan_policy="omit") for k in METRICS}
        for i, m in enumerate(cfg.max_basis):
            rec: dict[str, Any] = {"model": model, "setting": setting, "max_basis": m}
            for k, (mean, half) in cells.items():
                rec[k] = float(mean[i])
                rec[f"{k}_ci95"] = float(half[i])
            out.append(rec)
    for k in ("mse", "mse_jump", "mse_smooth", "seconds"):
        mean, half = mean_ci(result.mlp_values(k)[None], nan_policy="omit")
        if not out or out[-1]["model"] != "mlp":
            out.append({"model": "mlp", "setting": "fixed", "max_basis": None})
        out[-1][k], out[-1][f"{k}_ci95"] = float(mean[0]), float(half[0])
    return out


def _n_finite(samples: np.ndarray) -> np.ndarray:
    """Samples per row that ``mean_ci(..., nan_policy="omit")`` uses (the finite ones)."""
    return np.isfinite(samples).sum(axis=-1)


def _with_note(table: str, estimate: str) -> str:
    """``table``, and below it the rule for its cells without an interval if it has any."""
    if NO_INTERVAL not in table:
        return table
    return (
        f"{table}\n\nWith fewer than {MIN_SAMPLES_FOR_INTERVAL} seeds a cell gives {estimate} "
        f'alone ("{NO_INTERVAL}").'
    )


def metric_table(
    result: ReproductionResult,
    max_basis: Sequence[int] | None = None,
    models: Sequence[str] = CORE_MODELS,
    settings: Sequence[str] = SETTINGS,
    metric: str = "mse",
) -> str:
    """Markdown table of ``metric`` (mean ± 95% CI over seeds): rows = model and setting,
    columns = capacities (default: all), with the MLP and the TD baseline as reference rows.

    A cell from fewer than :data:`~sb3_geogp.toolbox.tables.MIN_SAMPLES_FOR_INTERVAL` seeds
    (finite values) gives the mean alone
    (:func:`~sb3_geogp.toolbox.tables.estimate_cell`); a note under the table then says so.
    """
    cfg = result.config
    caps = list(max_basis or cfg.max_basis)
    rows = []
    for setting in settings:
        for model in models:
            vals = result.values(model, setting, metric)
            if np.all(np.isnan(vals)):
                continue
            mean, half = mean_ci(vals, nan_policy="omit")
            n = _n_finite(vals)
            cells = []
            for m in caps:
                i = cfg.max_basis.index(m)
                cells.append(estimate_cell(f"{mean[i]:.2f}", f"± {half[i]:.2f}", int(n[i])))
            rows.append([model, setting, *cells])
    mlp_vals = result.mlp_values(metric)
    mlp_mean, mlp_half = mean_ci(mlp_vals[None], nan_policy="omit")
    if metric in ("mse", "mse_jump", "mse_smooth"):
        mlp = estimate_cell(f"{mlp_mean[0]:.2f}", f"± {mlp_half[0]:.2f}", int(_n_finite(mlp_vals)))
        rows.append(["mlp (64, 64)", "—", *[mlp] * len(caps)])
        td = result.truth.summary()[
            {"mse": "td_mse", "mse_jump": "td_mse_jump", "mse_smooth": "td_mse_smooth"}[metric]
        ]
        rows.append([f"TD, {cfg.td_episodes} episodes", "—", *[f"{td:.2f}"] * len(caps)])
    header = ["model", "setting", *(f"max_BV={m}" for m in caps)]
    return _with_note(markdown_table(header, rows, align="ll" + "r" * len(caps)), "the mean")


def ratio_table(
    result: ReproductionResult,
    model: str = "geodesic",
    references: Sequence[str] = ("rbf", "euclid_laplacian", "euclid_lap_shepard"),
    metric: str = "mse",
) -> str:
    """Markdown table of paired error ratios ``model / reference``
    (:func:`~sb3_geogp.studies.pendulum.reproduction.paired_log_ratio`).

    Cells: geometric mean over seeds and its 95% interval; below 1 ``model`` is better. A
    cell from fewer than :data:`~sb3_geogp.toolbox.tables.MIN_SAMPLES_FOR_INTERVAL` seeds with
    a finite log ratio gives the geometric mean alone
    (:func:`~sb3_geogp.toolbox.tables.estimate_cell`); a note under the table then says so.
    """
    caps = result.config.max_basis
    rows = []
    for setting in SETTINGS:
        for reference in references:
            ratio, low, high = paired_log_ratio(result, model, reference, setting, metric)
            if np.all(np.isnan(ratio)):
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                logs = np.log(
                    result.values(model, setting, metric)
                    / result.values(reference, setting, metric)
                )
            cells = [
                estimate_cell(f"{r:.2f}", f"[{lo:.2f}, {hi:.2f}]", int(n))
                for r, lo, hi, n in zip(ratio, low, high, _n_finite(logs), strict=True)
            ]
            rows.append([reference, setting, *cells])
    header = ["versus", "setting", *(f"max_BV={m}" for m in caps)]
    return _with_note(
        markdown_table(header, rows, align="ll" + "r" * len(caps)), "the geometric mean"
    )


def config_dict(result: ReproductionResult) -> dict[str, Any]:
    """The run's provenance, configuration and task constants as plain data."""
    task = result.task
    return {
        "provenance": result.provenance or provenance(),
        "config": asdict(result.config),
        "task": {
            "params": asdict(task.params),
            "policy": asdict(task.policy),
            "gamma": task.gamma,
            "speed_limit": task.speed_limit,
            "horizon": task.horizon,
            "horizon_tol": task.horizon_tol,
        },
    }
