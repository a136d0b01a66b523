"""Smoke runs of the engine's benchmark and numerics scripts in their quickest modes."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType

import pytest

from sb3_geogp.toolbox import scripts as toolbox_scripts

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load_script(name: str) -> ModuleType:
    """Import ``examples/<name>.py`` as a module (the examples are not a package)."""
    pytest.importorskip("tqdm")
    pytest.importorskip("matplotlib")
    return toolbox_scripts.load_script(EXAMPLES / f"{name}.py", f"_example_{name}")


def test_benchmark_speed_refuses_a_warm_update_on_a_seen_rollout(
    capsys: pytest.CaptureFixture[str],
) -> None:
    bench = load_script("benchmark_speed")
    with pytest.raises(SystemExit):
        bench.main(["--quick", "--warm-rollouts", "0"])
    assert "argument --warm-rollouts: must be at least 1, got 0" in capsys.readouterr().err


def test_benchmark_speed_quick_writes_promised_json(tmp_path: Path) -> None:
    bench = load_script("benchmark_speed")
    out = tmp_path / "bench.json"
    assert bench.main(["--quick", "--out", str(out), "--threads", "1"]) == 0
    result = json.loads(out.read_text())
    assert {"meta", "rows", "peer", "targets"} <= result.keys()
    assert {"torch_version", "torch_threads", "load_average_start"} <= result["meta"].keys()
    assert result["meta"]["torch_threads"] == 1
    expected = {
        "variant", "max_basis", "update_warm_ms", "update_cold_ms", "predict_var_ms",
        "predict_mean_ms", "mse_cold", "mse_warm", "n_basis", "n_added", "n_deleted",
    }  # fmt: skip
    variants = {"rbf", "geodesic", "geodesic/nearest"}
    assert {row["variant"] for row in result["rows"]} == variants
    for row in result["rows"]:
        assert expected <= row.keys()
        assert row["n_basis"] <= row["max_basis"]
        assert row["update_warm_ms"] > 0 and row["predict_mean_ms"] > 0
    peer = result["peer"]
    assert "skipped" in peer or {"fit_ms", "predict_std_ms", "mse"} <= peer.keys()


@pytest.mark.parametrize("stream", ["pendulum", "drift", "onehot"])
def test_long_run_numerics_quick_passes_all_checks(tmp_path: Path, stream: str) -> None:
    soak = load_script("long_run_numerics")
    argv = ["--points", "1536", "--batch-size", "384", "--max-basis", "24", "--stream", stream]
    assert soak.main([*argv, "--out", str(tmp_path), "--threads", "1"]) == 0
    result = json.loads((tmp_path / "long_run_numerics.json").read_text())
    assert result["all_passed"] is True
    assert len(result["summary"]) == len(soak.VARIANTS[stream])
    for row in result["summary"]:
        assert row["passed"] and row["points"] == 1536
        assert row["n_basis"] <= 24
        # Four batches: the median is the mean of the two middle times.
        ms = sorted(result["history"][row["variant"]]["batch_ms"])
        assert len(ms) == 4 and row["median_batch_ms"] == pytest.approx((ms[1] + ms[2]) / 2)
        assert {"worst_asym_P", "worst_min_eig_P", "worst_min_var", "final_ev"} <= row.keys()
    assert (tmp_path / "long_run_numerics.png").stat().st_size > 0


def test_fixed_policy_check_refuses_a_capacity_twice_or_no_seeds(
    capsys: pytest.CaptureFixture[str],
) -> None:
    script = load_script("fixed_policy_check")
    for argv, why in (
        (["--max-basis", "10", "10"], "names a capacity twice"),
        (["--seeds", "0"], "must be at least 1"),
    ):
        with pytest.raises(SystemExit):
            script.parse_args(["--quick", *argv])
        assert why in capsys.readouterr().err


def test_fixed_policy_check_quick_checks_only_the_kernels_asked(tmp_path: Path) -> None:
    script = load_script("fixed_policy_check")
    forgetting = ["--forgetting", "0.1", "--forgetting-points", "4096"]
    argv = ["--quick", "--kernels", "geodesic", "--trend", "level", *forgetting]
    script.main([*argv, "--out", str(tmp_path)])
    result = json.loads((tmp_path / "results.json").read_text())
    assert result["config"]["kernels"] == ["geodesic"]
    assert result["config"]["trend"] == "level"
    assert (result["config"]["forgetting"], result["config"]["forgetting_points"]) == (0.1, 4096)
    assert {row["kernel"] for row in result["rows"]} == {"geodesic"}
    assert (tmp_path / "mse_ratio.png").stat().st_size > 0


@pytest.mark.parametrize("family", [42, 7])
def test_option_verdicts_caption_names_the_family_its_verdicts_hold_to(family: int) -> None:
    """The caption gives the family-wise level the rows were computed at (it said 42 whatever
    ``--family-size`` was); 42 is the published sweep's."""
    from tests.comparison.test_results import _result

    script = load_script("option_verdicts")
    variant = [_result("geodesic", s, final=10.0 + s, rmse=1.0) for s in range(5)]
    reference = [
        _result(c, s, final=float(s), rmse=2.0) for s in range(5) for c in ("geodesic", "mlp")
    ]
    rows = script.verdict_rows(variant, reference, "geodesic", family_size=family)
    text = script.markdown(rows, [], "toy")
    published = "published " if family == 42 else ""
    assert f"also at the {published}family-wise level ({family} comparisons)." in text
    assert f"({42 if family != 42 else 7} comparisons)" not in text
