"""Tables and figures of a critic-comparison sweep.

Writes to ``out/report/`` (:func:`write_report`), from :mod:`sb3_geogp.comparison.results`:

* ``curves_<env>.png``: evaluation return against timesteps, one panel per algorithm, the
  mean over seeds of each critic with its 95 % percentile-bootstrap band;
* ``critic_accuracy.png``: RMSE of the critic's value against Monte Carlo returns at the probe
  states, per environment and algorithm, mean and band over seeds;
* ``summary.md`` / ``summary.json``: :func:`~sb3_geogp.comparison.results.summary_rows`;
* ``comparisons.md`` / ``comparisons.json``: :func:`~sb3_geogp.comparison.results.comparisons`
  (and ``vs_baseline.md`` / ``.json`` against another sweep).
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.hyperparams import CRITICS
from sb3_geogp.comparison.results import (
    METRICS,
    Key,
    comparisons,
    critic_pairs,
    group_runs,
    load_results,
    stack_curves,
    summary_rows,
)
from sb3_geogp.toolbox.stats import bootstrap_ci
from sb3_geogp.toolbox.tables import markdown_table

COLORS = {"mlp": "tab:gray", "rbf": "tab:blue", "geodesic": "tab:red"}


def _fmt(x: float) -> str:
    if not math.isfinite(x):
        return "—"
    if abs(x) >= 1000:
        return f"{x:.0f}"
    if abs(x) >= 10:
        return f"{x:.1f}"
    return f"{x:.3g}"


def _ci(est: float, low: float, high: float) -> str:
    return f"{_fmt(est)} [{_fmt(low)}, {_fmt(high)}]"


def comparisons_markdown(rows: list[dict[str, Any]]) -> str:
    """One table per metric: a row per ``(env, algo)``, a column per critic pair.

    A verdict in bold also holds at the family-wise level.
    """
    against_baseline = bool(rows) and rows[0]["b_sweep"] == "baseline"
    columns = [
        p for p in critic_pairs(against_baseline) if any((r["a"], r["b"]) == p for r in rows)
    ]
    lines: list[str] = []
    for name, metric in METRICS.items():
        mine = [r for r in rows if r["metric"] == name]
        if not mine:
            continue
        fw = mine[0]["fw_level"]
        labels = [f"{a} − baseline {b}" if against_baseline else f"{a} − {b}" for a, b in columns]
        body = []
        for env_id, algo in sorted({(r["env"], r["algo"]) for r in mine}):
            cells = {(r["a"], r["b"]): r for r in mine if (r["env"], r["algo"]) == (env_id, algo)}
            body.append([f"`{env_id}`", algo, *(_comparison_cell(cells.get(p)) for p in columns)])
        lines += [
            f"### {metric.label}",
            "",
            f"Difference of means [95 % bootstrap CI] and verdict; **bold**: the verdict also "
            f"holds at the family-wise level (Bonferroni over {len(mine)} comparisons, "
            f"{100 * fw:.3g} % intervals).",
            "",
            markdown_table(["env", "algo", *labels], body),
            "",
        ]
    return "\n".join(lines)


def _comparison_cell(r: dict[str, Any] | None) -> str:
    if r is None:
        return ""
    word = r["verdict"]
    if word in ("better", "worse") and r["fw_verdict"] == word:
        word = f"**{word}**"
    return f"{_ci(r['diff'], r['low'], r['high'])} {word}"


def _num(x: float | None) -> float:
    return math.nan if x is None else float(x)


def summary_markdown(rows: list[dict[str, Any]]) -> str:
    """The summary rows as a markdown table (one table, environments in blocks)."""
    header = [
        "env", "algo", "critic", "seeds", "steps", "final return mean [95% CI]", "IQM",
        "steps to threshold (median, reached)", "critic RMSE [95% CI]", "train s", "GP share",
    ]  # fmt: skip
    return markdown_table(header, (_summary_cells(r) for r in rows)) + "\n"


def _summary_cells(r: dict[str, Any]) -> list[str]:
    stt = _num(r["steps_to_threshold_median"])
    share = r["critic_share_mean"]
    return [
        f"`{r['env']}`",
        r["algo"],
        r["critic"],
        str(r["n_seeds"]),
        str(r["timesteps"]),
        _ci(r["final_mean"], r["final_low"], r["final_high"]),
        _fmt(r["final_iqm"]),
        f"{_fmt(stt)} ({r['reached']}/{r['n_seeds']} ≥ {_fmt(r['threshold'])})",
        _ci(r["critic_rmse_mean"], r["critic_rmse_low"], r["critic_rmse_high"]),
        _fmt(r["train_seconds_mean"]),
        "—" if share is None else f"{100 * share:.0f} %",
    ]


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _band(ax: Any, t: np.ndarray, values: np.ndarray, critic: str, seed: int) -> None:
    est, low, high = bootstrap_ci(values, seed=seed)
    ax.plot(t, est, color=COLORS.get(critic), label=f"{critic} (n={len(values)})")
    ax.fill_between(t, low, high, color=COLORS.get(critic), alpha=0.2, linewidth=0)


def plot_learning_curves(
    results: list[dict[str, Any]], out_dir: str | Path, seed: int = 0
) -> list[Path]:
    """One ``curves_<env>.png`` per environment; returns the paths."""
    plt = _plt()
    groups = group_runs(results)
    paths = []
    for env_id in sorted({k[0] for k in groups}):
        algos = sorted({k[1] for k in groups if k[0] == env_id})
        fig, axes = plt.subplots(1, len(algos), figsize=(5 * len(algos), 3.6), squeeze=False)
        for ax, algo in zip(axes[0], algos, strict=True):
            for critic in CRITICS:
                runs = groups.get((env_id, algo, critic))
                if runs:
                    t, values = stack_curves(runs)
                    _band(ax, t, values, critic, seed)
            ax.axhline(runs_threshold(groups, env_id), color="k", lw=0.8, ls=":")
            ax.set_title(f"{env_id} — {algo.upper()}")
            ax.set_xlabel("timesteps")
            ax.set_ylabel("evaluation return (deterministic)")
            ax.legend(fontsize=8)
        fig.tight_layout()
        path = Path(out_dir) / f"curves_{env_id.replace('/', '-')}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def runs_threshold(groups: dict[Key, list[dict[str, Any]]], env_id: str) -> float:
    """The steps-to-threshold level recorded in the runs of ``env_id``."""
    for key, runs in groups.items():
        if key[0] == env_id:
            return float(runs[0]["threshold"])
    raise KeyError(env_id)


def plot_critic_accuracy(results: list[dict[str, Any]], path: str | Path, seed: int = 0) -> Path:
    """``critic_accuracy.png``: critic RMSE vs Monte Carlo returns over training."""
    plt = _plt()
    groups = group_runs(results)
    envs = sorted({k[0] for k in groups})
    algos = sorted({k[1] for k in groups})
    fig, axes = plt.subplots(
        len(envs), len(algos), figsize=(4.5 * len(algos), 3 * len(envs)), squeeze=False
    )
    for i, env_id in enumerate(envs):
        for j, algo in enumerate(algos):
            ax = axes[i, j]
            for critic in CRITICS:
                runs = groups.get((env_id, algo, critic))
                if runs:
                    t, values = stack_curves(runs, "critic_accuracy", "rmse")
                    _band(ax, t, values, critic, seed)
            ax.set_yscale("log")
            ax.set_title(f"{env_id} — {algo.upper()}", fontsize=9)
            ax.set_xlabel("timesteps")
            ax.set_ylabel("critic RMSE vs MC")
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def write_report(
    out_dir: str | Path, seed: int = 0, baseline_dir: str | Path | None = None
) -> list[Path]:
    """Figures and summary of the sweep in ``out_dir`` into ``out_dir/report``.

    Without matplotlib only the tables (markdown and JSON) are written.

    With ``baseline_dir`` (another sweep's folder) also ``vs_baseline.md`` / ``.json``: each
    critic against the same critic there (:func:`comparisons` with ``baseline``).

    Returns
    -------
    list of Path
        Files written (none if no result exists yet).
    """
    results = load_results(out_dir)
    if not results:
        return []
    report = Path(out_dir) / "report"
    report.mkdir(parents=True, exist_ok=True)
    rows = summary_rows(results, seed=seed)
    md = report / "summary.md"
    md.write_text(summary_markdown(rows))
    js = report / "summary.json"
    js.write_text(json.dumps(rows, indent=1))
    diffs = comparisons(results, seed=seed)
    cmd = report / "comparisons.md"
    cmd.write_text(comparisons_markdown(diffs))
    cjs = report / "comparisons.json"
    cjs.write_text(json.dumps(diffs, indent=1))
    paths = [md, js, cmd, cjs]
    if baseline_dir is not None:
        vs = comparisons(results, seed=seed, baseline=load_results(baseline_dir))
        paths += [report / "vs_baseline.md", report / "vs_baseline.json"]
        paths[-2].write_text(f"Baseline: `{baseline_dir}`\n\n" + comparisons_markdown(vs))
        paths[-1].write_text(json.dumps(vs, indent=1))
    if not matplotlib_available():
        return paths  # the tables; figures need matplotlib
    paths += plot_learning_curves(results, report, seed=seed)
    paths.append(plot_critic_accuracy(results, report / "critic_accuracy.png", seed=seed))
    return paths


def matplotlib_available() -> bool:
    """Whether the report can draw its figures (matplotlib is an optional dependency)."""
    return importlib.util.find_spec("matplotlib") is not None
