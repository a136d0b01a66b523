"""Tables and figures of a critic-comparison sweep.

Writes to ``out/report/`` (:func:`write_report`), from :mod:`sb3_geogp.comparison.results`:

* ``curves_<env>.png``: evaluation return against timesteps, one panel per algorithm, the
  mean over seeds of each critic with the 95 % percentile-bootstrap interval of that mean at
  every checkpoint as a band, and the steps-to-threshold level;
* ``curves.png``: the same for every cell on one figure, a panel per (algorithm,
  environment), each algorithm's cells from a new line (:func:`plot_cell_curves`);
* ``critic_accuracy.png``: RMSE of the critic's value against Monte Carlo returns at the probe
  states, per environment and algorithm, mean and band over seeds;
* ``summary.md`` / ``summary.json``: :func:`~sb3_geogp.comparison.results.summary_rows`;
* ``comparisons.md`` / ``comparisons.json``: :func:`~sb3_geogp.comparison.results.comparisons`
  (and ``vs_baseline.md`` / ``.json`` against another sweep).

Each figure says what its bands are in a caption (:data:`BAND_CAPTION`). Neither the figures
nor the tables give an interval from fewer than
:data:`~sb3_geogp.toolbox.tables.MIN_SAMPLES_FOR_INTERVAL` seeds.
"""

from __future__ import annotations

import importlib.util
import json
import math
import textwrap
from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.hyperparams import ALL_CRITICS
from sb3_geogp.comparison.results import (
    METRICS,
    PUBLISHED_FAMILY,
    Key,
    VerdictTest,
    comparisons,
    critic_pairs,
    env_file_name,
    group_runs,
    load_results,
    load_sweeps,
    machine_caution,
    stack_curves,
    summary_rows,
)
from sb3_geogp.toolbox.stats import N_RESAMPLES, bootstrap_ci
from sb3_geogp.toolbox.tables import (
    MIN_SAMPLES_FOR_INTERVAL,
    NO_INTERVAL,
    estimate_cell,
    markdown_table,
)

COLORS = {
    "mlp": "tab:gray",
    "rbf": "tab:blue",
    "geodesic": "tab:red",
    "laplacian": "tab:green",
    "matern": "tab:purple",
}
#: Confidence level of the figures' bands.
LEVEL = 0.95


def _fmt(x: float) -> str:
    if not math.isfinite(x):
        return "—"
    if abs(x) >= 1000:
        return f"{x:.0f}"
    if abs(x) >= 10:
        return f"{x:.1f}"
    return f"{x:.3g}"


def _ci(est: float, low: float, high: float, n: int) -> str:
    return estimate_cell(_fmt(est), f"[{_fmt(low)}, {_fmt(high)}]", n)


def _few_seeds_note(n_seeds: Collection[int], consequence: str) -> str:
    """The caption's sentence on cells without an interval, if the table has any."""
    if min(n_seeds, default=MIN_SAMPLES_FOR_INTERVAL) >= MIN_SAMPLES_FOR_INTERVAL:
        return ""
    return f' With fewer than {MIN_SAMPLES_FOR_INTERVAL} seeds{consequence} ("{NO_INTERVAL}").'


def _comparisons(n: int) -> str:
    return f"{n} comparison{'s' * (n != 1)}"


def _verdict_rule(row: dict[str, Any], higher_is_better: bool) -> str:
    """The caption's sentence on how a comparisons table's verdicts were reached."""
    side = "higher" if higher_is_better else "lower"
    family, fw = _comparisons(row["family_size"]), row["fw_level"]
    if "p_value" in row:
        alpha = (1 - fw) * row["family_size"]
        return (
            "Difference of means [95 % bootstrap CI] and the verdict of a two-sided "
            f"permutation test of it for the first critic ({side} is better): *better* or "
            f"*worse* where p < {alpha:.3g}, *no difference* otherwise; **bold**: the verdict "
            f"also holds at the family-wise level (Bonferroni over {family}, p < {1 - fw:.3g})."
        )
    return (
        "Difference of means [95 % bootstrap CI] and verdict for the first critic: *better* "
        f"where the interval excludes 0 on its better side ({side} is better), *worse* where "
        "it excludes 0 on the other, *no difference* where it holds 0; **bold**: the verdict "
        f"also holds at the family-wise level (Bonferroni over {family}, {100 * fw:.3g} % "
        "intervals)."
    )


def comparisons_markdown(rows: list[dict[str, Any]]) -> str:
    """One table per metric: a row per ``(env, algo)``, a column per critic pair.

    A verdict in bold also holds at the family-wise level. With fewer than
    :data:`~sb3_geogp.toolbox.tables.MIN_SAMPLES_FOR_INTERVAL` seeds on either side a cell
    gives the difference alone, without interval or verdict.
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
        labels = [f"{a} − baseline {b}" if against_baseline else f"{a} − {b}" for a, b in columns]
        body = []
        for env_id, algo in sorted({(r["env"], r["algo"]) for r in mine}):
            cells = {(r["a"], r["b"]): r for r in mine if (r["env"], r["algo"]) == (env_id, algo)}
            body.append([f"`{env_id}`", algo, *(comparison_cell(cells.get(p)) for p in columns)])
        lines += [
            f"### {metric.label}",
            "",
            _verdict_rule(mine[0], metric.higher_is_better)
            + _few_seeds_note(
                [min(r["n_a"], r["n_b"]) for r in mine],
                " on either side: the difference alone, no interval and no verdict",
            ),
            "",
            markdown_table(["env", "algo", *labels], body),
            "",
        ]
    return "\n".join(lines)


def rerun_markdown(
    before: list[dict[str, Any]],
    after: list[dict[str, Any]],
    replaces: Mapping[str, str] | None = None,
) -> str:
    """Before and after side by side (see :func:`~sb3_geogp.comparison.results.rerun_comparisons`):
    one table per metric, a row per cell and critic pair, cells as in :func:`comparisons_markdown`.

    ``replaces`` (re-run critic to the published critic it replaces) pairs a re-run critic's
    rows with the published rows of the critic it replaces, named in the row.
    """
    renamed = dict(replaces or {})
    lines: list[str] = []
    for name, metric in METRICS.items():
        old = {(r["env"], r["algo"], r["a"], r["b"]): r for r in before if r["metric"] == name}
        new = {(r["env"], r["algo"], r["a"], r["b"]): r for r in after if r["metric"] == name}
        if not new:
            continue
        fw = next(iter(new.values()))["fw_level"]
        body = [
            [f"`{env}`", algo, _pair_label(a, b, renamed.get(a, a)),
             comparison_cell(old.get((env, algo, renamed.get(a, a), b))), comparison_cell(new[k])]
            for k in sorted(new)
            for env, algo, a, b in [k]
        ]  # fmt: skip
        lines += [
            f"### {metric.label}",
            "",
            f"Difference of means [95 % bootstrap CI] and verdict; **bold**: the verdict also "
            f"holds at the published family-wise level ({100 * fw:.3g} % intervals).",
            "",
            markdown_table(["env", "algo", "critics", "published", "re-run"], body),
            "",
        ]
    return "\n".join(lines)


def _pair_label(a: str, b: str, published: str) -> str:
    label = f"{a} − {b}"
    return label if published == a else f"{label} (published: {published} − {b})"


def family_level(family: int) -> str:
    """A caption's name of the family-wise level of ``family`` comparisons per metric."""
    published = "published " if family == PUBLISHED_FAMILY else ""
    return f"{published}family-wise level"


def comparison_cell(r: dict[str, Any] | None) -> str:
    """A :func:`~sb3_geogp.comparison.results.comparisons` row as a table cell: the difference
    with its 95 % interval and verdict, the verdict in bold where it also holds family-wise
    (empty for ``None``; no verdict below the seeds an interval needs)."""
    if r is None:
        return ""
    n = min(r["n_a"], r["n_b"])
    cell = _ci(r["diff"], r["low"], r["high"], n)
    if n < MIN_SAMPLES_FOR_INTERVAL:
        return cell  # a verdict rests on the interval
    word = r["verdict"]
    if word in ("better", "worse") and r["fw_verdict"] == word:
        word = f"**{word}**"
    return f"{cell} {word}"


def difference_title(r: dict[str, Any]) -> str:
    """A :func:`~sb3_geogp.comparison.results.comparisons` row as a figure's title line:
    ``"+51.0 [+24.8, +79.8], better"``, with ``" at 95 %"`` after a verdict that does not also
    hold family-wise."""
    word = r["verdict"] if r["fw_verdict"] == r["verdict"] else f"{r['verdict']} at 95 %"
    return f"{r['diff']:+.1f} [{r['low']:+.1f}, {r['high']:+.1f}], {word}"


def count_verdicts(rows: Sequence[dict[str, Any]]) -> str:
    """``"better (family-wise) / no difference / worse (family-wise)"`` counts of
    :func:`~sb3_geogp.comparison.results.comparisons` rows, e.g. ``"4 (1) / 9 / 1 (0)"``."""

    def count(v: str) -> str:
        n = sum(r["verdict"] == v for r in rows)
        fw = sum(r["fw_verdict"] == v for r in rows)
        return f"{n} ({fw})" if v != "no difference" else str(n)

    return " / ".join(count(v) for v in ("better", "no difference", "worse"))


def _num(x: float | None) -> float:
    return math.nan if x is None else float(x)


def summary_markdown(rows: list[dict[str, Any]]) -> str:
    """The summary rows as a markdown table (one table, environments in blocks), captioned."""
    header = [
        "env", "algo", "critic", "seeds", "steps", "final return mean [95% CI]", "IQM",
        "steps to threshold (median, reached; training s)", "critic RMSE [95% CI]", "train s",
        "GP share",
    ]  # fmt: skip
    caption = "Final return and final critic RMSE: mean over seeds [95 % percentile-bootstrap CI]."
    caption += _few_seeds_note([r["n_seeds"] for r in rows], ": the mean alone")
    table = markdown_table(header, (_summary_cells(r) for r in rows))
    return f"{caption}\n\n{table}\n\n{SUMMARY_KEY}\n"


#: What ``summary.md``'s columns mean, and where the rest of the report is.
SUMMARY_KEY = """\
Columns, over each cell's seeds: the final evaluation return (deterministic actions, mean and
IQM, the mean of the middle half of the seeds); the median step at which the evaluation return
first reached the threshold (a seed that never did counts as never), and how many seeds did,
with the median training seconds to it where the runs recorded them (since 0.40; evaluations
excluded, comparable between critics only for runs made one at a time on an idle machine);
the critic's final RMSE against Monte Carlo returns of its run's own policy at fixed probe
states (lower is better); `train s`, the mean wall-clock seconds of training per run
(evaluations excluded); `GP share`, the part of it the GP critic took (its updates and value
predictions). Differences between critics with their verdicts: `comparisons.md`. Figures:
`curves_<env>.png` (evaluation return along training) and `critic_accuracy.png` (critic RMSE
along training)."""


def _summary_cells(r: dict[str, Any]) -> list[str]:
    stt = _num(r["steps_to_threshold_median"])
    share = r["critic_share_mean"]
    return [
        f"`{r['env']}`",
        r["algo"],
        r["critic"],
        str(r["n_seeds"]),
        str(r["timesteps"]),
        _ci(r["final_mean"], r["final_low"], r["final_high"], r["n_seeds"]),
        _fmt(r["final_iqm"]),
        f"{_fmt(stt)} ({r['reached']}/{r['n_seeds']} ≥ {_fmt(r['threshold'])}"
        + _seconds_to_threshold(r)
        + ")",
        _ci(r["critic_rmse_mean"], r["critic_rmse_low"], r["critic_rmse_high"], r["n_seeds"]),
        _fmt(r["train_seconds_mean"]),
        "—" if share is None else f"{100 * share:.0f} %",
    ]


def _seconds_to_threshold(r: dict[str, Any]) -> str:
    """``"; 3.1 s"``: a summary row's median training seconds to the threshold (``—`` where
    most runs never reached it), or nothing where its runs did not record them (before 0.40)."""
    if "seconds_to_threshold_median" not in r:
        return ""
    return f"; {_fmt(_num(r['seconds_to_threshold_median']))} s"


def pyplot() -> Any:
    """matplotlib's ``pyplot`` on the headless Agg backend.

    matplotlib is optional: check :func:`matplotlib_available` before calling this.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_difference_panels(
    rows: Sequence[dict[str, Any]],
    columns: Sequence[str],
    path: str | Path,
    title: str,
    n_cols: int,
    panel_size: tuple[float, float],
    tick_labels: Sequence[str] | None = None,
) -> Path:
    """Differences of means with their 95 % intervals: a panel per row, a point per column.

    Parameters
    ----------
    rows : sequence of dict
        One per panel: ``env``, ``algo``, optional ``critic``, and under each of ``columns`` a
        :func:`~sb3_geogp.comparison.results.comparisons` row (or ``None``: no point).
    columns : sequence of str
        The keys of ``rows`` plotted, left to right (colours C0, C1, ...).
    path : str or Path
    title : str
        The figure's title.
    n_cols : int
        Panels per line.
    panel_size : (float, float)
        Width and height of a panel, inches.
    tick_labels : sequence of str, optional
        The x labels (``columns`` if not given).
    """
    plt = pyplot()
    n_rows = -(-len(rows) // n_cols)
    width, height = panel_size
    fig, axes = plt.subplots(
        n_rows, n_cols, figsize=(width * n_cols, height * n_rows), squeeze=False
    )
    for ax, r in zip(axes.flat, rows, strict=False):
        for k, column in enumerate(columns):
            c = r[column]
            if c is None:
                continue
            ax.errorbar(
                k, c["diff"], yerr=[[c["diff"] - c["low"]], [c["high"] - c["diff"]]],
                fmt="o", color=f"C{k}", capsize=3,
            )  # fmt: skip
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xticks(range(len(columns)), list(tick_labels or columns), fontsize=7)
        ax.set_xlim(-0.6, len(columns) - 0.4)
        critic = f", {r['critic']}" if "critic" in r else ""
        ax.set_title(f"{r['env'].split('/')[-1]}\n{r['algo']}{critic}", fontsize=8)
        ax.tick_params(axis="y", labelsize=7)
        ax.grid(alpha=0.3, axis="y")
    for ax in axes.flat[len(rows) :]:
        ax.axis("off")
    # About 13 characters of a 10-point title per inch: a narrow figure wraps it, not cuts it.
    fig.suptitle(textwrap.fill(title, width=int(13 * width * n_cols)), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


#: The caption under each figure: what its lines and bands are (:func:`_band`).
BAND_CAPTION = (
    f"Lines: mean over seeds (n in the legend). Shaded: {100 * LEVEL:g} % percentile-bootstrap "
    f"confidence interval of that mean at each checkpoint ({N_RESAMPLES:,} resamples of whole "
    f"runs); none from fewer than {MIN_SAMPLES_FOR_INTERVAL} seeds."
)


def _band(ax: Any, t: np.ndarray, values: np.ndarray, critic: str, seed: int) -> int:
    """Mean over runs (rows) and its bootstrap band, as :data:`BAND_CAPTION` says; returns n."""
    n = len(values)
    est, low, high = bootstrap_ci(values, level=LEVEL, seed=seed)
    ax.plot(t, est, color=COLORS.get(critic))
    if n >= MIN_SAMPLES_FOR_INTERVAL:
        ax.fill_between(t, low, high, color=COLORS.get(critic), alpha=0.2, linewidth=0)
    return n


def _finish(
    fig: Any, path: Path, n_seeds: dict[str, list[int]], threshold: str | None = None
) -> None:
    """Write ``fig`` with one legend above its panels and :data:`BAND_CAPTION` below.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : Path
    n_seeds : dict of str to list of int
        Per critic drawn, the number of seeds of each of its lines.
    threshold : str, optional
        The legend's entry for the dotted line drawn in every panel (a threshold).
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Any] = []
    for critic in sorted(n_seeds, key=ALL_CRITICS.index):
        lo, hi = min(n_seeds[critic]), max(n_seeds[critic])
        n = f"{lo}" if lo == hi else f"{lo}-{hi}"
        handles.append(Line2D([], [], color=COLORS.get(critic), label=f"{critic} (n = {n})"))
    if max(max(n) for n in n_seeds.values()) >= MIN_SAMPLES_FOR_INTERVAL:
        label = f"{100 * LEVEL:g} % CI of the mean"
        handles.append(Patch(color="0.5", alpha=0.3, linewidth=0, label=label))
    if threshold is not None:
        handles.append(Line2D([], [], color="k", lw=0.8, ls=":", label=threshold))
    # Legend entries take up to 1.8 inches and 8-point text about 1/15 inch per character.
    width = fig.get_figwidth()
    ncol = max(1, min(len(handles), int(width / 1.8)))
    fig.legend(handles=handles, loc="upper center", ncol=ncol, fontsize=9, frameon=False)
    caption = textwrap.fill(BAND_CAPTION, width=int(15 * width), break_on_hyphens=False)
    fig.text(0.01, 0.01, caption, fontsize=8, va="bottom")
    legend_rows = -(-len(handles) // ncol)
    caption_lines = caption.count("\n") + 1
    inch = 1 / fig.get_figheight()  # figure fraction
    bottom, top = (0.1 + 0.15 * caption_lines) * inch, (0.1 + 0.25 * legend_rows) * inch
    fig.tight_layout(rect=(0, bottom, 1, 1 - top))
    fig.savefig(path, dpi=110)
    pyplot().close(fig)


def plot_learning_curves(
    results: list[dict[str, Any]], out_dir: str | Path, seed: int = 0
) -> list[Path]:
    """One ``curves_<env>.png`` per environment; returns the paths."""
    plt = pyplot()
    groups = group_runs(results)
    paths = []
    for env_id in sorted({k[0] for k in groups}):
        algos = sorted({k[1] for k in groups if k[0] == env_id})
        fig, axes = plt.subplots(1, len(algos), figsize=(5 * len(algos), 4), squeeze=False)
        n_seeds: dict[str, list[int]] = {}
        for ax, algo in zip(axes[0], algos, strict=True):
            _curve_panel(ax, groups, (env_id, algo), n_seeds, seed)
            ax.set_title(f"{env_id} — {algo.upper()}")
            ax.set_xlabel("timesteps")
            ax.set_ylabel("evaluation return (deterministic)")
        path = Path(out_dir) / f"curves_{env_file_name(env_id)}.png"
        _finish(fig, path, n_seeds, f"threshold ({runs_threshold(groups, env_id):g})")
        paths.append(path)
    return paths


def plot_cell_curves(
    results: list[dict[str, Any]],
    path: str | Path,
    cells: Sequence[tuple[str, str] | None],
    titles: Mapping[tuple[str, str], str] | None = None,
    n_cols: int = 4,
    seed: int = 0,
) -> Path:
    """Evaluation return against timesteps, a panel per ``(env_id, algo)`` cell, every critic
    of ``results`` in it (its mean and band, :data:`BAND_CAPTION`) and the cell's threshold.

    Parameters
    ----------
    results : list of dict
        Runs of :func:`~sb3_geogp.comparison.results.load_results`.
    path : str or Path
    cells : sequence of (str, str) or None
        ``(env_id, algo)`` of each panel, in order, ``n_cols`` to a line; ``None`` leaves a
        panel empty.
    titles : mapping, optional
        A line under a cell's name in its title (a verdict, say).
    n_cols : int
    seed : int
        Seed of the bands' bootstrap.
    """
    plt = pyplot()
    groups = group_runs(results)
    n_rows = -(-len(cells) // n_cols)
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(2.6 * n_cols, 2.5 * n_rows), squeeze=False)
    n_seeds: dict[str, list[int]] = {}
    for i, ax in enumerate(axes.flat):
        cell = cells[i] if i < len(cells) else None
        if cell is None:
            ax.axis("off")
            continue
        _curve_panel(ax, groups, cell, n_seeds, seed)
        extra = (titles or {}).get(cell)
        name = f"{cell[1].upper()} {cell[0].split('/')[-1]}"
        ax.set_title(name if extra is None else f"{name}\n{extra}", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("timesteps", fontsize=7)
        if i % n_cols == 0:
            ax.set_ylabel("evaluation return", fontsize=7)
    _finish(fig, Path(path), n_seeds, "the cell's threshold")
    return Path(path)


def sweep_cells(
    results: list[dict[str, Any]], algos: Sequence[str] | None = None, n_cols: int = 4
) -> list[tuple[str, str] | None]:
    """The ``(env_id, algo)`` cells of ``results`` for :func:`plot_cell_curves`: by algorithm
    (in the order of ``algos``, by default alphabetical) and environment, each algorithm's
    first cell at the start of a line of ``n_cols`` (``None`` fills the line before it)."""
    cells: list[tuple[str, str] | None] = []
    for algo in algos or sorted({r["spec"]["algo"] for r in results}):
        cells += [None] * (-len(cells) % n_cols)
        envs = sorted({r["spec"]["env_id"] for r in results if r["spec"]["algo"] == algo})
        cells += [(env, algo) for env in envs]
    return cells


def _curve_panel(
    ax: Any,
    groups: dict[Key, list[dict[str, Any]]],
    cell: tuple[str, str],
    n_seeds: dict[str, list[int]],
    seed: int,
) -> None:
    """Every critic's evaluation curves of ``cell`` (mean and band) and its environment's
    threshold (dotted) in ``ax``; the number of runs of each critic is added to ``n_seeds``."""
    for critic in ALL_CRITICS:
        runs = groups.get((*cell, critic))
        if runs:
            t, values = stack_curves(runs)
            n_seeds.setdefault(critic, []).append(_band(ax, t, values, critic, seed))
    ax.axhline(runs_threshold(groups, cell[0]), color="k", lw=0.8, ls=":")


def runs_threshold(groups: dict[Key, list[dict[str, Any]]], env_id: str) -> float:
    """The steps-to-threshold level recorded in the runs of ``env_id``."""
    for key, runs in groups.items():
        if key[0] == env_id:
            return float(runs[0]["threshold"])
    raise KeyError(env_id)


def plot_critic_accuracy(results: list[dict[str, Any]], path: str | Path, seed: int = 0) -> Path:
    """``critic_accuracy.png``: critic RMSE vs Monte Carlo returns over training."""
    plt = pyplot()
    from matplotlib.ticker import LogFormatter

    class PlainLogFormatter(LogFormatter):
        """matplotlib's choice of labelled log ticks, written 0.4 and 30, not 4e-01 and 3x10^1."""

        def __call__(self, x: float, pos: int | None = None) -> str:
            return f"{x:g}" if super().__call__(x, pos) else ""

    groups = group_runs(results)
    envs = sorted({k[0] for k in groups})
    algos = sorted({k[1] for k in groups})
    fig, axes = plt.subplots(
        len(envs), len(algos), figsize=(4.5 * len(algos), 3.2 * len(envs)), squeeze=False
    )
    n_seeds: dict[str, list[int]] = {}
    for i, env_id in enumerate(envs):
        for j, algo in enumerate(algos):
            ax = axes[i, j]
            for critic in ALL_CRITICS:
                runs = groups.get((env_id, algo, critic))
                if runs:
                    t, values = stack_curves(runs, "critic_accuracy", "rmse")
                    n_seeds.setdefault(critic, []).append(_band(ax, t, values, critic, seed))
            ax.set_yscale("log")
            ax.yaxis.set_major_formatter(PlainLogFormatter())
            ax.yaxis.set_minor_formatter(PlainLogFormatter(labelOnlyBase=False))
            ax.set_title(f"{env_id} — {algo.upper()}", fontsize=9)
            ax.set_xlabel("timesteps")
            ax.set_ylabel("critic RMSE vs MC")
    _finish(fig, Path(path), n_seeds)
    return Path(path)


def write_report(
    out_dir: str | Path,
    seed: int = 0,
    baseline_dir: str | Path | Sequence[str | Path] | None = None,
    test: VerdictTest = "bootstrap",
    echo: Callable[[str], object] | None = None,
) -> list[Path]:
    """Figures and summary of the sweep in ``out_dir`` into ``out_dir/report``.

    Without matplotlib only the tables (markdown and JSON) are written. ``test`` decides the
    comparisons' verdicts (:func:`~sb3_geogp.comparison.results.comparisons`).

    With ``baseline_dir`` (another sweep's folder, or several read as one by
    :func:`load_sweeps`) also ``vs_baseline.md`` / ``.json``: each critic against the same
    critic there (:func:`comparisons` with ``baseline``), headed by the CPU models of both
    (:func:`~sb3_geogp.comparison.results.machine_caution`), which ``echo`` (``print``, say)
    is also given.

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
    diffs = comparisons(results, seed=seed, test=test)
    cmd = report / "comparisons.md"
    cmd.write_text(comparisons_markdown(diffs))
    cjs = report / "comparisons.json"
    cjs.write_text(json.dumps(diffs, indent=1))
    paths = [md, js, cmd, cjs]
    if baseline_dir is not None:
        dirs = [baseline_dir] if isinstance(baseline_dir, str | Path) else list(baseline_dir)
        baseline = load_sweeps(dirs)
        vs = comparisons(results, seed=seed, baseline=baseline, test=test)
        paths += [report / "vs_baseline.md", report / "vs_baseline.json"]
        named = ", ".join(f"`{d}`" for d in dirs)
        merged = " (a cell in several: the last)" if len(dirs) > 1 else ""
        caution = machine_caution(results, baseline)
        if echo is not None:
            echo(caution)
        header = f"Baseline: {named}{merged}\n\n{caution}\n\n"
        paths[-2].write_text(header + comparisons_markdown(vs))
        paths[-1].write_text(json.dumps(vs, indent=1))
    if not matplotlib_available():
        return paths  # the tables; figures need matplotlib
    paths += plot_learning_curves(results, report, seed=seed)
    paths.append(plot_cell_curves(results, report / "curves.png", sweep_cells(results), seed=seed))
    paths.append(plot_critic_accuracy(results, report / "critic_accuracy.png", seed=seed))
    return paths


def matplotlib_available() -> bool:
    """Whether the report can draw its figures (matplotlib is an optional dependency)."""
    return importlib.util.find_spec("matplotlib") is not None
