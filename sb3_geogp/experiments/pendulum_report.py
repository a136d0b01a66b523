"""Writing the pendulum reproduction's outputs: figures 1-4, CSV / JSON / markdown tables.

:func:`write_report` is what ``examples/reproduce_paper.py`` (and any CLI) calls after
:func:`~sb3_geogp.experiments.pendulum_reproduction.run_reproduction`.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.experiments.pendulum_plots import (
    figure_controls,
    figure_errors,
    figure_graph,
    figure_value_maps,
)
from sb3_geogp.experiments.pendulum_reproduction import (
    CORE_MODELS,
    MODELS,
    ReproductionResult,
    config_dict,
    example_fits,
    markdown_table,
    ratio_table,
    summary_records,
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
        markdown_table(result, max_basis=small_and_large),
        "",
        "## MSE against the Monte Carlo truth, every max BV (mean ± 95% CI over seeds)",
        "",
        markdown_table(result),
        "",
        "Geodesic variants (fixed setting):",
        "",
        markdown_table(result, models=(*variants, "shepard_oracle"), settings=("fixed",)),
        "",
        "`shepard_oracle`: Shepard interpolation of Monte Carlo values at the geodesic GP's "
        "basis vectors, the error floor of that prediction rule on that basis.",
        "",
        f"## MSE on the {cfg.jump_fraction:.0%} discontinuity cells",
        "",
        markdown_table(
            result,
            models=(*CORE_MODELS, *variants, "shepard_oracle"),
            settings=("fixed",),
            metric="mse_jump",
        ),
        "",
        "## MSE on the other cells",
        "",
        markdown_table(
            result,
            models=(*CORE_MODELS, *variants, "shepard_oracle"),
            settings=("fixed",),
            metric="mse_smooth",
        ),
        "",
        "## Normalised variance (grid mean of posterior / prior variance), fixed setting",
        "",
        markdown_table(
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
