"""Aggregation of a critic-comparison sweep and its report, on synthetic result files with known
answers."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sb3_geogp.comparison.report import (
    BAND_CAPTION,
    comparisons_markdown,
    difference_title,
    plot_cell_curves,
    plot_critic_accuracy,
    plot_difference_panels,
    plot_learning_curves,
    rerun_markdown,
    summary_markdown,
    sweep_cells,
)
from sb3_geogp.comparison.results import (
    METRICS,
    MIN_SEEDS_FOR_VERDICT,
    NON_FINITE_VERDICT,
    PAIRS,
    comparisons,
    group_runs,
    load_results,
    load_sweeps,
    machine_caution,
    pool_sweeps,
    rerun_comparisons,
    summary_rows,
    verdict,
)
from sb3_geogp.toolbox.stats import difference_ci
from sb3_geogp.toolbox.tables import MIN_SAMPLES_FOR_INTERVAL, NO_INTERVAL, estimate_cell


def _result(critic: str, seed: int, final: float, rmse: float) -> dict[str, Any]:
    curve = [-10.0, final / 2, final]
    return dict(
        spec=dict(env_id="E-v0", algo="ppo", critic=critic, seed=seed, total_timesteps=100),
        final_return=final,
        eval=dict(timesteps=[0, 50, 100], mean_return=curve),
        critic_accuracy=dict(timesteps=[0, 100], rmse=[50.0, rmse]),
        threshold=1.0,
        steps_to_threshold=None,
        train_seconds=1.0,
        critic_share=None,
    )


def _results() -> list[dict[str, Any]]:
    # geodesic far ahead of mlp in return, rbf equal to mlp; geodesic's critic error lower.
    out = []
    for s in range(6):
        out.append(_result("mlp", s, final=float(s), rmse=20.0 + s))
        out.append(_result("rbf", s, final=float(s), rmse=20.0 + s))
        out.append(_result("geodesic", s, final=100.0 + s, rmse=5.0 + s))
    return out


def test_verdict_respects_the_direction_of_the_metric() -> None:
    assert verdict(1.0, 2.0) == "better" and verdict(-2.0, -1.0) == "worse"
    assert verdict(1.0, 2.0, higher_is_better=False) == "worse"
    assert verdict(-2.0, -1.0, higher_is_better=False) == "better"
    assert verdict(-1.0, 1.0) == "no difference" == verdict(-1.0, 1.0, False)


def test_comparisons_against_hand_computed_means() -> None:
    diffs = comparisons(_results())
    ran = {"mlp", "rbf", "geodesic"}
    assert len(diffs) == len(METRICS) * sum(a in ran and b in ran for a, b in PAIRS) == 9
    by = {(d["metric"], d["a"], d["b"]): d for d in diffs}
    # hand-computed: final returns 100..105 vs 0..5, curve means (-10 + 1.5 f) / 3.
    geo_mlp = by[("final_return", "geodesic", "mlp")]
    assert geo_mlp["diff"] == pytest.approx(100.0)
    assert geo_mlp["verdict"] == "better" == geo_mlp["fw_verdict"]
    auc = by[("mean_return", "geodesic", "mlp")]
    assert auc["diff"] == pytest.approx(1.5 * 100.0 / 3)
    assert by[("final_return", "rbf", "mlp")]["diff"] == 0.0
    assert by[("final_return", "rbf", "mlp")]["verdict"] == "no difference"
    rmse = by[("critic_rmse", "geodesic", "rbf")]
    assert rmse["diff"] == pytest.approx(-15.0) and rmse["verdict"] == "better"
    # 3 pairs, Bonferroni per metric; the family-wise interval contains the 95 % one.
    for d in diffs:
        assert d["fw_level"] == pytest.approx(1 - 0.05 / 3)
        assert d["fw_low"] <= d["low"] <= d["diff"] <= d["high"] <= d["fw_high"]


def test_a_rerun_keeps_the_published_family() -> None:
    """family_size sets the Bonferroni level; the interval is the bootstrap at that level."""
    runs = _results()
    for d in comparisons(runs, family_size=42):
        assert d["family_size"] == 42 and d["fw_level"] == pytest.approx(1 - 0.05 / 42)
        metric = METRICS[d["metric"]]
        xa, xb = (
            np.array([metric.of_run(r) for r in runs if r["spec"]["critic"] == c], dtype=float)
            for c in (d["a"], d["b"])
        )
        _, low, high = difference_ci(xa, xb, level=d["fw_level"], seed=0)
        assert (d["fw_low"], d["fw_high"]) == (float(low), float(high))


def test_familywise_level_can_overturn_a_verdict() -> None:
    results = [
        _result(critic, s, final=s + shift, rmse=1.0)
        for s in range(5)
        for critic, shift in (("mlp", 0.0), ("rbf", 0.0), ("geodesic", 2.0))
    ]
    d = next(
        d
        for d in comparisons(results)
        if (d["metric"], d["a"], d["b"]) == ("final_return", "geodesic", "mlp")
    )
    # Normal theory: standard error sqrt(2/5 + 2/5) = 0.894, so 2 +- 1.96 se excludes 0 but
    # 2 +- 2.39 se (two-sided 1 - 0.05/3) does not: a verdict that does not hold family-wise,
    # shown in the table but not in bold.
    assert d["verdict"] == "better" and d["fw_verdict"] == "no difference"
    table = comparisons_markdown([d])
    assert " better |" in table and "**better**" not in table


def test_a_permutation_test_does_not_take_a_group_of_equal_runs_as_known() -> None:
    """50 runs of one critic all at a floor, of the other 42 at it and 8 above (A2C
    MountainCarContinuous's shape), read at the published family of 42: the bootstrap
    interval excludes 0 even family-wise, as it resamples the floor as a known mean; a
    permutation test gives the share of the 100 runs' splits as extreme, by a count: only the
    splits that keep the 8 together, 2 C(92, 42) / C(100, 50) = 0.0058, better at 95 % but not
    family-wise (0.05 / 42 = 0.0012)."""
    results = [
        _result(c, s, final=float(s - 32) if c == "geodesic" and s >= 42 else -99.9, rmse=1.0)
        for s in range(50)
        for c in ("mlp", "geodesic")
    ]
    bootstrap, permutation = (
        next(
            d
            for d in comparisons(results, test=test, family_size=42)
            if d["metric"] == "final_return"
        )
        for test in ("bootstrap", "permutation")
    )
    assert bootstrap["fw_verdict"] == "better" and "p_value" not in bootstrap
    expected = 2 * math.comb(92, 42) / math.comb(100, 50)
    assert permutation["p_value"] == pytest.approx(expected, abs=0.002)
    assert permutation["verdict"] == "better" and permutation["fw_verdict"] == "no difference"
    assert (permutation["low"], permutation["high"]) == (bootstrap["low"], bootstrap["high"])
    assert "permutation test" in comparisons_markdown([permutation])


def test_no_verdict_from_too_few_seeds() -> None:
    few = [r for r in _results() if r["spec"]["seed"] < MIN_SEEDS_FOR_VERDICT - 1]
    for d in comparisons(few):
        assert d["verdict"] == d["fw_verdict"] == "too few seeds"
        assert d["low"] <= d["diff"] <= d["high"]  # the interval is still reported


def test_summary_rows_hand_computed() -> None:
    rows = summary_rows(_results())
    assert [r["critic"] for r in rows] == ["mlp", "rbf", "geodesic"]
    geo = rows[2]
    assert geo["final_mean"] == pytest.approx(102.5) and geo["n_seeds"] == 6
    assert geo["final_iqm"] == pytest.approx(np.mean([101, 102, 103, 104]))
    assert geo["critic_rmse_mean"] == pytest.approx(7.5)


def test_summary_gives_the_median_seconds_to_threshold_where_every_run_recorded_them() -> None:
    reached = [(50.0, 2.0), (100.0, 4.5), (None, None)]  # the last run never reached it
    runs = [
        {**_result("geodesic", s, 1.0, 1.0), "steps_to_threshold": a, "seconds_to_threshold": b}
        for s, (a, b) in enumerate(reached)
    ]
    row = summary_rows(runs)[0]
    assert (row["steps_to_threshold_median"], row["seconds_to_threshold_median"]) == (100, 4.5)
    assert "(2/3 ≥ 1; 4.5 s)" in summary_markdown([row])
    never = summary_rows([{**r, "seconds_to_threshold": None} for r in runs[2:]])[0]
    assert never["seconds_to_threshold_median"] is None  # JSON's null for inf
    assert "(0/1 ≥ 1; — s)" in summary_markdown([never])
    older = summary_rows([_result("geodesic", 0, 1.0, 1.0), *runs[1:]])[0]  # one file of 0.39
    assert "seconds_to_threshold_median" not in older
    assert "(1/3 ≥ 1)" in summary_markdown([older])


def test_comparison_against_a_baseline_sweep() -> None:
    base = _results()
    # The same sweep with every GP critic's final return raised by 50 and the MLP unchanged.
    arm = [
        {**r, "final_return": r["final_return"] + (0.0 if r["spec"]["critic"] == "mlp" else 50.0)}
        for r in base
    ]
    diffs = comparisons(arm, baseline=base)
    final = {d["a"]: d for d in diffs if d["metric"] == "final_return"}
    assert set(final) == {"mlp", "rbf", "geodesic"}
    assert all(d["b"] == d["a"] and d["b_sweep"] == "baseline" for d in diffs)
    assert final["mlp"]["diff"] == 0.0 and final["mlp"]["verdict"] == "no difference"
    assert final["rbf"]["diff"] == pytest.approx(50.0) and final["rbf"]["verdict"] == "better"
    assert final["geodesic"]["fw_level"] == pytest.approx(1 - 0.05 / 3)
    table = comparisons_markdown(diffs)
    assert "geodesic − baseline geodesic" in table and "rbf − mlp" not in table


def _on(results: list[dict[str, Any]], cpu: str | None) -> list[dict[str, Any]]:
    """``results`` as made on a machine of CPU model ``cpu`` (None: before it was recorded)."""
    if cpu is None:
        return results
    return [{**r, "provenance": {"machine": {"cpu_model": cpu}}} for r in results]


def test_a_baseline_from_another_cpu_model_is_named_with_a_caution() -> None:
    base, arm = _results(), _results()
    same = machine_caution(_on(arm, "AMD EPYC"), _on(base, "AMD EPYC"))
    assert same == "CPU models: this sweep AMD EPYC; baseline AMD EPYC."
    other = machine_caution(_on(arm, "AMD EPYC"), _on(base, "Intel(R) Xeon(R) Processor"))
    assert other.startswith("CPU models: this sweep AMD EPYC; baseline Intel(R) Xeon(R) Processor.")
    assert "Caution" in other and "Re-run the baseline on this machine" in other
    # a baseline pooled from both machines is mixed too
    pooled = _on(base[:9], "AMD EPYC") + _on(base[9:], "Intel(R) Xeon(R) Processor")
    mixed = machine_caution(_on(arm, "AMD EPYC"), pooled)
    assert "baseline AMD EPYC, Intel(R) Xeon(R) Processor." in mixed and "Caution" in mixed
    # runs that do not record their CPU cannot be told apart: named, no caution
    unknown = machine_caution(_on(arm, "AMD EPYC"), _on(base, None))
    assert unknown == "CPU models: this sweep AMD EPYC; baseline unrecorded."


def _percentile_bootstrap_of_mean(x: np.ndarray, seed: int = 0) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of the mean, written out from its definition."""
    rng = np.random.default_rng(seed)
    means = np.array([x[rng.integers(0, len(x), len(x))].mean() for _ in range(10_000)])
    low, high = np.percentile(means, [2.5, 97.5])
    return float(low), float(high)


def test_estimate_cell_gives_no_interval_below_five_samples() -> None:
    assert MIN_SAMPLES_FOR_INTERVAL == 5 == MIN_SEEDS_FOR_VERDICT  # one rule for both
    assert estimate_cell("1.5", "[1, 2]", 4) == "1.5 (n < 5: no interval)"
    assert estimate_cell("1.5", "± 0.5", 5) == "1.5 ± 0.5"


def test_summary_table_interval_only_from_five_seeds() -> None:
    finals = np.array([100.0, 130.0, 170.0, 220.0, 300.0])
    results = [_result("geodesic", s, final=f, rmse=20.0) for s, f in enumerate(finals)]
    results += [_result("mlp", s, final=50.0 + s, rmse=20.0) for s in range(2)]
    table = summary_markdown(summary_rows(results, seed=3))
    mlp = next(line for line in table.splitlines() if "| mlp |" in line)
    geo = next(line for line in table.splitlines() if "| geodesic |" in line)
    assert f"| 50.5 ({NO_INTERVAL}) |" in mlp and "[" not in mlp
    low, high = _percentile_bootstrap_of_mean(finals, seed=3)
    assert f"| {finals.mean():.1f} [{low:.1f}, {high:.1f}] |" in geo
    assert "With fewer than 5 seeds: the mean alone" in table.splitlines()[0]
    five = summary_markdown(summary_rows([r for r in results if r["spec"]["critic"] != "mlp"]))
    assert NO_INTERVAL not in five and "fewer than" not in five


@pytest.mark.parametrize("test", ["bootstrap", "permutation"])
def test_a_non_finite_run_is_flagged_not_read_as_no_difference(test: str) -> None:
    """One NaN critic RMSE (an unmeasured run) and one infinite return among six seeds: the
    cells they fall in get no verdict, whatever the test, and the table says why; the other
    cells keep theirs (the NaN interval would otherwise hold no 0 and no side)."""
    results = _results()
    results[1]["critic_accuracy"]["rmse"][-1] = math.nan  # rbf, seed 0
    results[5]["final_return"] = math.inf  # geodesic, seed 1
    by = {(d["metric"], d["a"], d["b"]): d for d in comparisons(results, test=test)}
    flagged = {k for k, d in by.items() if d["verdict"] == NON_FINITE_VERDICT}
    assert flagged == {
        ("critic_rmse", "rbf", "mlp"),
        ("critic_rmse", "geodesic", "rbf"),
        ("final_return", "geodesic", "mlp"),
        ("final_return", "geodesic", "rbf"),
    }
    assert all(by[k]["fw_verdict"] == NON_FINITE_VERDICT for k in flagged)
    assert by[("critic_rmse", "geodesic", "mlp")]["verdict"] == "better"
    assert NON_FINITE_VERDICT in comparisons_markdown(list(by.values()))


def test_comparison_table_gives_neither_interval_nor_verdict_below_five_seeds() -> None:
    two = [r for r in _results() if r["spec"]["seed"] < 2]
    table = comparisons_markdown(comparisons(two))
    cells = [line for line in table.splitlines() if line.startswith("| `E-v0`")]
    assert len(cells) == len(METRICS)
    for line in cells:
        assert line.count(NO_INTERVAL) == 3  # the three pairs of mlp, rbf and geodesic
        assert "[" not in line and "too few seeds" not in line
    assert "on either side: the difference alone, no interval and no verdict" in table
    five = comparisons([r for r in _results() if r["spec"]["seed"] < 5], seed=4)
    d = next(
        d for d in five if (d["metric"], d["a"], d["b"]) == ("final_return", "geodesic", "mlp")
    )
    assert f"{d['diff']:.1f} [{d['low']:.1f}, {d['high']:.1f}] **better**" in comparisons_markdown(
        [d]
    )


def test_figures_say_what_their_bands_are(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    plt = pytest.importorskip("matplotlib.pyplot")
    figures: list[Any] = []
    monkeypatch.setattr(plt, "close", figures.append)
    results = [r for r in _results() if r["spec"]["critic"] != "rbf" or r["spec"]["seed"] < 2]
    plot_learning_curves(results, tmp_path)
    plot_critic_accuracy(results, tmp_path / "critic_accuracy.png")
    assert len(figures) == 2
    for fig, threshold in zip(figures, ("threshold (1)", None), strict=True):
        (legend,) = fig.legends
        labels = [t.get_text() for t in legend.get_texts()]
        expected = ["mlp (n = 6)", "rbf (n = 2)", "geodesic (n = 6)", "95 % CI of the mean"]
        assert labels == [*expected, *([threshold] if threshold else [])]
        assert [t.get_text().replace("\n", " ") for t in fig.texts] == [BAND_CAPTION]
        (ax,) = fig.axes
        assert len(ax.collections) == 2  # bands of the 6-seed critics, none of the 2-seed one
    monkeypatch.undo()
    for fig in figures:
        plt.close(fig)


def test_cell_curves_draw_each_cells_means_and_threshold(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A panel per cell in the order given (``None``: an empty one), each with every critic's
    mean curve over its seeds (known by hand) and its own environment's threshold."""
    plt = pytest.importorskip("matplotlib.pyplot")
    figures: list[Any] = []
    monkeypatch.setattr(plt, "close", figures.append)
    other = []
    for r in _results():
        spec = {**r["spec"], "env_id": "sb3_geogp/F-v0", "algo": "a2c"}
        other.append({**r, "spec": spec, "threshold": 2.0})
    cells = [("E-v0", "ppo"), None, ("sb3_geogp/F-v0", "a2c")]
    titles = {("E-v0", "ppo"): "+100, better"}
    plot_cell_curves(_results() + other, tmp_path / "c.png", cells, titles, n_cols=2)
    (fig,) = figures
    drawn = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_title() for ax in drawn] == ["PPO E-v0\n+100, better", "A2C F-v0"]
    assert not fig.axes[1].axison and not fig.axes[3].axison
    # final returns: mlp and rbf 0..5 (mean 2.5), geodesic 100..105 (mean 102.5)
    expected = {2.5: [-10.0, 1.25, 2.5], 102.5: [-10.0, 51.25, 102.5]}
    for ax, threshold in zip(drawn, (1.0, 2.0), strict=True):
        *means, level = ax.get_lines()
        assert [list(line.get_ydata()) for line in means] == [
            pytest.approx(expected[f]) for f in (2.5, 2.5, 102.5)
        ]
        assert list(means[0].get_xdata()) == [0, 50, 100]
        assert list(level.get_ydata()) == [threshold, threshold]
    (legend,) = fig.legends
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels == ["mlp (n = 6)", "rbf (n = 6)", "geodesic (n = 6)", "95 % CI of the mean",
                      "the cell's threshold"]  # fmt: skip
    monkeypatch.undo()
    plt.close(fig)


def test_difference_title_says_where_a_verdict_holds_only_at_95() -> None:
    row = {"diff": 51.04, "low": 24.8, "high": 79.85, "verdict": "better", "fw_verdict": "better"}
    assert difference_title(row) == "+51.0 [+24.8, +79.8], better"
    row |= {
        "diff": -3.0,
        "low": -6.1,
        "high": -0.5,
        "verdict": "worse",
        "fw_verdict": "no difference",
    }
    assert difference_title(row) == "-3.0 [-6.1, -0.5], worse at 95 %"


def test_sweep_cells_start_each_algorithm_on_a_new_line() -> None:
    runs = [{"spec": {"env_id": env, "algo": algo}} for env in ("B-v0", "A-v0", "C-v0")
            for algo in ("ppo", "a2c")] + [{"spec": {"env_id": "A-v0", "algo": "ppo"}}]  # fmt: skip
    a2c = [("A-v0", "a2c"), ("B-v0", "a2c"), ("C-v0", "a2c")]
    ppo = [("A-v0", "ppo"), ("B-v0", "ppo"), ("C-v0", "ppo")]
    assert sweep_cells(runs, n_cols=2) == [*a2c, None, *ppo]
    assert sweep_cells(runs, ("ppo", "a2c"), n_cols=3) == [*ppo, *a2c]
    assert sweep_cells(runs, ("ppo", "a2c"), n_cols=4) == [*ppo, None, *a2c]


@pytest.mark.parametrize("n_cells", [1, 2, 7])
def test_difference_panels_keep_a_long_title_inside_the_figure(
    n_cells: int, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """However few the panels, the title is wrapped to the figure's width, never cut."""
    plt = pytest.importorskip("matplotlib.pyplot")
    figures: list[Any] = []
    monkeypatch.setattr(plt, "close", figures.append)
    cell = {"diff": 1.0, "low": 0.0, "high": 2.0}
    rows = [{"env": f"Env{i}-v0", "algo": "ppo", "C − A": cell} for i in range(n_cells)]
    title = "PPO (20 seeds a cell): Monte Carlo targets (C), SB3's returns (A), final return"
    plot_difference_panels(rows, ["C − A"], tmp_path / "d.png", title, n_cols=n_cells,
                           panel_size=(2.6, 2.4))  # fmt: skip
    (fig,) = figures
    renderer = fig.canvas.get_renderer()
    extent = fig._suptitle.get_window_extent(renderer)
    assert extent.x0 >= 0 and extent.x1 <= fig.bbox.width
    assert fig._suptitle.get_text().replace("\n", " ") == title
    monkeypatch.undo()
    plt.close(fig)


def test_a_rerun_is_compared_under_the_published_rule() -> None:
    """Re-run RBF runs replace the published ones; the MLP keeps its published runs."""
    published = _results()
    rerun = [_result("rbf", s, final=50.0 + s, rmse=1.0) for s in range(6)]
    before, after = rerun_comparisons(published, rerun)
    assert (
        {(r["a"], r["b"]) for r in before} == {("rbf", "mlp")} == {(r["a"], r["b"]) for r in after}
    )
    final = {r["metric"]: r for r in after}["final_return"]
    assert final["diff"] == pytest.approx(50.0) and final["fw_verdict"] == "better"
    assert {r["metric"]: r for r in before}["final_return"]["verdict"] == "no difference"
    assert all(r["family_size"] == 3 for r in before + after)  # the published sweep's 3 pairs
    text = rerun_markdown(before, after)
    assert text.count("| `E-v0` | ppo | rbf − mlp |") == len(METRICS)


def test_a_new_default_critic_is_compared_with_the_one_it_replaces() -> None:
    """A re-run Laplacian critic replaces the published geodesic one: before is geodesic - b,
    after laplacian - b, against the critics not re-run only, under the published family."""
    published = _results()
    rerun = [_result("laplacian", s, final=-50.0 - s, rmse=1.0) for s in range(6)]
    before, after = rerun_comparisons(published, rerun, replaces={"laplacian": "geodesic"})
    assert {(r["a"], r["b"]) for r in before} == {("geodesic", "mlp"), ("geodesic", "rbf")}
    assert {(r["a"], r["b"]) for r in after} == {("laplacian", "mlp"), ("laplacian", "rbf")}
    assert all(r["family_size"] == 3 for r in before + after)
    final = {(r["metric"], r["b"]): r for r in after}[("final_return", "mlp")]
    # hand-computed: -50..-55 against 0..5
    assert final["diff"] == pytest.approx(-55.0) and final["fw_verdict"] == "worse"
    text = rerun_markdown(before, after, {"laplacian": "geodesic"})
    row = "| `E-v0` | ppo | laplacian − mlp (published: geodesic − mlp) | 100.0 ["
    assert text.count(row) == 1  # final return; the published geodesic was 100 ahead
    # Without the mapping the published geodesic runs stay in the cell as a critic not re-run.
    _, plain = rerun_comparisons(published, rerun)
    assert ("laplacian", "geodesic") in {(r["a"], r["b"]) for r in plain}


def _write_sweep(folder: Path, results: list[dict[str, Any]]) -> Path:
    """``results`` as a sweep folder's result files (``folder/runs/*.json``)."""
    (folder / "runs").mkdir(parents=True)
    for r in results:
        s = r["spec"]
        (folder / "runs" / f"{s['critic']}_{s['seed']}.json").write_text(json.dumps(r))
    return folder


def test_load_sweeps_takes_a_cell_whole_from_the_last_folder(tmp_path: Path) -> None:
    sweep = _write_sweep(tmp_path / "sweep", _results())
    # A re-run of the geodesic cell with fewer seeds and other returns.
    rerun = _write_sweep(
        tmp_path / "rerun", [_result("geodesic", s, final=-s, rmse=1.0) for s in (7, 8)]
    )
    merged = group_runs(load_sweeps([sweep, rerun]))
    assert [r["spec"]["seed"] for r in merged[("E-v0", "ppo", "geodesic")]] == [7, 8]
    assert merged[("E-v0", "ppo", "mlp")] == group_runs(load_results(sweep))[("E-v0", "ppo", "mlp")]
    reverse = group_runs(load_sweeps([rerun, sweep]))
    assert [r["spec"]["seed"] for r in reverse[("E-v0", "ppo", "geodesic")]] == list(range(6))


def test_pool_sweeps_adds_seeds_and_takes_a_repeated_run_from_the_last_folder(
    tmp_path: Path,
) -> None:
    sweep = _write_sweep(tmp_path / "sweep", _results())
    more = _write_sweep(
        tmp_path / "more", [_result("geodesic", s, final=-s, rmse=1.0) for s in (5, 6, 7)]
    )
    pooled = group_runs(pool_sweeps([sweep, more]))
    geodesic = pooled[("E-v0", "ppo", "geodesic")]
    assert [r["spec"]["seed"] for r in geodesic] == list(range(8))
    before = group_runs(load_results(sweep))[("E-v0", "ppo", "geodesic")]
    assert geodesic[:5] == before[:5]
    assert [r["final_return"] for r in geodesic[5:]] == [-5, -6, -7]
    assert pooled[("E-v0", "ppo", "mlp")] == group_runs(load_results(sweep))[("E-v0", "ppo", "mlp")]
    reverse = group_runs(pool_sweeps([more, sweep]))[("E-v0", "ppo", "geodesic")]
    assert reverse[5] == before[5] and [r["spec"]["seed"] for r in reverse] == list(range(8))


def test_rerun_verdicts_script_writes_the_before_and_after(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from tests.test_examples_engine import load_script

    published = _write_sweep(tmp_path / "published", _results())
    rerun = _write_sweep(
        tmp_path / "rerun", [_result("laplacian", s, final=-50.0 - s, rmse=1.0) for s in range(6)]
    )
    script = load_script("rerun_verdicts")
    out = tmp_path / "before_after.md"
    argv = ["--published", str(published), "--rerun", str(rerun), "--out", str(out)]
    assert script.main([*argv, "--replaces", "laplacian=geodesic"]) == 0
    written = json.loads(out.with_suffix(".json").read_text())
    before, after = rerun_comparisons(
        _results(), load_results(rerun), replaces={"laplacian": "geodesic"}
    )
    assert (written["before"], written["after"]) == (before, after)
    assert out.read_text() in capsys.readouterr().out
    with pytest.raises(SystemExit):
        script.main([*argv, "--replaces", "laplacian=ppo"])
    assert "expected NEW=OLD" in capsys.readouterr().err
    with pytest.raises(SystemExit, match="no results"):  # the re-run has PPO cells only
        script.main([*argv, "--algos", "a2c"])


def test_replication_reading_follows_the_fixed_rule() -> None:
    from tests.test_examples_engine import load_script

    script = load_script("replication_verdicts")
    cases = {
        ("better", "better"): "replicates",
        ("worse", "worse"): "replicates",
        ("better", "no difference"): "not confirmed",
        ("worse", "better"): "contradicted",
        ("no difference", "no difference"): "stays no difference",
        ("no difference", "worse"): "new: worse",
    }
    for (old, new), reading in cases.items():
        assert script.replication({"verdict": old}, {"verdict": new}) == reading


def test_replication_verdicts_script_pools_and_refuses_shared_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Seeds 0-5: the Laplacian critic 100 ahead of the MLP; fresh seeds 10-15: level with
    it. The fresh column says no difference, the pooled one the hand-computed +50, and the
    reading is "not confirmed"; the RBF runs of the published sweep are left out."""
    from tests.test_examples_engine import load_script

    script = load_script("replication_verdicts")
    before = [r for r in _results() if r["spec"]["critic"] != "geodesic"]
    before += [_result("laplacian", s, final=100.0 + s, rmse=5.0) for s in range(6)]
    fresh = [
        _result(c, s, final=float(s % 3), rmse=20.0)
        for c in ("mlp", "laplacian")
        for s in range(10, 16)
    ]
    out = tmp_path / "verdicts.md"
    argv = ["--before", str(_write_sweep(tmp_path / "before", before))]
    argv += ["--fresh", str(_write_sweep(tmp_path / "fresh", fresh))]
    assert script.main([*argv, "--critic", "ppo=laplacian", "--out", str(out)]) == 0
    rows = {r["metric"]: r for r in json.loads(out.with_suffix(".json").read_text())}
    final = rows["final_return"]
    assert final["critic"] == "laplacian" and final["reading"] == "not confirmed"
    assert (
        final["before"]["diff"] == pytest.approx(100.0) and final["before"]["verdict"] == "better"
    )
    assert (
        final["fresh"]["diff"] == pytest.approx(0.0)
        and final["fresh"]["verdict"] == "no difference"
    )
    # Pooled over 12 seeds each: (102.5 + 1) / 2 - (2.5 + 1) / 2 = 50.
    assert final["pooled"]["diff"] == pytest.approx(50.0) and final["pooled"]["n_a"] == 12
    assert final["fresh"]["family_size"] == 42
    assert "| **counts** |" in out.read_text() and out.with_suffix(".png").stat().st_size > 0
    capsys.readouterr()
    with pytest.raises(ValueError, match="on both sides"):
        script.main([*argv[:2], "--fresh", argv[1], "--critic", "ppo=laplacian", "--out", str(out)])
    with pytest.raises(SystemExit):
        script.main([*argv, "--critic", "ppo=mlp", "--out", str(out)])
    assert "expected ALGO=CRITIC" in capsys.readouterr().err


def _option_sweeps(tmp_path: Path, variant_critic: str, reference_critic: str) -> list[str]:
    """``--variant`` and ``--reference`` of two written sweeps, seeds 0-5: the variant
    (``variant_critic``) 10 ahead, run for run, of the reference GP critic, which is level with
    the MLP."""
    reference = [_result(c, s, final=float(s % 3), rmse=20.0) for c in ("mlp", reference_critic)
                 for s in range(6)]  # fmt: skip
    variant = [_result(variant_critic, s, final=10.0 + s % 3, rmse=20.0) for s in range(6)]
    return [
        "--variant", str(_write_sweep(tmp_path / "variant", variant)),
        "--reference", str(_write_sweep(tmp_path / "reference", reference)),
    ]  # fmt: skip


def test_option_verdicts_compares_variant_reference_and_mlp(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Seeds 0-5: the variant 10 ahead of the reference GP critic run for run, which is level
    with the MLP; hand-computed differences 10, 10, 0, the final returns listed sorted, the
    counts of each column; a variant sweep holding the MLP is refused."""
    from tests.test_examples_engine import load_script

    script = load_script("option_verdicts")
    out = tmp_path / "option.md"
    argv = _option_sweeps(tmp_path, "laplacian", "laplacian")
    argv += ["--critic", "laplacian", "--label", "prior_mean=linear", "--out", str(out)]
    assert script.main(argv) == 0
    rows = {r["metric"]: r for r in json.loads(out.with_suffix(".json").read_text())}
    final = rows["final_return"]
    diffs = [final[c]["diff"] for c in script.COLUMNS]
    assert diffs == pytest.approx([10.0, 10.0, 0.0])
    assert [final[c]["verdict"] for c in script.COLUMNS] == ["better", "better", "no difference"]
    assert final[script.COLUMNS[0]]["family_size"] == 42
    text = out.read_text()
    assert "| `E-v0` ppo | variant | 6 | 10, 10, 11, 11, 12, 12 |" in text
    assert "| **counts** | better (fw) / n.d. / worse (fw) | 1 (1) / 0 / 0 (0) |" in text
    assert out.with_suffix(".png").stat().st_size > 0
    capsys.readouterr()
    with pytest.raises(ValueError, match="runs of laplacian only"):
        script.main([*argv[:1], str(tmp_path / "reference"), *argv[2:]])


def test_option_verdicts_reads_another_kernel_as_an_option(tmp_path: Path) -> None:
    """A variant sweep of ``rbf`` 10 ahead of the reference ``geodesic`` critic run for run:
    ``--variant-critic rbf`` compares it as the geodesic critic's option (differences 10, 10,
    0); without it the sweep is refused as one of another critic."""
    from tests.test_examples_engine import load_script

    script = load_script("option_verdicts")
    out = tmp_path / "option.md"
    argv = _option_sweeps(tmp_path, "rbf", "geodesic")
    argv += ["--critic", "geodesic", "--label", "kernel=rbf", "--out", str(out)]
    assert script.main([*argv, "--variant-critic", "rbf"]) == 0
    rows = {r["metric"]: r for r in json.loads(out.with_suffix(".json").read_text())}
    diffs = [rows["final_return"][c]["diff"] for c in script.COLUMNS]
    assert diffs == pytest.approx([10.0, 10.0, 0.0])
    with pytest.raises(ValueError, match="runs of geodesic only"):
        script.main(argv)


def test_option_verdicts_reads_only_the_seeds_asked_for(tmp_path: Path) -> None:
    """A variant sweep of seeds 0-11 whose seeds 6-11 are 100 further ahead, read with
    ``--seeds 0..5`` against references of seeds 0-5: the differences of those seeds alone
    (10 against the GP reference), six variant runs."""
    from tests.test_examples_engine import load_script

    script = load_script("option_verdicts")
    reference = [_result(c, s, final=float(s % 3), rmse=20.0) for c in ("mlp", "laplacian")
                 for s in range(6)]  # fmt: skip
    variant = [
        _result("laplacian", s, final=10.0 + s % 3 + (100.0 if s >= 6 else 0.0), rmse=20.0)
        for s in range(12)
    ]
    out = tmp_path / "option.md"
    argv = ["--variant", str(_write_sweep(tmp_path / "variant", variant))]
    argv += ["--reference", str(_write_sweep(tmp_path / "reference", reference))]
    argv += ["--critic", "laplacian", "--label", "x", "--out", str(out)]
    assert script.main([*argv, "--seeds", *map(str, range(6))]) == 0
    rows = {r["metric"]: r for r in json.loads(out.with_suffix(".json").read_text())}
    assert rows["final_return"][script.COLUMNS[0]]["diff"] == pytest.approx(10.0)
    assert "| `E-v0` ppo | variant | 6 | 10, 10, 11, 11, 12, 12 |" in out.read_text()
    assert script.main(argv) == 0  # all twelve: the later seeds count too
    rows = {r["metric"]: r for r in json.loads(out.with_suffix(".json").read_text())}
    assert rows["final_return"][script.COLUMNS[0]]["diff"] == pytest.approx(60.0)


def test_option_verdicts_pools_folders_of_different_seeds(tmp_path: Path) -> None:
    """Variant and references split into folders of seeds 0-5 and 6-11, the variant 10 ahead
    on the first and 30 on the second: ``--pool`` compares all twelve seeds (20 ahead), without
    it each cell is the last folder's (30). References of seeds the variant lacks (12-17, 100
    further ahead) are left out with ``--pool``."""
    from tests.test_examples_engine import load_script

    script = load_script("option_verdicts")
    variants, references = [], []
    for part, seeds, ahead in (("a", range(6), 10.0), ("b", range(6, 12), 30.0)):
        reference = [_result(c, s, final=float(s % 3), rmse=20.0) for c in ("mlp", "laplacian")
                     for s in seeds]  # fmt: skip
        variant = [_result("laplacian", s, final=ahead + s % 3, rmse=20.0) for s in seeds]
        variants.append(str(_write_sweep(tmp_path / f"variant_{part}", variant)))
        references.append(str(_write_sweep(tmp_path / f"reference_{part}", reference)))
    extra_seeds = [_result(c, s, final=100.0, rmse=20.0) for c in ("mlp", "laplacian")
                   for s in range(12, 18)]  # fmt: skip
    references.insert(0, str(_write_sweep(tmp_path / "reference_more", extra_seeds)))
    out = tmp_path / "option.md"
    argv = ["--variant", *variants, "--reference", *references, "--critic", "laplacian"]
    argv += ["--label", "x", "--out", str(out)]
    for extra, diff, n in (([], 30.0, 6), (["--pool"], 20.0, 12)):
        assert script.main([*argv, *extra]) == 0
        final = {r["metric"]: r for r in json.loads(out.with_suffix(".json").read_text())}
        assert final["final_return"][script.COLUMNS[0]]["diff"] == pytest.approx(diff)
        assert f"| `E-v0` ppo | variant | {n} |" in out.read_text()
        assert f"| `E-v0` ppo | reference | {n} |" in out.read_text()
