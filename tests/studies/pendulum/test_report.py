"""The pendulum reproduction's tables: no confidence interval from fewer than five seeds."""

from __future__ import annotations

import math
import statistics
from types import SimpleNamespace
from typing import Any

from scipy import stats as sps

from sb3_geogp.studies.pendulum.report import metric_table, ratio_table
from sb3_geogp.studies.pendulum.reproduction import ReproductionConfig, ReproductionResult
from sb3_geogp.toolbox.tables import NO_INTERVAL

NOTE = f'With fewer than 5 seeds a cell gives the mean alone ("{NO_INTERVAL}").'
RATIO_NOTE = f'With fewer than 5 seeds a cell gives the geometric mean alone ("{NO_INTERVAL}").'


def _t_interval(x: list[float]) -> tuple[float, float]:
    """Mean and 95 % Student-t half-width, computed independently of the package."""
    n = len(x)
    return statistics.fmean(x), sps.t.ppf(0.975, n - 1) * statistics.stdev(x) / math.sqrt(n)


def _result(mse: dict[tuple[str, str], list[float]], mlp: list[float]) -> ReproductionResult:
    """A result with one capacity (10) whose MSE per seed is ``mse[(model, setting)]``."""
    rows: list[dict[str, Any]] = []
    for (model, setting), values in mse.items():
        for seed, v in enumerate(values):
            rows.append(
                {"model": model, "setting": setting, "max_basis": 10, "seed": seed, "mse": v}
            )
    rows += [
        {"model": "mlp", "setting": "fixed", "max_basis": None, "seed": s, "mse": v}
        for s, v in enumerate(mlp)
    ]
    n_seeds = max(len(mlp), *(len(v) for v in mse.values()))
    config = ReproductionConfig(max_basis=(10,), seeds=tuple(range(n_seeds)))
    truth = SimpleNamespace(summary=lambda: {"td_mse": 99.0})
    return ReproductionResult(rows, truth, config)  # type: ignore[arg-type]


def _row(table: str, start: str) -> str:
    return next(line for line in table.splitlines() if line.startswith(start))


def test_metric_table_gives_the_mean_alone_from_two_seeds() -> None:
    two = [31.0, 47.0]
    table = metric_table(_result({("geodesic", "fixed"): two}, mlp=[10.0, 12.0]))
    geo = _row(table, "| geodesic | fixed |")
    assert geo == f"| geodesic | fixed | 39.00 ({NO_INTERVAL}) |"
    assert _row(table, "| mlp (64, 64) |") == f"| mlp (64, 64) | — | 11.00 ({NO_INTERVAL}) |"
    assert "±" not in table
    assert table.count(NOTE) == 1 and table.endswith(NOTE)


def test_metric_table_gives_the_t_interval_from_five_seeds() -> None:
    five = [31.0, 47.0, 38.5, 52.0, 40.25]
    mlp = [10.0, 12.0, 11.5, 9.0, 14.0]
    table = metric_table(_result({("geodesic", "fixed"): five}, mlp=mlp))
    mean, half = _t_interval(five)
    assert _row(table, "| geodesic | fixed |") == f"| geodesic | fixed | {mean:.2f} ± {half:.2f} |"
    mean, half = _t_interval(mlp)
    assert _row(table, "| mlp (64, 64) |") == f"| mlp (64, 64) | — | {mean:.2f} ± {half:.2f} |"
    assert NO_INTERVAL not in table and "fewer than" not in table


def test_the_td_row_names_the_episodes_it_ran() -> None:
    result = _result({("geodesic", "fixed"): [31.0, 47.0]}, mlp=[10.0, 12.0])
    for episodes in (800, 100):
        result.config = ReproductionConfig(max_basis=(10,), seeds=(0, 1), td_episodes=episodes)
        row = _row(metric_table(result), "| TD,")
        assert row == f"| TD, {episodes} episodes | — | 99.00 |"


def test_metric_table_counts_only_the_finite_seeds() -> None:
    # Five seeds, one failed fit (NaN): four values, no interval.
    table = metric_table(
        _result(
            {
                ("geodesic", "fixed"): [31.0, 47.0, math.nan, 52.0, 40.0],
                ("rbf", "fixed"): [60.0, 70.0, 65.0, 80.0, 75.0],
            },
            mlp=[10.0, 12.0, 11.5, 9.0, 14.0],
        )
    )
    assert _row(table, "| geodesic | fixed |") == f"| geodesic | fixed | 42.50 ({NO_INTERVAL}) |"
    mean, half = _t_interval([60.0, 70.0, 65.0, 80.0, 75.0])
    assert _row(table, "| rbf | fixed |") == f"| rbf | fixed | {mean:.2f} ± {half:.2f} |"
    assert table.count(NOTE) == 1


def _ratio_result(geo: list[float], rbf: list[float]) -> ReproductionResult:
    return _result({("geodesic", "fixed"): geo, ("rbf", "fixed"): rbf}, mlp=[1.0] * len(geo))


def test_ratio_table_gives_the_geometric_mean_alone_from_two_seeds() -> None:
    table = ratio_table(_ratio_result([20.0, 45.0], [40.0, 50.0]), references=("rbf",))
    ratio = math.sqrt(0.5 * 0.9)
    assert _row(table, "| rbf | fixed |") == f"| rbf | fixed | {ratio:.2f} ({NO_INTERVAL}) |"
    assert "[" not in _row(table, "| rbf |")
    assert table.count(RATIO_NOTE) == 1 and table.endswith(RATIO_NOTE)


def test_ratio_table_gives_the_paired_t_interval_from_five_seeds() -> None:
    geo, rbf = [20.0, 45.0, 30.0, 25.0, 33.0], [40.0, 50.0, 36.0, 45.0, 30.0]
    table = ratio_table(_ratio_result(geo, rbf), references=("rbf",))
    mean, half = _t_interval([math.log(g / r) for g, r in zip(geo, rbf, strict=True)])
    low, high = math.exp(mean - half), math.exp(mean + half)
    expected = f"| rbf | fixed | {math.exp(mean):.2f} [{low:.2f}, {high:.2f}] |"
    assert _row(table, "| rbf | fixed |") == expected
    assert NO_INTERVAL not in table and "fewer than" not in table
