"""The ``sb3-geogp train`` command on a tiny budget."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import torch as th
from stable_baselines3 import A2C, PPO

from sb3_geogp import GPActorCriticPolicy
from sb3_geogp.cli import build_parser, main


@pytest.fixture(autouse=True)
def _restore_threads() -> Iterator[None]:
    """The command sets torch's thread count for the whole process; undo it."""
    threads = th.get_num_threads()
    yield
    th.set_num_threads(threads)


@pytest.mark.parametrize(("algo", "critic"), [("ppo", "geodesic"), ("a2c", "rbf"), ("ppo", "mlp")])
def test_train_writes_model_logs_and_curve(algo: str, critic: str, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "run"
    argv = ["train", "--algo", algo, "--env", "CartPole-v1", "--critic", critic]
    argv += ["--timesteps", "256", "--seed", "1", "--out", str(out), "--n-envs", "2"]
    argv += ["--n-steps", "64", "--max-basis", "32", "--no-progress"]
    assert main(argv) == 0
    assert (out / "model.zip").is_file()
    assert (out / "progress.csv").is_file()
    assert (out / "learning_curve.png").stat().st_size > 0
    model = {"ppo": PPO, "a2c": A2C}[algo].load(out / "model.zip")
    assert isinstance(model.policy, GPActorCriticPolicy) == (critic != "mlp")
    if algo == "ppo" and critic != "mlp":  # A2C logs every 100 rollouts only
        assert "gp/n_basis" in (out / "progress.csv").read_text().splitlines()[0]
    if critic != "mlp":  # default forgetting: 0.9 with A2C (docs/results.md), 1.0 with PPO
        assert model.policy.gp.forgetting == (0.9 if algo == "a2c" else 1.0)


def test_parser_rejects_unknown_critic() -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["train", "--critic", "cnn"])


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    import sb3_geogp

    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"sb3-geogp {sb3_geogp.__version__}"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--env", "NoSuchEnv-v0"], "unknown environment 'NoSuchEnv-v0'"),
        (["--max-basis", "0"], "--max-basis must be at least 1, got 0"),
        (["--timesteps", "0"], "--timesteps must be at least 1"),
        (["--forgetting", "1.5"], "--forgetting must be in (0, 1]"),
    ],
)
def test_user_errors_are_one_line_with_exit_status_2(
    extra: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["train", "--out", str(tmp_path / "run"), "--no-progress", *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert not (tmp_path / "run").exists()  # refused before any work


def test_existing_out_with_other_settings_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "train_settings.json").write_text('{"algo": "a2c"}')
    assert main(["train", "--out", str(out), "--no-progress"]) == 2
    assert "holds a run made with other settings" in capsys.readouterr().err


def test_help_shows_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    assert "(default: 256)" in capsys.readouterr().out
