"""The SB3-side example scripts, in tiny configurations (they are not otherwise run by CI)."""

from __future__ import annotations

import json
from pathlib import Path

from tests.test_examples_engine import load_script


def test_benchmark_training_runs_every_critic(tmp_path: Path) -> None:
    """A tiny run of the training benchmark (SB3 inside): every critic, adaptive ones too."""
    bench = load_script("benchmark_training")
    out = tmp_path / "bench.json"
    argv = ["--workloads", "A2C CartPole-v1", "--seeds", "0", "--scale", "0.005", "--adapt"]
    bench.main([*argv, "--max-basis", "16", "--out", str(out)])
    results = json.loads(out.read_text())["results"]["A2C CartPole-v1"]
    assert set(results) == {"mlp", "rbf", "geodesic", "rbf+adapt", "geodesic+adapt"}
    for critic, runs in results.items():
        assert runs[0]["wall"] > 0
        assert (runs[0]["update"] > 0) == (critic != "mlp")
