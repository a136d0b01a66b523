"""The ``sb3-geogp train`` command on a tiny budget."""

from __future__ import annotations

import csv
import dataclasses
import functools
import json
import os
import re
import shutil
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3 import A2C, PPO

from sb3_geogp import (
    Adaptation,
    GPActorCriticPolicy,
    GPValueCallback,
    LaplacianKernel,
    RBFKernel,
)
from sb3_geogp.cli import (
    CriticLog,
    build_parser,
    learning_curve_figure,
    main,
    read_critic_log,
    read_monitor_logs,
    reward_threshold,
)
from sb3_geogp.policies import DEFAULT_ADAPTATION
from tests.test_sparse_gp import assert_same_state


@pytest.fixture(autouse=True)
def _restore_threads() -> Iterator[None]:
    """The command sets torch's thread count for the whole process; undo it."""
    threads = th.get_num_threads()
    yield
    th.set_num_threads(threads)


def test_train_no_adapt_gives_the_fixed_critic(tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = ["train", "--algo", "a2c", "--env", "CartPole-v1", "--critic", "rbf", "--no-adapt"]
    argv += ["--timesteps", "64", "--out", str(out), "--n-envs", "2", "--no-progress"]
    assert main(argv) == 0
    gp = A2C.load(out / "model.zip").policy.gp
    assert gp.adaptation is None
    assert gp.forgetting == 0.9  # A2C without adaptation needs forgetting (docs/results.md)


@pytest.mark.parametrize(
    ("algo", "critic"),
    [("ppo", None), ("a2c", None), ("a2c", "rbf"), ("ppo", "mlp"), ("a2c", "mlp")],
)
def test_train_writes_model_logs_and_curve(
    algo: str, critic: str | None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plt = pytest.importorskip("matplotlib.pyplot")
    out = tmp_path / "run"
    argv = ["train", "--algo", algo, "--env", "CartPole-v1"]
    argv += [] if critic is None else ["--critic", critic]
    argv += ["--timesteps", "256", "--seed", "1", "--out", str(out), "--n-envs", "2"]
    argv += ["--n-steps", "64", "--no-progress"]
    argv += [] if critic == "mlp" else ["--max-basis", "32"]  # a GP option: refused with mlp
    assert main(argv) == 0
    assert (out / "model.zip").is_file()
    assert (out / "learning_curve.png").stat().st_size > 0
    model = {"ppo": PPO, "a2c": A2C}[algo].load(out / "model.zip")
    gp = critic != "mlp"
    assert isinstance(model.policy, GPActorCriticPolicy) == gp
    if gp:  # the options the drop-in resolves for the same algorithm, kernel and capacity
        kernel_option = {} if critic is None else {"kernel": critic}
        gp_kwargs = dict(max_basis=32, **kernel_option)
        drop_in = type(model)(
            GPActorCriticPolicy, "CartPole-v1", policy_kwargs=dict(gp_kwargs=gp_kwargs)
        )
        # With the defaults written out, as SB3's save stores them.
        saved_options = model.policy._get_constructor_parameters()["gp_kwargs"]
        assert saved_options == drop_in.policy._get_constructor_parameters()["gp_kwargs"]
        adaptation = {"ppo": DEFAULT_ADAPTATION, "a2c": Adaptation(max_gap=16, settle=False)}[algo]
        assert model.policy.gp.adaptation == adaptation
    if critic is None:  # the policy's default kernel for the algorithm
        kernel = {"ppo": LaplacianKernel, "a2c": RBFKernel}[algo]
        assert isinstance(model.policy.gp.kernel, kernel)

    # Every rollout (256 steps of 2 x 64) is in progress.csv; the terminal keeps SB3's pace.
    header = (out / "progress.csv").read_text().splitlines()[0].split(",")
    ev_key = "gp/explained_variance" if gp else "train/explained_variance"
    assert ev_key in header and ("gp/n_basis" in header) == gp
    assert capsys.readouterr().out.count("total_timesteps") == (2 if algo == "ppo" else 0)
    log = read_critic_log(out / "progress.csv")
    assert log is not None
    # An MLP's explained variance is logged with the next rollout: the last one is never.
    np.testing.assert_array_equal(log.timesteps, [128, 256] if gp else [128])
    assert np.all(np.isfinite(log.explained_variance)) and np.all(log.explained_variance <= 1)
    assert (log.n_basis is not None) == gp

    steps, returns = read_monitor_logs(out / "monitor")
    fig = learning_curve_figure(steps, returns, log, reward_threshold("CartPole-v1"))
    returns_ax, ev_ax, *twin = fig.axes
    assert returns_ax.get_ylabel() == "episode return" and ev_ax.get_xlabel() == "timesteps"
    assert ev_ax.get_ylabel() == "explained variance\n(out of sample)"
    assert [ax.get_ylabel() for ax in twin] == (["basis vectors (GP)"] if gp else [])
    (line,) = [ln for ln in returns_ax.get_lines() if ln.get_label().startswith("threshold")]
    assert set(line.get_ydata()) == {gym.spec("CartPole-v1").reward_threshold}
    plt.close(fig)


def test_read_critic_log_pairs_the_mlp_explained_variance_with_its_rollout(
    tmp_path: Path,
) -> None:
    # SB3 writes a row before train(), so train/ values describe the rollout of the row before.
    progress = tmp_path / "progress.csv"
    progress.write_text("time/total_timesteps,train/explained_variance\n100,\n200,0.25\n300,0.5\n")
    log = read_critic_log(progress)
    assert log is not None and log.n_basis is None
    np.testing.assert_array_equal(log.timesteps, [100, 200])
    np.testing.assert_array_equal(log.explained_variance, [0.25, 0.5])
    progress.write_text("time/total_timesteps,train/explained_variance\n")
    assert read_critic_log(progress) is None
    assert read_critic_log(tmp_path / "missing.csv") is None


def test_reward_threshold_is_the_comparison_level_else_none() -> None:
    assert reward_threshold("CartPole-v1") == 475.0 == gym.spec("CartPole-v1").reward_threshold
    assert gym.spec("Pendulum-v1").reward_threshold is None
    assert reward_threshold("Pendulum-v1") == -200.0  # the comparison's own
    assert gym.spec("Blackjack-v1").reward_threshold is None
    assert reward_threshold("Blackjack-v1") is None


def test_learning_curve_without_critic_log_threshold_or_episodes() -> None:
    plt = pytest.importorskip("matplotlib.pyplot")
    fig = learning_curve_figure(np.array([10, 20, 30]), np.array([1.0, 2.0, 3.0]))
    (ax,) = fig.axes
    assert ax.get_xlabel() == "timesteps"
    assert not [ln for ln in ax.get_lines() if ln.get_label().startswith("threshold")]
    plt.close(fig)
    log = CriticLog(np.array([64.0, 128.0]), np.array([np.nan, -3.0]), None)
    fig = learning_curve_figure(np.empty(0), np.empty(0), log)
    returns_ax, ev_ax = fig.axes
    assert [t.get_text() for t in returns_ax.texts] == ["no episode finished yet"]
    assert "1 below −1, off scale" in ev_ax.get_legend_handles_labels()[1][0]
    plt.close(fig)


def test_learning_curve_draws_the_basis_of_the_fed_rollouts_only() -> None:
    """With ``feed_every > 1`` the rollouts in between log no ``gp/n_basis``: the step line
    joins the fed ones instead of breaking into pieces at each gap."""
    plt = pytest.importorskip("matplotlib.pyplot")
    steps = np.array([40.0, 80.0, 120.0, 160.0])
    log = CriticLog(steps, np.array([np.nan, 0.5, np.nan, 0.7]), np.array([np.nan, 9, np.nan, 12]))
    fig = learning_curve_figure(np.array([10, 20]), np.array([1.0, 2.0]), log)
    (basis,) = fig.axes[-1].get_lines()
    np.testing.assert_array_equal(basis.get_xdata(), [80.0, 160.0])
    np.testing.assert_array_equal(basis.get_ydata(), [9, 12])
    plt.close(fig)


def test_learning_curve_marks_the_basis_of_a_lone_fed_rollout() -> None:
    """A step line through one point has no length: a marker shows it (and only then)."""
    plt = pytest.importorskip("matplotlib.pyplot")
    for n_basis, marker in (([np.nan, 9.0], "."), ([8.0, 9.0], "None")):
        log = CriticLog(np.array([40.0, 80.0]), np.array([0.5, 0.6]), np.array(n_basis))
        fig = learning_curve_figure(np.array([10, 20]), np.array([1.0, 2.0]), log)
        (basis,) = fig.axes[-1].get_lines()
        assert basis.get_marker() == marker
        plt.close(fig)


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
        (["--forgetting", "1.5"], "--forgetting must be in (0, 1]"),
        (["--device", "gpu0"], "--device 'gpu0' is not a torch device"),
        (
            ["--horizon", "5"],
            "target='monte_carlo' passed explicitly; got horizon=5 with target=None",
        ),
        (["--target", "returns", "--horizon", "5"], "got horizon=5 with target='returns'"),
        (["--target", "monte_carlo", "--horizon", "0"], "horizon=0 with target='monte_carlo'"),
        (["--critic", "mlp", "--target", "monte_carlo"], "SB3's MLP critic learns SB3's returns"),
        (["--critic", "mlp", "--horizon", "5"], "Drop them, or pass a GP --critic"),
        (["--critic", "mlp", "--feed-every", "4"], "learns SB3's returns every rollout"),
        (["--feed-every", "0"], "feed_every must be a positive integer, got 0"),
        (["--save-every", "-1"], "--save-every must be at least 0"),
        (["--critic", "mlp", "--max-basis", "10"], "--max-basis configures the GP critic"),
        (["--critic", "mlp", "--no-adapt"], "--no-adapt configures the GP critic"),
        (
            ["--critic", "mlp", "--normalize-actor-obs"],
            "--normalize-actor-obs configures the GP critic",
        ),
        (
            ["--critic", "mlp", "--lengthscale-rule", "distance"],
            "--lengthscale-rule configures the GP critic",
        ),
        (
            ["--critic", "mlp", "--gp-option", "trend=linear"],
            "--gp-option configures the GP critic",
        ),
        (["--gp-option", "max_basis=10"], "--gp-option max_basis=...: pass --max-basis instead"),
        (["--gp-option", "adapt=False"], "--gp-option adapt=...: pass --adapt / --no-adapt"),
        (
            ["--no-adapt", "--gp-option", "adapt.prior_sd=None"],
            "adapt.prior_sd=... changes a setting of the adaptation, and adapt=False gives none",
        ),
        # Refused by the policy as the model is built.
        (["--gp-option", "trend=slanted"], "fails to build: ValueError: trend must be one of"),
        (["--env", "Blackjack-v1"], "Blackjack-v1: the GP critic supports Box observations"),
        (["--seed", "-1"], "--seed must be in [0, 2**32), got -1"),
        (["--seed", str(2**32)], "--seed must be in [0, 2**32)"),
        (["--n-steps", "1", "--n-envs", "1"], "PPO needs rollouts of at least 2 steps"),
        # Refused by the policy as the model is built, a check of its own.
        (
            ["--env", "FrozenLake-v1", "--normalize-actor-obs"],
            "ppo with the laplacian critic on FrozenLake-v1 fails to build: ValueError: "
            "normalize_actor_obs normalises Box observations",
        ),
        (["--max-basis", "100000000"], "choose a smaller max_basis"),
        pytest.param(
            ["--device", "cuda"],
            "torch sees no CUDA device here; use --device cpu",
            marks=pytest.mark.skipif(th.cuda.is_available(), reason="this machine has CUDA"),
        ),
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


@pytest.mark.parametrize(
    "argv",
    [
        ["train", "--max-basis", "0"],
        ["train", "--timesteps", "0"],
        ["train", "--n-envs", "-2"],
        ["train", "--n-steps", "0"],
        ["train", "--threads", "0"],
        ["compare", "--timesteps", "0"],
        ["compare", "--seeds", "0"],
        ["compare", "--workers", "0"],
    ],
)
def test_counts_below_one_are_refused_by_the_parser_as_in_the_example_scripts(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every count is read by the scripts' ``count_arg``, and refused in one line naming the
    option, exit status 2, nothing written."""
    command, option, value = argv
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--out", str(tmp_path / "run"), option, value])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err == (
        f"sb3-geogp {command}: error: argument {option}: must be at least 1, got {value}; "
        f"see sb3-geogp {command} --help\n"
    )
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["train", "--max-basis", "many"], "argument --max-basis: expected an integer, got 'many'"),
        (["train", "--algo", "sac"], "argument --algo: invalid choice: 'sac'"),
        (["compare", "--quick", "--nosuch"], "unrecognized arguments: --nosuch"),
        ([], "the following arguments are required: command"),
    ],
)
def test_what_argparse_refuses_also_ends_in_one_line(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and err.rstrip().endswith("--help"), err


def test_an_out_that_is_a_file_or_holds_unreadable_settings_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """One line, exit status 2, the files and folders as they were (a model.zip without the
    settings train writes is not a finished run of this command)."""
    afile, broken, foreign = tmp_path / "afile", tmp_path / "broken", tmp_path / "foreign"
    afile.write_text("mine")
    broken.mkdir()
    (broken / "train_settings.json").write_text("{not json")
    foreign.mkdir()
    (foreign / "model.zip").write_text("someone else's")
    for out, message in (
        (afile, "is a file, not a directory"),
        (broken, "cannot be read"),
        (foreign, "holds a model.zip that sb3-geogp train did not write"),
    ):
        assert main(["train", "--out", str(out), "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err
    assert afile.read_text() == "mine" and [p.name for p in broken.iterdir()] == [
        "train_settings.json"
    ]
    assert [p.name for p in foreign.iterdir()] == ["model.zip"]


class ImageObs(gym.Env[np.ndarray, int]):
    """Image observations (which the GP critic refuses and SB3's MlpPolicy takes), 8 steps."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"]}
    observation_space = gym.spaces.Box(0, 255, shape=(36, 36, 3), dtype=np.uint8)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, render_mode: str | None = None) -> None:
        self.render_mode = render_mode

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        super().reset(seed=seed)
        self.t = 0
        return self.observation_space.sample(), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self.t += 1
        return self.observation_space.sample(), float(action), self.t >= 8, False, {}


gym.register("ImageObs-v0", entry_point=ImageObs)


def test_an_env_the_gp_critic_refuses_leaves_the_directory_free_for_the_mlp_critic(
    tmp_path: Path,
) -> None:
    """Refused before anything is written, so the same --out trains SB3's MLP critic next."""
    argv = ["train", "--env", "ImageObs-v0", "--out", str(tmp_path / "run"), "--no-progress"]
    assert main(argv) == 2
    tiny = ["--timesteps", "8", "--n-envs", "1", "--n-steps", "8"]
    assert main([*argv, "--critic", "mlp", *tiny]) == 0
    assert (tmp_path / "run" / "model.zip").is_file()


def test_train_asks_sb3_for_whole_rollouts(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """SB3 trains whole rollouts whatever it is asked; asked for them, its progress bar's total
    is the number of steps it runs (2 envs x 64 steps: 200 -> 256)."""
    asked: list[int] = []
    learn = PPO.learn

    @functools.wraps(learn)  # the CLI reads learn's defaults from its signature
    def recording(self: PPO, total_timesteps: int, **kwargs: Any) -> PPO:
        asked.append(total_timesteps)
        return learn(self, total_timesteps, **kwargs)

    monkeypatch.setattr(PPO, "learn", recording)
    argv = ["train", "--env", "CartPole-v1", "--timesteps", "200", "--n-envs", "2"]
    argv += ["--n-steps", "64", "--critic", "mlp", "--out", str(tmp_path / "run"), "--no-progress"]
    assert main(argv) == 0
    assert asked == [256]
    assert PPO.load(tmp_path / "run" / "model.zip").num_timesteps == 256


def test_train_feeds_the_cut_monte_carlo_targets(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sb3_geogp.cli as cli

    made: list[GPValueCallback] = []

    class Recorded(GPValueCallback):
        def __init__(self, **kwargs: Any) -> None:
            super().__init__(**kwargs)
            made.append(self)

    monkeypatch.setattr(cli, "GPValueCallback", Recorded)
    out = tmp_path / "run"
    argv = ["train", "--algo", "a2c", "--env", "CartPole-v1", "--target", "monte_carlo"]
    argv += ["--horizon", "7", "--feed-every", "2", "--timesteps", "64", "--out", str(out)]
    assert main([*argv, "--no-progress"]) == 0
    fed = [c for c in made if c.num_timesteps > 0]  # the check's own instance never trains
    assert [(c.target, c.horizon, c.feed_every) for c in fed] == [("monte_carlo", 7, 2)]
    settings = json.loads((out / "train_settings.json").read_text())
    assert (settings["target"], settings["horizon"], settings["feed_every"]) == (
        "monte_carlo",
        7,
        2,
    )


class InterruptAt(gym.Wrapper):
    """CartPole-v1 that stops the process at the ``at``-th step of all its instances together:
    by Ctrl-C's ``KeyboardInterrupt``, a SIGTERM sent to itself, or a crash (an error the
    command does not handle, as a hard kill leaves no chance to save)."""

    at: int | None = None
    how = "ctrl-c"
    steps = 0

    def __init__(self) -> None:
        super().__init__(gym.make("CartPole-v1"))

    def step(self, action: Any) -> Any:
        InterruptAt.steps += 1
        if InterruptAt.steps == InterruptAt.at:
            if InterruptAt.how == "sigterm":
                os.kill(os.getpid(), signal.SIGTERM)
            elif InterruptAt.how == "crash":
                raise RuntimeError("crash")
            else:
                raise KeyboardInterrupt
        return self.env.step(action)


gym.register("InterruptAt-v0", entry_point=InterruptAt)


def _policy_state(path: Path) -> dict[str, Any]:
    return PPO.load(path).policy.state_dict()


def _assert_same_state(a: dict[str, Any], b: dict[str, Any]) -> None:
    assert a.keys() == b.keys()
    for name, value in a.items():
        assert th.equal(b[name], value) if isinstance(value, th.Tensor) else b[name] == value, name


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_interrupted_train_saves_its_checkpoint_and_the_same_command_resumes(
    how: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Interrupted in its third rollout (2 envs x 64 steps each), the run's checkpoint holds
    the policy of a run trained for two rollouts, bit for bit, and its step count (the cut
    rollout dropped); the same command resumes it to the budget, twice alike, with one
    progress.csv over both parts (a row logged after the checkpoint dropped); once finished,
    the command leaves the run as it is."""
    argv = ["train", "--algo", "ppo", "--env", "InterruptAt-v0", "--n-envs", "2"]
    argv += ["--n-steps", "64", "--max-basis", "32", "--seed", "3", "--no-progress"]
    out = tmp_path / "run"
    handler = signal.getsignal(signal.SIGTERM)
    InterruptAt.at, InterruptAt.how, InterruptAt.steps = 2 * 139, how, 0
    assert main([*argv, "--timesteps", "512", "--out", str(out)]) == 130
    assert signal.getsignal(signal.SIGTERM) == handler
    assert "run the same command to resume" in capsys.readouterr().err
    assert not (out / "model.zip").exists()
    assert PPO.load(out / "checkpoint.zip").num_timesteps == 256
    InterruptAt.at = None
    assert main([*argv, "--timesteps", "256", "--out", str(tmp_path / "two_rollouts")]) == 0
    _assert_same_state(
        _policy_state(out / "checkpoint.zip"), _policy_state(tmp_path / "two_rollouts/model.zip")
    )

    twin = tmp_path / "twin"
    shutil.copytree(out, twin)
    # As a part killed after the checkpoint would leave it: its rows are dropped on resuming.
    with (out / "progress.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    with (out / "progress.csv").open("a", newline="") as handle:
        csv.DictWriter(handle, list(rows[0])).writerow({**rows[-1], "time/total_timesteps": 300})
    for run in (out, twin):
        assert main([*argv, "--timesteps", "512", "--out", str(run)]) == 0
        assert not (run / "checkpoint.zip").exists()
        assert not (run / "progress_earlier.csv").exists()
    assert "(resumed at 256)" in capsys.readouterr().out
    model = PPO.load(out / "model.zip")
    assert model.num_timesteps == 512
    _assert_same_state(_policy_state(out / "model.zip"), _policy_state(twin / "model.zip"))
    log = read_critic_log(out / "progress.csv")
    assert log is not None
    np.testing.assert_array_equal(log.timesteps, [128, 256, 384, 512])
    assert np.isfinite(log.explained_variance).all()
    assert (out / "monitor" / "from_256").is_dir()

    saved = (out / "model.zip").read_bytes()
    assert main([*argv, "--timesteps", "512", "--out", str(out)]) == 0
    assert "trained already" in capsys.readouterr().out
    assert (out / "model.zip").read_bytes() == saved


def test_interrupted_in_ppos_update_the_actor_is_as_before_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C in the middle of the third rollout's PPO update (its 45th optimiser step of 20
    per update): the checkpoint's actor and optimiser are those of the run trained for two
    rollouts, bit for bit, and its GP critic, which learnt the third rollout before the update,
    that of the run trained for three; the third rollout's steps count."""
    argv = ["train", "--algo", "ppo", "--env", "CartPole-v1", "--n-envs", "2", "--n-steps"]
    argv += ["64", "--max-basis", "32", "--seed", "3", "--no-progress"]
    runs = {n: tmp_path / f"rollouts_{n}" for n in (2, 3)}
    for n, path in runs.items():
        assert main([*argv, "--timesteps", str(128 * n), "--out", str(path)]) == 0
    step, calls = th.optim.Adam.step, [0]

    def interrupting(self: th.optim.Adam, *args: Any, **kwargs: Any) -> Any:
        calls[0] += 1
        if calls[0] == 45:
            raise KeyboardInterrupt
        return step(self, *args, **kwargs)

    monkeypatch.setattr(th.optim.Adam, "step", interrupting)
    out = tmp_path / "run"
    assert main([*argv, "--timesteps", "512", "--out", str(out)]) == 130
    monkeypatch.setattr(th.optim.Adam, "step", step)
    saved = PPO.load(out / "checkpoint.zip")
    assert saved.num_timesteps == 384
    actors = {n: PPO.load(path / "model.zip").policy for n, path in runs.items()}
    parameters = dict(saved.policy.named_parameters())
    for name, value in actors[2].named_parameters():
        assert th.equal(parameters[name], value), name
    moments = saved.policy.optimizer.state_dict()["state"]
    expected = actors[2].optimizer.state_dict()["state"]
    assert moments.keys() == expected.keys()
    for index, state in expected.items():
        _assert_same_state(moments[index], state)
    assert_same_state(actors[3].gp.state_dict(), saved.policy.gp.state_dict())


def _episodes(monitor: Path) -> list[list[tuple[str, str]]]:
    """The (return, length) of each environment's episodes in the Monitor files of one part."""
    out = []
    for file in sorted(monitor.glob("*.monitor.csv")):
        with file.open(newline="") as handle:
            handle.readline()
            out.append([(r["r"], r["l"]) for r in csv.DictReader(handle)])
    return out


def test_after_a_crash_the_run_resumes_from_its_last_periodic_checkpoint(tmp_path: Path) -> None:
    """With ``--save-every 128`` a run that crashes in its third rollout left the checkpoint
    saved as that rollout started: the policy of the run trained for two rollouts, bit for
    bit. Resumed from it, the logs keep only what came before it: the progress rows to step 256
    and the episodes that the run trained for two rollouts played."""
    argv = ["train", "--algo", "ppo", "--env", "InterruptAt-v0", "--n-envs", "2"]
    argv += ["--n-steps", "64", "--max-basis", "32", "--seed", "3", "--no-progress"]
    out, reference = tmp_path / "run", tmp_path / "two_rollouts"
    InterruptAt.at, InterruptAt.how, InterruptAt.steps = 2 * 170, "crash", 0
    with pytest.raises(RuntimeError, match="crash"):
        main([*argv, "--timesteps", "512", "--save-every", "128", "--out", str(out)])
    InterruptAt.at = None
    assert main([*argv, "--timesteps", "256", "--out", str(reference)]) == 0
    assert PPO.load(out / "checkpoint.zip").num_timesteps == 256
    _assert_same_state(
        _policy_state(out / "checkpoint.zip"), _policy_state(reference / "model.zip")
    )
    played = sum(map(len, _episodes(out / "monitor")))
    assert played > sum(map(len, _episodes(reference / "monitor")))  # some after the checkpoint

    assert main([*argv, "--timesteps", "512", "--save-every", "128", "--out", str(out)]) == 0
    assert _episodes(out / "monitor") == _episodes(reference / "monitor")
    log = read_critic_log(out / "progress.csv")
    assert log is not None
    np.testing.assert_array_equal(log.timesteps, [128, 256, 384, 512])
    assert not (out / "checkpoint.zip").exists()


def test_a_run_seeded_at_the_largest_seed_resumes(tmp_path: Path) -> None:
    """SB3's seeds stop at 2**32 - 1, and a resumed run reseeds with its seed plus the step it
    resumes at: that wraps there instead of failing at every resume."""
    argv = ["train", "--algo", "ppo", "--env", "InterruptAt-v0", "--n-envs", "2", "--n-steps"]
    argv += ["64", "--max-basis", "32", "--seed", str(2**32 - 1), "--no-progress"]
    argv += ["--timesteps", "512", "--save-every", "128", "--out", str(tmp_path / "run")]
    InterruptAt.at, InterruptAt.how, InterruptAt.steps = 2 * 170, "crash", 0
    with pytest.raises(RuntimeError, match="crash"):
        main(argv)
    InterruptAt.at = None
    assert main(argv) == 0
    assert PPO.load(tmp_path / "run" / "model.zip").num_timesteps == 512


def test_learning_curve_marks_where_a_run_resumed() -> None:
    plt = pytest.importorskip("matplotlib.pyplot")
    log = CriticLog(np.array([100.0, 200.0]), np.array([0.5, 0.6]), None)
    fig = learning_curve_figure(
        np.array([50.0, 150.0]), np.array([1.0, 2.0]), log, resumed_at=[120]
    )
    for ax in fig.axes:
        marks = [ln for ln in ax.get_lines() if list(ln.get_xdata()) == [120, 120]]
        assert len(marks) == 1
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert labels.count("resumed") == 1
    plt.close(fig)


def test_monitor_logs_of_all_parts_are_ordered_by_absolute_time(tmp_path: Path) -> None:
    """Each Monitor file counts time from its own start (header ``t_start``): a resumed part's
    episodes, in a subfolder, come after the first part's although their ``t`` is smaller."""

    def write(path: Path, t_start: float, episodes: list[tuple[float, int, float]]) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        lines = [f'#{{"t_start": {t_start}, "env_id": "x"}}', "r,l,t"]
        lines += [f"{r},{length},{t}" for r, length, t in episodes]
        path.write_text("\n".join(lines) + "\n")

    write(tmp_path / "0.monitor.csv", 1000.0, [(1.0, 10, 5.0), (3.0, 30, 20.0)])
    write(tmp_path / "1.monitor.csv", 1001.0, [(2.0, 20, 6.0)])
    write(tmp_path / "from_60" / "0.monitor.csv", 1100.0, [(4.0, 40, 1.0)])
    steps, returns = read_monitor_logs(tmp_path)
    np.testing.assert_array_equal(returns, [1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(steps, [10, 30, 60, 100])


def test_train_normalize_actor_obs_reaches_the_policy_and_is_recorded(tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = ["train", "--algo", "a2c", "--env", "CartPole-v1", "--timesteps", "64"]
    argv += ["--n-envs", "2", "--out", str(out), "--no-progress", "--normalize-actor-obs"]
    assert main(argv) == 0
    policy = A2C.load(out / "model.zip").policy
    assert policy.normalize_actor_obs and float(policy.actor_normalizer.running_count) > 1
    assert json.loads((out / "train_settings.json").read_text())["normalize_actor_obs"] is True


def test_train_lengthscale_rule_reaches_the_critic_and_is_recorded(tmp_path: Path) -> None:
    """``--lengthscale-rule distance`` on CartPole-v1: the pole's angle, bounded in +-0.418,
    starts at ``sqrt(4)`` times a uniform's standard deviation on its bounds."""
    out = tmp_path / "run"
    argv = ["train", "--algo", "a2c", "--env", "CartPole-v1", "--timesteps", "64"]
    argv += ["--out", str(out), "--no-progress", "--lengthscale-rule", "distance"]
    assert main(argv) == 0
    gp = A2C.load(out / "model.zip").policy.gp
    space = gym.make("CartPole-v1").observation_space
    width = float(space.high[2]) - float(space.low[2])
    assert gp.lengthscale_rule == "distance"
    assert float(gp.ls_start[2]) == pytest.approx(2 * width / np.sqrt(12), rel=1e-6)
    assert json.loads((out / "train_settings.json").read_text())["lengthscale_rule"] == "distance"


def test_train_gp_options_reach_the_critic_and_are_recorded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--gp-option trend=linear --gp-option adapt.prior_sd=None``: the saved critic has the
    linear trend and PPO's default adaptation with that one setting changed; the directory
    records the options, so the same command finds its run and another is refused."""
    out = tmp_path / "run"
    argv = ["train", "--env", "CartPole-v1", "--timesteps", "32", "--n-steps", "16"]
    argv += ["--out", str(out), "--no-progress"]
    options = ["--gp-option", "trend=linear", "--gp-option", "adapt.prior_sd=None"]
    assert main([*argv, *options]) == 0
    gp = PPO.load(out / "model.zip").policy.gp
    assert gp.trend == "linear"
    assert gp.adaptation == dataclasses.replace(DEFAULT_ADAPTATION, prior_sd=None)
    recorded = json.loads((out / "train_settings.json").read_text())["gp_option"]
    assert recorded == [["trend", "linear"], ["adapt.prior_sd", None]]
    assert main([*argv, *options]) == 0
    assert "trained already" in capsys.readouterr().out
    assert main([*argv, "--gp-option", "trend=level"]) == 2
    assert "holds a run made with other settings" in capsys.readouterr().err


def test_unset_horizon_keeps_older_run_directories_valid(tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = ["train", "--algo", "a2c", "--env", "CartPole-v1", "--timesteps", "64"]
    argv += ["--out", str(out), "--no-progress"]
    assert main(argv) == 0
    settings = json.loads((out / "train_settings.json").read_text())
    # As 0.20 wrote it, so re-running there is accepted.
    added = {"horizon", "feed_every", "normalize_actor_obs", "lengthscale_rule", "gp_option"}
    assert not added & set(settings)
    assert main(argv) == 0


@pytest.mark.parametrize(
    ("extra", "target", "horizon"),
    [(["--algo", "ppo"], "monte_carlo", None), (["--algo", "a2c"], "returns", None),
     (["--algo", "ppo", "--critic", "mlp"], "returns", None),
     (["--algo", "ppo", "--target", "returns"], "returns", None),
     (["--algo", "ppo", "--target", "monte_carlo"], "monte_carlo", None)],
)  # fmt: skip
def test_run_directory_records_the_target_fed(
    extra: list[str],
    target: str,
    horizon: int | None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Unset, ``--target`` is the algorithm's default and recorded as such, with its horizon
    where it has one: a directory made before PPO's default moved (``"returns"``) is refused
    under PPO, kept under A2C."""
    argv = ["train", *extra, "--env", "CartPole-v1", "--timesteps", "32", "--n-steps", "16"]
    argv.append("--no-progress")
    assert main([*argv, "--out", str(tmp_path / "run")]) == 0
    settings = json.loads((tmp_path / "run" / "train_settings.json").read_text())
    assert (settings["target"], settings.get("horizon")) == (target, horizon)
    older = tmp_path / "older"
    older.mkdir()
    (older / "train_settings.json").write_text(json.dumps({**settings, "target": "returns"}))
    assert main([*argv, "--out", str(older)]) == (0 if target == "returns" else 2)
    named = f"target: 'returns' there, '{target}' now"
    assert target == "returns" or named in capsys.readouterr().err


def test_existing_out_with_other_settings_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "train_settings.json").write_text('{"algo": "a2c"}')
    assert main(["train", "--out", str(out), "--no-progress"]) == 2
    assert "holds a run made with other settings" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["train", "compare"])
def test_help_shows_each_default_once(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main([command, "--help", "--no-progress"] if command == "train" else [command, "--help"])
    text = capsys.readouterr().out
    if command == "train":
        assert "(default: 256)" in text
    # One entry per option: from a line that starts with "  -" to the next such line; the
    # options end at the first blank line (the epilog follows).
    options = text.split("options:", 1)[1].split("\n\n", 1)[0]
    entries = re.split(r"\n(?=  -)", options)
    twice = [e.split()[0] for e in entries if e.count("default:") > 1]
    assert twice == [], f"options whose help shows the default twice: {twice}"
