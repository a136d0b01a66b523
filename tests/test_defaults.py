"""Default hyperparameters: the one rule, checked against hand computations."""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

import sb3_geogp
from sb3_geogp import GPCriticWarning, SparseOnlineGP
from sb3_geogp.defaults import (
    COVERAGE_POINTS,
    BoundsCoverage,
    bounds_lengthscale,
    default_lengthscale,
    resolve_lengthscale,
    target_standardisation,
)
from sb3_geogp.kernels import RBFKernel


def test_bounds_lengthscale_uses_finite_bounds_only() -> None:
    """The std of a uniform on the bounds where bounded, NaN (from data) elsewhere."""
    low = np.array([-1.0, -np.inf, 0.0, -3.4e38], dtype=np.float32)
    high = np.array([1.0, np.inf, 6.0, 3.4e38], dtype=np.float32)
    got = bounds_lengthscale(low, high)
    np.testing.assert_allclose(got, [2 / np.sqrt(12), np.nan, 6 / np.sqrt(12), np.nan])


def test_resolve_lengthscale_order_is_request_then_bounds_then_batch() -> None:
    rng = np.random.default_rng(0)
    x = torch.as_tensor(rng.normal(size=(50, 3)) * [1.0, 2.0, 3.0])
    requested = torch.tensor([0.5, float("nan"), float("nan")], dtype=torch.float64)
    bounds = (np.array([-9.0, -1.0, -np.inf]), np.array([9.0, 2.0, np.inf]))
    before_data = resolve_lengthscale(requested, bounds=bounds)
    np.testing.assert_allclose(before_data.numpy(), [0.5, 3 / np.sqrt(12), np.nan])
    after = resolve_lengthscale(before_data, x=x)
    std = x.numpy().std(axis=0)
    np.testing.assert_allclose(after.numpy(), [0.5, 3 / np.sqrt(12), std[2]], rtol=1e-12)


def test_default_lengthscale_falls_back_for_constant_dimensions() -> None:
    x = torch.tensor([[1.0, -4.0, 0.0], [3.0, -4.0, 0.0]], dtype=torch.float64)
    np.testing.assert_allclose(default_lengthscale(x).numpy(), [1.0, 4.0, 1.0])


@pytest.mark.parametrize("value", [0.1, 0.3, 123.456])
def test_constants_get_their_fallbacks_in_float32_as_in_float64(value: float) -> None:
    """A constant that float32 does not hold exactly: its mean differs from it by rounding, so
    its standard deviation is about 1e-8 of it. It does not vary: the lengthscale falls back to
    its size and the target scale to 1, in both dtypes."""
    for dtype in (torch.float32, torch.float64):
        column = torch.full((1000, 1), value, dtype=dtype)
        size = torch.tensor([value], dtype=dtype)
        torch.testing.assert_close(default_lengthscale(column), size, rtol=0, atol=0)
        assert target_standardisation(column[:, 0])[1] == 1.0


def test_target_standardisation_uses_given_values_else_the_batch() -> None:
    y = torch.tensor([1.0, 2.0, 6.0], dtype=torch.float64)
    mean, scale = target_standardisation(y)
    assert float(mean) == 3.0 and abs(float(scale) - float(np.std([1, 2, 6], ddof=1))) < 1e-12
    assert target_standardisation(y, mean=-1.0, scale=2.0) == (-1.0, 2.0)
    assert float(target_standardisation(torch.full((4,), 7.0, dtype=torch.float64))[1]) == 1.0


# -- loose bounds ------------------------------------------------------------------------------


def _gp_on_a_square(
    bounds: float, lengthscale: list[float] | None = None, rule: str = "spread"
) -> SparseOnlineGP:
    """A GP that knows its inputs lie in +-``bounds`` (RBF, no adaptation: the check is the
    engine's, whatever it learns)."""
    high = np.array([bounds, bounds])
    return SparseOnlineGP(
        2,
        kernel=RBFKernel(lengthscale=lengthscale),
        max_basis=16,
        input_bounds=(-high, high),
        lengthscale_rule=rule,
    )


def _feed(gp: SparseOnlineGP, points: int, batch: int = 2_000) -> None:
    """``points`` inputs uniform on the unit square [-1, 1]^2, in batches."""
    rng = np.random.default_rng(0)
    for _ in range(points // batch):
        x = rng.uniform(-1, 1, size=(batch, 2))
        gp.update(x, x.sum(axis=1))


def test_bounds_far_wider_than_the_data_are_named_once_after_enough_points() -> None:
    """Inputs on [-1, 1]^2 declared in +-100: each dimension fills 1 % of its bounds, whose
    lengthscale 200 / sqrt(12) = 57.7 exceeds the data's range 2. Named once, at 10,000 points,
    with the bounds' rule applied to the data's range (2 / sqrt(12) = 0.577)."""
    gp = _gp_on_a_square(100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _feed(gp, COVERAGE_POINTS - 2_000)  # not yet: the data may still spread
    with pytest.warns(GPCriticWarning) as record:
        _feed(gp, 2_000)
    (warning,) = record
    text = str(warning.message)
    assert re.search(r"dimension 0 spans \[-(1|0\.99\d), (1|0\.99\d)\] \(1\.0% of its bounds "
                     r"\[-100, 100\]; lengthscale 57\.7\)", text)  # fmt: skip
    assert "dimension 1 spans" in text and "lengthscale=[0.577, 0.577]" in text
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _feed(gp, 4_000)  # once


def test_under_the_distance_rule_the_named_bounds_suggest_the_rules_lengthscales() -> None:
    """The same square under ``lengthscale_rule="distance"``: the bounds gave ``sqrt(2)``
    times 57.7, and the suggestion is ``sqrt(2)`` times the data's range over ``sqrt(12)``,
    0.816."""
    gp = _gp_on_a_square(100.0, rule="distance")
    expected = r"lengthscale 81\.6\).*lengthscale=\[0\.816, 0\.816\] \(1\.41 x the data's range"
    with pytest.warns(GPCriticWarning, match=expected):
        _feed(gp, COVERAGE_POINTS)


@pytest.mark.parametrize(
    ("bounds", "lengthscale"),
    [(10.0, None), (100.0, [0.5, 0.5]), (100.0, [float("nan"), 0.5])],
    ids=["data-fill-10%", "lengthscales-given", "one-given-one-barely-filled"],
)
def test_bounds_the_data_fill_or_given_lengthscales_are_not_named(
    bounds: float, lengthscale: list[float] | None
) -> None:
    """At +-10 the data fill 10 % of the bounds; a lengthscale the user gave is theirs. In the
    last case dimension 0 is named and dimension 1, given, keeps its lengthscale."""
    gp = _gp_on_a_square(bounds, lengthscale)
    if lengthscale is not None and np.isnan(lengthscale[0]):
        with pytest.warns(GPCriticWarning, match=r"dimension 0 spans.*lengthscale=\[0.577, 0.5\]"):
            _feed(gp, COVERAGE_POINTS)
        return
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _feed(gp, COVERAGE_POINTS)


def test_bounds_coverage_counts_what_it_is_given() -> None:
    """Range, count and share from :meth:`BoundsCoverage.add` against numpy on the same data."""
    rng = np.random.default_rng(1)
    x = rng.normal(size=(COVERAGE_POINTS, 4)) * np.array([0.01, 1.0, 0.01, 0.0])
    # dimension 2 of zero width (unbounded for the bounds' rule: its lengthscale from the
    # data), 3 constant in wide bounds
    low, high = np.array([-10.0, -10.0, 0.0, -10.0]), np.array([10.0, 10.0, 0.0, 10.0])
    coverage = BoundsCoverage(low, high, [True] * 4)
    np.testing.assert_array_equal(coverage.from_bounds, [True, True, False, True])
    for part in np.array_split(x, 7):
        coverage.add(torch.as_tensor(part))
    np.testing.assert_array_equal(coverage.seen_low, x.min(axis=0))
    np.testing.assert_array_equal(coverage.seen_high, x.max(axis=0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no division by a zero-width bound
        message = coverage.check(torch.ones(4))
    # dimension 0: share < 5 % and lengthscale 1 > its range; 1 fills ~40 %; 2 was not from
    # the bounds; 3 does not vary (nothing to fit along it)
    assert message is not None and "dimension 0 spans" in message
    assert all(f"dimension {i}" not in message for i in (1, 2, 3))
    assert coverage.check(torch.ones(4)) is None  # once


def test_a_warning_points_at_a_user_file_named_like_the_package() -> None:
    """``sb3_geogp_helpers.py`` beside the package directory is the user's code, not ours: the
    warning is attributed to its line."""
    helper = str(Path(sb3_geogp.__file__).parent) + "_helpers.py"
    source = "from sb3_geogp.user_warnings import warn_user\n\ndef train():\n    warn_user('x')\n"
    namespace: dict[str, Any] = {}
    exec(compile(source, helper, "exec"), namespace)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        namespace["train"]()
    assert [(w.filename, w.lineno) for w in caught] == [(helper, 4)]
