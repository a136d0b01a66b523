"""The ``sb3-geogp compare`` options: sweep settings, GP options, an environment and
hyperparameters of the user's own, and every mistake stopped before any run."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from stable_baselines3 import A2C, PPO

from sb3_geogp.adaptation import CHEAP_ADAPTATION, as_adaptation
from sb3_geogp.cli import main
from sb3_geogp.comparison.command import (
    UsageError,
    add_arguments,
    config_from_args,
    parse_gp_option,
)
from sb3_geogp.comparison.hyperparams import GP_KWARGS
from sb3_geogp.comparison.report import write_report
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.policies import default_adaptation
from sb3_geogp.toolbox.provenance import cpu

MODULE = "tests.comparison.toy_env"
TOY = f"{MODULE}:ToyEnv-v0"  # no reward_threshold
WARNS = f"{MODULE}:ToyEnvWarns-v0"  # reward_threshold -2, warns when made
#: rl-baselines3-zoo's ppo.yml format, policy_kwargs as the zoo writes it (a string).
PPO_YML = """\
ToyEnv-v0: &toy
  n_envs: 2
  n_timesteps: !!float 256
  policy: 'MlpPolicy'
  n_steps: 16
  batch_size: 32
  gamma: 0.9
  learning_rate: lin_1e-3
  clip_range: 0.2
  normalize: true
  policy_kwargs: "dict(ortho_init=False, activation_fn=nn.ReLU,
                       net_arch=dict(pi=[16], vf=[16]))"
ToyEnvWarns-v0: *toy
"""


@pytest.fixture(autouse=True)
def _tests_importable(monkeypatch: pytest.MonkeyPatch) -> None:
    """``tests.comparison.toy_env`` importable however pytest was started (spawned workers
    inherit ``sys.path``)."""
    monkeypatch.syspath_prepend(str(Path(__file__).parents[2]))


def _parse(*argv: str) -> argparse.Namespace:
    return add_arguments(argparse.ArgumentParser()).parse_args(argv)


def test_cli_arguments() -> None:
    config = config_from_args(_parse("--quick", "--seeds", "3", "--timesteps-scale", "0.5"))
    assert config.seeds == (0, 1, 2) and config.timesteps_scale == 0.5
    assert config.n_eval_episodes == SweepConfig.quick().n_eval_episodes
    config = config_from_args(_parse("--envs", "CartPole-v1", "--algos", "ppo", "--critics", "mlp"))
    assert config.envs == ("CartPole-v1",) and config.seeds == (0, 1, 2, 3, 4)
    assert len(config.specs()) == 5
    config = config_from_args(_parse("--seeds", "3", "--first-seed", "10"))
    assert config.seeds == (10, 11, 12)
    assert config_from_args(_parse("--quick", "--first-seed", "7")).seeds == (7, 8)


def test_kernel_options_are_checked_against_the_kernels_named() -> None:
    """``--gp-option kernel_kwargs=...`` reaches the runs of a kernel that takes it (the Matérn
    kernel's ``nu``), and is refused, naming the kernel, where another named kernel does not
    take it, or where no GP critic is named."""
    argv = ("--envs", "CartPole-v1", "--algos", "ppo", "--gp-option", 'kernel_kwargs={"nu": 1.5}')
    specs = config_from_args(_parse(*argv, "--critics", "mlp", "matern")).specs()
    gp = [s for s in specs if s.critic == "matern"]
    assert gp and all(dict(s.gp_kwargs)["kernel_kwargs"] == {"nu": 1.5} for s in gp)
    with pytest.raises(UsageError, match="unknown option 'nu' of kernel 'rbf'"):
        config_from_args(_parse(*argv, "--critics", "matern", "rbf"))
    with pytest.raises(UsageError, match="--critics names none"):
        config_from_args(_parse(*argv, "--critics", "mlp"))


def test_gp_actor_normalize_reaches_the_gp_runs_of_entries_that_normalise() -> None:
    specs = config_from_args(_parse("--gp-actor-normalize")).specs()
    default = config_from_args(_parse()).specs()
    assert [s.run_id for s in specs] == [s.run_id for s in default]
    normalised = {(s.algo, s.env_id) for s in specs if s.actor_normalize}
    assert all(s.critic != "mlp" and not s.normalize for s in specs if s.actor_normalize)
    # A2C's PaperPendulum takes the zoo's Pendulum-v1 entry, which normalises.
    pendulums = {"Pendulum-v1", "sb3_geogp/PaperPendulum-v0"}
    expected = {("ppo", e) for e in ("MountainCarContinuous-v0", "Acrobot-v1")}
    expected |= {("a2c", e) for e in (*pendulums, "MountainCarContinuous-v0", "Acrobot-v1")}
    assert normalised == expected
    # With --mlp-normalize too, each critic gets the zoo's normalisation in its own form.
    both = config_from_args(_parse("--gp-actor-normalize", "--mlp-normalize")).specs()
    mlp = {(s.algo, s.env_id) for s in both if s.normalize}
    assert mlp == expected and all(s.critic == "mlp" for s in both if s.normalize)
    assert [s.actor_normalize for s in both] == [s.actor_normalize for s in specs]


def test_target_reaches_every_gp_run_and_keeps_the_run_ids() -> None:
    """``--target``/``--horizon`` reach every GP critic's run; unset, each algorithm's default
    (GPValueCallback's: Monte Carlo returns under PPO since 0.24, cut after 200 steps since
    0.25 where the zoo's ``gamma ** 200 >= 0.5`` since 0.26, which of these tasks only
    MountainCarContinuous-v0's 0.9999 meets; SB3's returns uncut under A2C); SB3's MLP critic's
    runs record the returns it learns, uncut, whatever is passed."""
    specs = config_from_args(_parse("--target", "monte_carlo", "--horizon", "50")).specs()
    default = config_from_args(_parse()).specs()
    assert [s.run_id for s in specs] == [s.run_id for s in default]
    assert {s.algo for s in specs} == {"ppo", "a2c"} and "mlp" in {s.critic for s in specs}
    for spec, unset in zip(specs, default, strict=True):
        if spec.critic == "mlp":
            assert (spec.target, spec.horizon) == (unset.target, unset.horizon) == ("returns", None)
        else:
            assert (spec.target, spec.horizon) == ("monte_carlo", 50)
            cut = 200 if spec.env_id == "MountainCarContinuous-v0" else None
            expected = {"ppo": ("monte_carlo", cut), "a2c": ("returns", None)}[spec.algo]
            assert (unset.target, unset.horizon) == expected
    returns = config_from_args(_parse("--target", "returns")).specs()
    assert {s.target for s in returns} == {"returns"}
    with pytest.raises(SystemExit):
        _parse("--target", "td0")
    for bad in (["--horizon", "50"], ["--target", "monte_carlo", "--horizon", "0"]):
        with pytest.raises(UsageError, match="--horizon"):
            config_from_args(_parse(*bad))


def test_feed_every_reaches_every_gp_run_and_is_recorded_only_where_set() -> None:
    """``--feed-every`` reaches the GP critics' runs and their result files' specs; SB3's MLP
    critic's runs, fed by SB3 every rollout, record 1, as do the runs made before it existed."""
    specs = config_from_args(_parse("--algos", "a2c", "--feed-every", "4")).specs()
    default = config_from_args(_parse("--algos", "a2c")).specs()
    assert [s.run_id for s in specs] == [s.run_id for s in default]
    for spec, unset in zip(specs, default, strict=True):
        assert unset.feed_every == 1 and "feed_every" not in unset.as_dict()
        expected = 1 if spec.critic == "mlp" else 4
        assert spec.feed_every == expected
        assert spec.as_dict().get("feed_every", 1) == expected
    with pytest.raises(UsageError, match="--feed-every 0: feed_every must be a positive"):
        config_from_args(_parse("--feed-every", "0"))


def test_gp_options_reach_every_gp_run_and_bad_ones_fail_early() -> None:
    specs = config_from_args(_parse("--algos", "a2c", "--gp-option", "forgetting=0.9")).specs()
    for spec in specs:
        assert dict(spec.gp_kwargs) == {**GP_KWARGS, "forgetting": 0.9}
    default = SweepConfig(algos=("a2c",)).specs()
    assert [s.run_id for s in specs] == [s.run_id for s in default]
    assert all(dict(s.gp_kwargs) == GP_KWARGS for s in default)
    args = _parse("--gp-option", "dtype=float64", "--gp-option", "forgetting=0.99")
    assert config_from_args(args).gp_options == (("dtype", "float64"), ("forgetting", 0.99))
    # JSON as well as Python literals: a dict in either spelling is a dict, not a string.
    for spelling in ('{"ard": false}', '{"ard": False}'):
        assert parse_gp_option(f"kernel_kwargs={spelling}") == ("kernel_kwargs", {"ard": False})
    # The preset as documented for the command line (docs/usage.md, adapt).
    key, settings = parse_gp_option(
        'adapt={"max_gap": 16, "settle": false, "drift_tol": 2.0, "fit_points": 256, '
        '"score_points": 256, "fold_points": 256}'
    )
    assert key == "adapt" and as_adaptation(settings) == CHEAP_ADAPTATION
    for bad, message in (
        ("forgetting=1.5", "forgetting"),  # rejected by SparseOnlineGP
        ("no_such_option=1", "no_such_option"),
        ("kernel=rbf", "--critics"),
        ("dtype=float7", "dtype"),
        ("dtype=float32", "float32"),  # the RBF critic is not safe in float32
        ("device='cpu'", "device"),  # the policy sets it
    ):
        with pytest.raises(UsageError, match=message):
            config_from_args(_parse("--gp-option", bad))
    with pytest.raises(SystemExit):  # argparse: not KEY=VALUE
        _parse("--gp-option", "forgetting")


def test_adapt_name_changes_one_setting_of_each_algorithms_adaptation() -> None:
    """``--gp-option adapt.prior_sd=None`` gives each algorithm's default adaptation
    (:func:`~sb3_geogp.policies.default_adaptation`) with that one setting changed, spelled
    out in the runs' options as a command line had to before; on top of ``adapt=...`` it
    changes those settings; a change meets no adaptation, or an unknown setting, fails early."""
    args = _parse("--algos", "ppo", "a2c", "--gp-option", "adapt.prior_sd=None")
    assert parse_gp_option("adapt.prior_sd=None") == ("adapt.prior_sd", None)
    for spec in config_from_args(args).specs():
        if spec.critic == "mlp":
            continue
        algo = {"ppo": PPO, "a2c": A2C}[spec.algo]
        expected = dataclasses.replace(default_adaptation(algo), prior_sd=None).as_dict()
        assert dict(spec.gp_kwargs)["adapt"] == expected
    args = _parse("--gp-option", 'adapt={"max_gap": 4}', "--gp-option", "adapt.window=512")
    for spec in config_from_args(args).specs():
        assert dict(spec.gp_kwargs)["adapt"] == {"max_gap": 4, "window": 512}
    for bad, message in (
        (("adapt=False", "adapt.window=512"), "adapt=False gives none to change"),
        (("adapt.no_such_setting=1",), "no_such_setting"),
        (("adapt.window=0",), "window"),
    ):
        options = [word for option in bad for word in ("--gp-option", option)]
        with pytest.raises(UsageError, match=message):
            config_from_args(_parse(*options))
    for malformed in ("adapt.=1", "adapt.1x=1", "adapt.a.b=1"):
        with pytest.raises(SystemExit):
            _parse("--gp-option", malformed)


def test_budget_and_threshold_of_an_own_environment(tmp_path: Path) -> None:
    yml = tmp_path / "ppo.yml"
    yml.write_text(PPO_YML)
    own = ("--envs", WARNS, "--hyperparams", f"ppo={yml}", "--critics", "mlp")
    specs = config_from_args(_parse(*own)).specs()
    # --algos defaults to the file's; budget: its n_timesteps; threshold: reward_threshold.
    assert [s.algo for s in specs] == ["ppo"] * 5
    assert {(s.total_timesteps, s.threshold, s.hyperparams["n_steps"]) for s in specs} == {
        (256, -2.0, 16)
    }
    assert specs[0].run_id == "ppo__mlp__ToyEnvWarns-v0__s0"
    for extra, budget in (
        (("--timesteps", "96"), 96),
        (("--timesteps-scale", "0.5"), 128),
        (("--quick",), 64),  # 5 % of 256, raised to two rollouts of 2 x 16 steps
        (("--quick", "--timesteps", "96"), 96),
    ):
        assert config_from_args(_parse(*own, *extra)).specs()[0].total_timesteps == budget
    # One threshold per environment; the file's entry for a built-in environment, with the
    # built-in budget where the entry has none.
    yml.write_text(PPO_YML + "CartPole-v1:\n  n_steps: 64\n")
    both = ("--envs", WARNS, "CartPole-v1", "--hyperparams", f"ppo={yml}", "--critics", "mlp")
    specs = config_from_args(_parse(*both, "--threshold", "-3", "400", "--seeds", "1")).specs()
    assert [(s.env_id, s.threshold, s.total_timesteps, s.hyperparams) for s in specs] == [
        (WARNS, -3.0, 256, specs[0].hyperparams),
        ("CartPole-v1", 400.0, 30_000, dict(n_steps=64)),
    ]
    # A2C has no file, and no built-in entry for the environment of the test.
    with pytest.raises(UsageError, match=f"no built-in a2c hyperparameters for {WARNS}"):
        config_from_args(_parse(*both, "--algos", "ppo", "a2c"))


def test_compare_on_an_environment_only_the_test_knows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The real command on ``module:EnvId`` in 2 spawned workers, with a zoo yaml file, a
    threshold of its own, and a warning that every run raises shown once."""
    from tests.comparison.toy_env import WARNING

    yml = tmp_path / "ppo.yml"
    yml.write_text(PPO_YML)
    out = tmp_path / "out"
    argv = ["compare", "--envs", WARNS, "--hyperparams", f"ppo={yml}", "--threshold", "-3"]
    argv += ["--critics", "mlp", "geodesic", "--seeds", "1", "--workers", "2", "--out", str(out)]
    assert main([*argv, "--no-progress", "--no-plots"]) == 0
    assert capsys.readouterr().err.count(WARNING) == 1
    runs = sorted((out / "runs").glob("*.json"))
    assert [p.name for p in runs] == [
        "ppo__geodesic__ToyEnvWarns-v0__s0.json",
        "ppo__mlp__ToyEnvWarns-v0__s0.json",
    ]
    for path in runs:
        r = json.loads(path.read_text())
        assert r["spec"]["env_id"] == WARNS and r["num_timesteps"] == 256  # n_timesteps
        assert r["hyperparams"]["source"] == str(yml)
        assert r["hyperparams"]["values"]["n_steps"] == 16
        assert r["critic_accuracy"]["gamma"] == 0.9  # the file's gamma trained the model
        assert r["threshold"] == -3.0 and f"UserWarning: {WARNING}" in r["warnings"]
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(sys.modules, "matplotlib", None)  # the tables only, in a blink
        write_report(out)
    summary = json.loads((out / "report" / "summary.json").read_text())
    assert [row["threshold"] for row in summary] == [-3.0, -3.0]
    assert "≥ -3" in (out / "report" / "summary.md").read_text()
    # Another threshold into the same folder would mix two sweeps.
    argv[argv.index("-3")] = "-4"
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "other threshold than requested (-3.0 there, -4.0 now)" in err


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_an_interrupted_sweep_says_so_and_the_same_command_resumes_it(
    how: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Ctrl-C, or a SIGTERM sent to the process, during the second of two runs (one worker, in
    this process): exit status 130, one line naming the runs kept, the first run's file; the
    same command runs only the second. SIGTERM's handler is the caller's again after."""
    import sb3_geogp.comparison.sweep as sweep

    yml = tmp_path / "ppo.yml"
    yml.write_text(PPO_YML)
    out = tmp_path / "out"
    argv = ["compare", "--envs", TOY, "--hyperparams", f"ppo={yml}", "--threshold", "-3"]
    argv += ["--critics", "mlp", "rbf", "--seeds", "1", "--workers", "1", "--out", str(out)]
    argv += ["--no-progress", "--no-plots"]
    real, calls = sweep.run_one, []

    def interrupted_second(spec: RunSpec, out_dir: str | Path) -> dict[str, Any]:
        calls.append(spec.run_id)
        if len(calls) == 2:
            if how == "sigterm":
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(2.0)  # the command's handler interrupts the sleep
                pytest.fail("SIGTERM did not interrupt the sweep")
            raise KeyboardInterrupt
        return real(spec, out_dir)

    def ignore(signum: int, frame: Any) -> None:
        """The caller's handler: one that does not end the test session."""

    monkeypatch.setattr(sweep, "run_one", interrupted_second)
    previous = signal.signal(signal.SIGTERM, ignore)
    try:
        assert main(argv) == 130
        assert signal.getsignal(signal.SIGTERM) is ignore
    finally:
        signal.signal(signal.SIGTERM, previous)
    err = capsys.readouterr().err
    assert f"interrupted; the finished runs are in {out / 'runs'}" in err
    assert [p.stem for p in (out / "runs").glob("*.json")] == [calls[0]]
    monkeypatch.setattr(sweep, "run_one", real)
    assert main(argv) == 0
    assert "ran 1 runs, 1 were already done" in capsys.readouterr().out
    assert sorted(p.stem for p in (out / "runs").glob("*.json")) == sorted(calls)
    # against a baseline (here itself) the command names both sweeps' CPU models
    again = [a for a in argv if a != "--no-plots"] + ["--baseline", str(out)]
    assert main(again) == 0
    here = cpu()["cpu_model"] or "unrecorded"  # both made here
    assert f"CPU models: this sweep {here}; baseline {here}.\n" in capsys.readouterr().out


def test_mistakes_end_in_one_line_and_status_2_before_any_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = tmp_path / "ppo.yml"
    good.write_text(PPO_YML)

    def yml(name: str, text: str) -> str:
        (tmp_path / name).write_text(text)
        return f"ppo={tmp_path / name}"

    own = ("--envs", TOY, "--threshold", "-3")
    for argv, message in (
        (("--envs", "NoSuchEnv-v0"), "unknown environment 'NoSuchEnv-v0'"),
        (
            ("--envs", "no_such_module:Foo-v0"),
            "cannot import its module (No module named 'no_such_module')",
        ),
        (("--envs", f"{MODULE}:ToyEnvEndless-v0"), "has no time limit: register it with"),
        (own, f"no built-in ppo hyperparameters for {TOY}"),
        ((*own, "--hyperparams", "ppo.yml"), "--hyperparams takes ALGO=FILE"),
        ((*own, "--hyperparams", f"ppo={tmp_path / 'missing.yml'}"), "cannot read"),
        ((*own, "--hyperparams", yml("bad.yml", "ToyEnv-v0: [\n")), "is not valid YAML"),
        ((*own, "--hyperparams", yml("other.yml", "Other-v0: {}\n")), "has no entry"),
        ((*own, "--hyperparams", yml("k.yml", "ToyEnv-v0: {n_step: 8}\n")), "key 'n_step'"),
        ((*own, "--hyperparams", yml("w.yml", "ToyEnv-v0: {frame_stack: 4}\n")), "frame_stack"),
        ((*own, "--hyperparams", yml("t.yml", "ToyEnv-v0: {}\n")), "no budget for ppo on"),
        (
            (
                *own,
                "--hyperparams",
                yml("p.yml", "ToyEnv-v0: {n_timesteps: 64, policy_kwargs: 'dict(a=1)'}\n"),
            ),
            "the mlp critic on tests.comparison.toy_env:ToyEnv-v0 fails to build: TypeError",
        ),
        (("--envs", TOY, "--hyperparams", f"ppo={good}"), "pass --threshold X"),
        (("--threshold", "1", "2"), "--threshold takes one value per environment (7:"),
        (("--algos", "a2c", "--hyperparams", f"ppo={good}"), "ppo is not among --algos"),
        (("--first-seed", "-1"), "--first-seed must be at least 0, got -1"),
        (("--timesteps", "9", "--timesteps-scale", "2"), "drop --timesteps-scale"),
        (("--gp-option", "forgetting=1.5"), "--gp-option: the GP critic rejects"),
        (("--gp-option", "noise_var=abc"), "noise_var must be a number, got 'abc' (str)"),
        (("--envs", "CartPole-v1", "--threshold", "nan"), "--threshold takes finite returns"),
        (("--envs", "CartPole-v1", "--threshold", "inf"), "--threshold takes finite returns"),
        (("--first-seed", str(2**32 - 1), "--seeds", "2"), "goes past SB3's largest seed"),
        (("--envs", "CartPole-v1", "Pendulum-v1", "CartPole-v1"), "names CartPole-v1 twice"),
        (("--critics", "mlp", "mlp"), "--critics names mlp twice"),
        (("--baseline", str(tmp_path / "nowhere")), "no run files in its runs/ folder"),
        (("--gp-normalize", "--gp-actor-normalize"), "alone: choose one"),
    ):
        out = tmp_path / "out"
        assert main(["compare", "--out", str(out), *argv]) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("sb3-geogp compare: error: ") and err.count("\n") == 1, err
        assert message in err, (message, err)
        assert not out.exists()


def test_an_out_that_is_a_file_or_cannot_be_made_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    afile = tmp_path / "afile"
    afile.write_text("mine")
    argv = ["compare", "--envs", "CartPole-v1", "--algos", "ppo", "--critics", "mlp"]
    for out, message in (
        (afile, "is a file, not a directory"),
        (afile / "sub", "cannot be created (Not a directory)"),
    ):
        assert main([*argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert afile.read_text() == "mine"


def _stat(pid: int) -> tuple[str, int] | None:
    """State letter and parent pid of process ``pid`` from ``/proc``; ``None`` if it is gone."""
    try:
        fields = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return fields[0], int(fields[1])


def _alive(pid: int) -> bool:
    stat = _stat(pid)
    return stat is not None and stat[0] != "Z"


def _running_workers(parent: int) -> list[int]:
    """Pids of the live worker processes (spawned by multiprocessing) of process ``parent``."""
    found = []
    for entry in Path("/proc").glob("[0-9]*"):
        pid = int(entry.name)
        try:
            spawned = b"spawn_main" in (entry / "cmdline").read_bytes()
        except OSError:
            continue
        stat = _stat(pid)
        if spawned and stat is not None and stat[0] != "Z" and stat[1] == parent:
            found.append(pid)
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
def test_sigterm_stops_a_sweep_and_its_workers_at_once(tmp_path: Path) -> None:
    """The command as a batch system stops it: ``sb3-geogp compare --workers 2`` in its own
    process, SIGTERM to that process alone once both workers are in their (long) runs. It ends
    with status 130 and the interrupt's line, and neither worker is left running (before, the
    command died with status 143 and its workers ran on)."""
    yml = tmp_path / "ppo.yml"
    yml.write_text(PPO_YML)
    out = tmp_path / "out"
    argv = ["compare", "--envs", TOY, "--hyperparams", f"ppo={yml}", "--threshold", "-3"]
    argv += ["--critics", "mlp", "--seeds", "2", "--workers", "2", "--timesteps", "10000000"]
    argv += ["--out", str(out), "--no-progress", "--no-plots"]
    code = "import sys; from sb3_geogp.cli import main; sys.exit(main())"
    root = Path(__file__).resolve().parents[2]
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]),
    }
    proc = subprocess.Popen(
        [sys.executable, "-c", code, *argv],
        cwd=root,
        env=env,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while len(workers := _running_workers(proc.pid)) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        assert len(workers) == 2, "the workers did not start"
        time.sleep(5.0)  # past their imports, inside their runs
        assert proc.poll() is None
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
        time.sleep(0.5)
        left = [pid for pid in workers if _alive(pid)]
        for pid in left:  # a failing command must not leave ten-million-step runs behind
            os.kill(pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert f"interrupted; the finished runs are in {out / 'runs'}" in err
    assert not left
    assert not list((out / "runs").glob("*.json"))
