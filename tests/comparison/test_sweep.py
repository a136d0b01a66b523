"""The critic-comparison runner: a tiny sweep end to end, resumption, aggregation."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.utils import explained_variance
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize, sync_envs_normalization

from sb3_geogp.cli import main
from sb3_geogp.comparison import run as run_module
from sb3_geogp.comparison.evaluation import EVAL_SEED, ProbeStates, mc_horizon
from sb3_geogp.comparison.hyperparams import TIMESTEPS, HyperparamsFile
from sb3_geogp.comparison.measurement import (
    MeasureCallback,
    RolloutRecorder,
    rollout_explained_variance,
)
from sb3_geogp.comparison.report import write_report
from sb3_geogp.comparison.results import (
    comparisons,
    estimate_sweep_seconds,
    load_results,
    summary_rows,
)
from sb3_geogp.comparison.run import build_model, result_path, run_one
from sb3_geogp.comparison.specs import SweepConfig
from sb3_geogp.comparison.sweep import _record_sweep, _sweep_record, pending_runs, run_sweep
from sb3_geogp.kernels import KERNELS, GeodesicKernel
from sb3_geogp.toolbox.provenance import cpu

TINY = SweepConfig(
    algos=("a2c",),
    critics=("mlp", "geodesic"),
    envs=("CartPole-v1",),
    seeds=(0, 1),
    timesteps_scale=400 / TIMESTEPS["CartPole-v1"],  # 400 steps: 10 rollouts of 8 x 5
    n_checkpoints=2,
    n_eval_episodes=2,
    critic_every=1,
    n_probe_states=4,
    n_mc_rollouts=2,
)


def _mtimes(out: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in (out / "runs").glob("*.json")}


def test_sweep_json_records_each_sweep_run_into_the_folder_once(tmp_path: Path) -> None:
    """A file of 0.31.3 or older (one sweep) keeps its sweep first; a resumed sweep adds
    nothing, another one adds itself."""
    first = json.loads(json.dumps(_sweep_record(TINY)))
    (tmp_path / "sweep.json").write_text(json.dumps(first))
    other = dataclasses.replace(TINY, seeds=(2, 3))
    for config in (TINY, other, TINY, other):
        _record_sweep(tmp_path, config)
    recorded = json.loads((tmp_path / "sweep.json").read_text())["sweeps"]
    assert [r["config"]["seeds"] for r in recorded] == [[0, 1], [2, 3]]
    assert recorded[0] == first


def test_tiny_sweep_end_to_end_and_resume(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "sweep"
    specs = TINY.specs()
    assert len(specs) == 4

    # 1. The sweep, in 2 worker processes.
    executed = run_sweep(TINY, out, workers=2, progress=False)
    assert sorted(executed) == sorted(s.run_id for s in specs)
    for spec in specs:
        r = json.loads(result_path(out, spec).read_text())
        assert r["spec"]["critic"] == spec.critic and r["num_timesteps"] >= 400
        ev = r["eval"]
        assert ev["timesteps"][0] == 0 and ev["timesteps"][-1] == r["num_timesteps"]
        assert len(ev["mean_return"]) == len(ev["timesteps"]) >= 3
        assert r["final_return"] == ev["mean_return"][-1]
        acc = r["critic_accuracy"]
        assert len(acc["rmse"]) == len(acc["timesteps"]) >= 2
        assert all(np.isfinite(acc["rmse"])) and r["max_episode_steps"] == 500
        assert acc["horizon"] == mc_horizon(0.99, 500) == 459  # A2C's gamma: 0.99^459 < 0.01
        assert 0 < r["train_seconds"] <= r["wall_clock_seconds"] and r["train_cpu_seconds"] > 0
        for clock in r["train_clock"].values():
            # the training clock at each evaluation: from learn()'s start, never going back
            assert len(clock) == len(ev["timesteps"]) and clock[0] >= 0
            assert clock == sorted(clock)
        assert r["train_clock"]["seconds"][-1] >= r["train_seconds"]  # read after learn()
        reached = r["steps_to_threshold"]
        assert r["seconds_to_threshold"] == (
            None if reached is None else r["train_clock"]["seconds"][ev["timesteps"].index(reached)]
        )
        if spec.critic == "mlp":
            assert r["critic_share"] is None
        else:
            assert 0 < r["critic_share"] < 1
            assert r["critic_seconds"]["gp_update"] > 0
    assert pending_runs(specs, out) == []

    # 2. Interrupted: one result lost, and a half-written temporary file left behind.
    lost = specs[1]
    result_path(out, lost).unlink()
    (out / "runs" / f".{lost.run_id}.abc.tmp").write_text("{ half")
    before = _mtimes(out)
    executed = run_sweep(TINY, out, workers=1, progress=False)
    assert executed == [lost.run_id]  # only the lost run reran
    after = _mtimes(out)
    assert {k: v for k, v in after.items() if k != f"{lost.run_id}.json"} == before
    assert result_path(out, lost).is_file()

    # 3. Nothing left to do; a sweep with other settings refuses to mix into this folder.
    assert run_sweep(TINY, out, workers=1, progress=False) == []
    with pytest.raises(ValueError, match="other settings"):
        pending_runs(dataclasses.replace(TINY, timesteps_scale=0.1).specs(), out)
    # other GP options: named by a GP run's file (the MLP runs record them, unused)
    other_gp = dataclasses.replace(TINY, gp_options=(("max_basis", 64),)).specs()
    with pytest.raises(ValueError, match=r"a2c__geodesic__CartPole-v1__s0\.json was made with"):
        pending_runs(other_gp, out)
    # fresh seeds join the folder's cells only with their settings (the report pools them)
    fresh = dataclasses.replace(TINY, seeds=(2,))
    assert pending_runs(fresh.specs(), out) == fresh.specs()
    for other in (
        dataclasses.replace(fresh, timesteps_scale=0.1),
        dataclasses.replace(fresh, gp_options=(("max_basis", 64),)),
        dataclasses.replace(fresh, thresholds=(("CartPole-v1", 100.0),)),
    ):
        with pytest.raises(ValueError, match=r"__CartPole-v1__s[01]\.json was made with other"):
            pending_runs(other.specs(), out)
    other_cell = dataclasses.replace(TINY, seeds=(2,), algos=("ppo",), timesteps_scale=0.1)
    assert pending_runs(other_cell.specs(), out) == other_cell.specs()  # no run of its cells

    # 4. Aggregation.
    results = load_results(out)
    assert len(results) == 4
    rows = summary_rows(results)
    assert [r["critic"] for r in rows] == ["mlp", "geodesic"]
    diffs = [d for d in comparisons(results) if d["metric"] == "final_return"]
    assert [(d["a"], d["b"]) for d in diffs] == [("geodesic", "mlp")]
    assert rows[0]["n_seeds"] == 2 and rows[0]["final_low"] <= rows[0]["final_mean"]
    estimate = estimate_sweep_seconds(results, specs, workers=2)
    assert estimate["missing"] == [] and estimate["wall_seconds"] > 0
    bigger = dataclasses.replace(TINY, timesteps_scale=2 * TINY.timesteps_scale).specs()
    assert estimate_sweep_seconds(results, bigger)["total_seconds"] > estimate["total_seconds"]
    argv = ["compare", "--estimate-from", str(out), "--envs", "CartPole-v1", "--algos", "ppo"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "CPU hours" in printed and "ppo/mlp" in printed  # only a2c was calibrated
    assert "estimate (an upper bound) for 0 of " in printed and "not counted, 3 cells" in printed
    # a folder without run files (a typo, or its runs/ folder passed) is refused
    assert main([*argv[:2], str(out / "runs"), *argv[3:]]) == 2
    assert "no run files in its runs/ folder" in capsys.readouterr().err
    if importlib.util.find_spec("matplotlib") is not None:
        echoed: list[str] = []
        # against itself: every difference 0
        written = write_report(out, baseline_dir=out, echo=echoed.append)
        names = {p.name for p in written}
        assert {"summary.md", "comparisons.md", "comparisons.json", "critic_accuracy.png"} <= names
        vs = json.loads((out / "report" / "vs_baseline.json").read_text())
        assert vs and all(d["diff"] == 0 and d["a"] == d["b"] for d in vs)
        here = cpu()["cpu_model"] or "unrecorded"  # these runs' machine: this one
        header = (out / "report" / "vs_baseline.md").read_text().split("\n\n")[1]
        assert header == f"CPU models: this sweep {here}; baseline {here}."
        assert echoed == [header]  # what the command prints
        assert {"curves_CartPole-v1.png", "curves.png"} <= names
        assert "| CartPole-v1" in (out / "report" / "summary.md").read_text().replace("`", "")

    # A base install (no matplotlib): the tables, no figures, no crash.
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(sys.modules, "matplotlib", None)
        written = write_report(out)
        assert {p.name for p in written} == {
            "summary.md",
            "summary.json",
            "comparisons.md",
            "comparisons.json",
        }

    # 5. --ray without Ray installed: a clear error.
    if importlib.util.find_spec("ray") is None:
        with pytest.raises(ImportError, match="pip install"):
            run_sweep(TINY, out, use_ray=True, progress=False)


class _Ref:
    """A finished task's result (hashable by identity, like Ray's ObjectRef)."""

    def __init__(self, value: Any) -> None:
        self.value = value


class _FakeRay:
    """The few Ray calls the runner makes, executing each task at once in this process."""

    def __init__(self) -> None:
        self.initialized = False
        self.tasks = 0

    def is_initialized(self) -> bool:
        return self.initialized

    def init(self, **_: object) -> None:
        self.initialized = True

    def remote(self, **_: object) -> Callable[[Callable[..., Any]], Any]:
        fake = self

        class _Remote:
            def __init__(self, fn: Callable[..., Any]) -> None:
                self.fn = fn

            def remote(self, *args: Any) -> _Ref:
                fake.tasks += 1
                return _Ref(self.fn(*args))

        return _Remote

    def wait(self, refs: list[Any], num_returns: int = 1) -> tuple[list[Any], list[Any]]:
        return refs[:num_returns], refs[num_returns:]

    def get(self, ref: _Ref) -> Any:
        return ref.value


@pytest.mark.parametrize(
    ("threshold", "steps", "seconds"), [(100.0, 200, 1.5), (200.0, None, None)]
)
def test_seconds_to_threshold_is_the_training_clock_where_the_curve_first_reaches_it(
    threshold: float, steps: int | None, seconds: float | None
) -> None:
    spec = dataclasses.replace(TINY, thresholds=(("CartPole-v1", threshold),)).specs()[0]
    checkpoints = SimpleNamespace(
        eval_timesteps=[0, 200, 400],
        eval_returns=[[20.0, 30.0], [90.0, 120.0], [150.0, 60.0]],  # means 25, 105, 105
        train_seconds=[0.0, 1.5, 3.0],
        train_cpu_seconds=[0.0, 1.4, 2.9],
    )
    r = run_module._evaluation(spec, checkpoints)  # type: ignore[arg-type]
    assert (r["steps_to_threshold"], r["seconds_to_threshold"]) == (steps, seconds)
    assert r["train_clock"] == {"seconds": [0.0, 1.5, 3.0], "cpu_seconds": [0.0, 1.4, 2.9]}


def test_the_training_clock_starts_with_learn_where_start_clock_was_not_called() -> None:
    spec = TINY.specs()[0]
    model = build_model(spec)
    eval_envs = [gym.make(spec.env_id) for _ in range(spec.n_eval_episodes)]
    checkpoints = MeasureCallback(spec, eval_envs, ProbeStates.build(spec.env_id, 2), None)
    start = time.perf_counter()
    model.learn(spec.total_timesteps, callback=checkpoints)
    elapsed = time.perf_counter() - start
    seconds = checkpoints.train_seconds
    assert len(seconds) == len(checkpoints.eval_timesteps) >= 2
    assert 0 <= seconds[0] <= seconds[-1] <= elapsed


def test_ray_path_runs_the_same_run_function(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fake = _FakeRay()
    monkeypatch.setitem(sys.modules, "ray", fake)
    config = dataclasses.replace(TINY, critics=("mlp",), seeds=(0,))
    executed = run_sweep(config, tmp_path, use_ray=True, progress=False)
    assert executed == [config.specs()[0].run_id] and fake.tasks == 1 and fake.initialized
    assert result_path(tmp_path, config.specs()[0]).is_file()
    assert run_sweep(config, tmp_path, use_ray=True, progress=False) == []


def test_measurements_do_not_change_training(tmp_path: Path) -> None:
    spec = TINY.specs()[2]  # a2c, geodesic, CartPole, seed 0
    assert spec.critic == "geodesic"
    a = run_one(spec, tmp_path / "a")
    b = run_one(dataclasses.replace(spec, n_mc_rollouts=1, n_probe_states=5), tmp_path / "b")
    assert a["eval"]["returns"] == b["eval"]["returns"]

    # Nor does a recorder that reads what the GP critic logged at each rollout's end.
    class Logged(RolloutRecorder):
        def row(self) -> dict[str, Any]:
            return dict(self.model.logger.name_to_value, t=self.num_timesteps)

    recorder = Logged()
    c = run_one(spec, tmp_path / "c", recorders=[recorder])
    assert c["eval"]["returns"] == a["eval"]["returns"]
    assert c["critic_accuracy"] == a["critic_accuracy"]
    # One row per rollout (A2C: n_envs * n_steps steps each), each with what the GP logged.
    steps = [row["t"] for row in recorder.rows]
    assert steps == list(range(steps[0], c["num_timesteps"] + 1, steps[0]))
    assert all("gp/n_basis" in row for row in recorder.rows)
    # One Monte Carlo rollout per state: no standard error, and the result file is still valid.
    assert all(np.isfinite(a["critic_accuracy"]["mc_stderr"]))
    assert set(b["critic_accuracy"]["mc_stderr"]) == {None}
    assert json.loads(next((tmp_path / "b" / "runs").glob("*.json")).read_text())["eval"]
    assert a["gp_n_basis"] == b["gp_n_basis"]


def test_rollout_explained_variance_is_sb3s_formula() -> None:
    rng = np.random.default_rng(0)
    returns = rng.normal(3.0, 2.0, (64, 4)).astype(np.float32)
    values = (returns + rng.normal(0.0, 1.0, (64, 4))).astype(np.float32)
    buffer = SimpleNamespace(returns=returns, values=values)
    expected = explained_variance(values.ravel(), returns.ravel())  # SB3's, in float32
    assert rollout_explained_variance(buffer) == pytest.approx(expected, rel=1e-6)
    # Returns that do not vary explain nothing: NaN, as SB3 says, not a division by zero.
    flat = SimpleNamespace(returns=np.full((8, 2), 5.0, np.float32), values=values[:8, :2])
    assert np.isnan(rollout_explained_variance(flat))


def test_monte_carlo_targets_reach_the_gp_critic_and_its_result(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``target="monte_carlo"`` (and a ``horizon``) is the callback's in the run, is recorded in
    the result (and so refuses to mix with runs of other targets), and changes what the critic
    learns; the default's spec stays as files made before the option recorded it."""
    targets: list[tuple[str, int | None]] = []

    class Recording(run_module.TimedGPValueCallback):
        def _on_training_start(self) -> None:
            targets.append((self.target, self.horizon))
            super()._on_training_start()

    monkeypatch.setattr(run_module, "TimedGPValueCallback", Recording)
    spec = TINY.specs()[2]  # a2c, geodesic, CartPole, seed 0
    returns = run_one(spec, tmp_path)
    mc_spec = dataclasses.replace(spec, target="monte_carlo")
    mc = run_one(mc_spec, tmp_path / "mc")
    cut_spec = dataclasses.replace(mc_spec, horizon=3)
    cut = run_one(cut_spec, tmp_path / "cut")
    assert targets == [("returns", None), ("monte_carlo", None), ("monte_carlo", 3)]
    assert "target" not in returns["spec"] and mc["spec"]["target"] == "monte_carlo"
    assert "horizon" not in mc["spec"] and cut["spec"]["horizon"] == 3
    assert mc["critic_accuracy"]["rmse"] != returns["critic_accuracy"]["rmse"]
    assert cut["critic_accuracy"]["rmse"] != mc["critic_accuracy"]["rmse"]
    with pytest.raises(ValueError, match="other settings"):
        pending_runs([mc_spec], tmp_path)
    with pytest.raises(ValueError, match=r"other settings .*horizon: unset there, 3 now"):
        pending_runs([cut_spec], tmp_path / "mc")


def test_every_critic_starts_from_the_same_actor() -> None:
    """A file's net_arch with vf layers reaches every critic unchanged: the GP critics build the
    MLP critic's layers (then drop them) so that their actor starts identically. A kernel
    outside the compared ones (``laplacian``, ``matern``) builds too, with that kernel; an
    unknown name is refused."""
    entry = dict(n_steps=8, policy_kwargs="dict(net_arch=dict(pi=[16], vf=[24]))")
    critics = ("mlp", "rbf", "geodesic", "laplacian", "matern")
    specs = dataclasses.replace(TINY, critics=critics, seeds=(3,)).specs()
    actors = []
    for spec in specs:
        model = build_model(dataclasses.replace(spec, hyperparams=entry))
        if spec.critic != "mlp":
            assert type(model.policy.gp.kernel) is KERNELS[spec.critic]
        assert model.policy.mlp_extractor.latent_dim_pi == 16
        state = model.policy.state_dict()
        actors.append({k: v for k, v in state.items() if "value_net" not in k and "gp" not in k})
        model.get_env().close()
    assert all(actor.keys() == actors[0].keys() for actor in actors[1:])
    for key, value in actors[0].items():
        assert all(torch.equal(value, other[key]) for other in actors[1:]), key
    with pytest.raises(ValueError, match="critic must be one of"):
        build_model(dataclasses.replace(specs[0], critic="matern32"))


def test_a_warning_of_every_run_is_shown_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(Path(__file__).parents[2]))
    from tests.comparison.toy_env import WARNING

    file = HyperparamsFile("inline", {"ToyEnvWarns-v0": dict(n_envs=2, n_steps=8)})
    config = dataclasses.replace(
        TINY,
        algos=("ppo",),
        critics=("mlp",),
        envs=("tests.comparison.toy_env:ToyEnvWarns-v0",),
        timesteps=32,
        hyperparams_files=(("ppo", file),),
    )
    assert len(run_sweep(config, tmp_path, workers=1, progress=True)) == 2
    assert capsys.readouterr().err.count(WARNING) == 1
    assert all(f"UserWarning: {WARNING}" in r["warnings"] for r in load_results(tmp_path))


def test_a_kernel_instance_replaces_the_named_kernel(tmp_path: Path) -> None:
    """``run_one(..., kernel=K)`` trains with a copy of ``K`` and records its class; a kernel
    instance equal to the named one gives the named run's results exactly."""
    spec = next(s for s in TINY.specs() if s.critic == "geodesic")
    named = run_one(spec, tmp_path / "named")
    given = run_one(spec, tmp_path / "given", kernel=GeodesicKernel())
    for key in ("eval", "final_return", "critic_accuracy", "gp_n_basis"):
        assert given[key] == named[key], key
    assert given["kernel"] == "sb3_geogp.kernels.geodesic.GeodesicKernel" and "kernel" not in named
    short = GeodesicKernel(lengthscale=0.01)
    model = build_model(spec, kernel=short)
    assert type(model.policy.gp.kernel) is GeodesicKernel and model.policy.gp.kernel is not short
    assert torch.allclose(
        model.policy.gp.kernel.lengthscale, torch.tensor(0.01, dtype=torch.float64)
    )
    model.get_env().close()
    mlp = next(s for s in TINY.specs() if s.critic == "mlp")
    with pytest.raises(ValueError, match="are for a GP critic"):
        build_model(mlp, kernel=GeodesicKernel())


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX file modes")
def test_result_files_get_the_mode_of_any_new_file(tmp_path: Path) -> None:
    """Written atomically through a temporary file, which is private (0600), a result file
    ends with the mode an ordinary new file gets in its folder (readable by a shared group)."""
    path = tmp_path / "runs" / "r.json"
    run_module.write_json_atomic(path, {"a": 1})
    ordinary = tmp_path / "runs" / "ordinary.json"
    ordinary.write_text("{}")
    assert path.stat().st_mode == ordinary.stat().st_mode
    assert json.loads(path.read_text()) == {"a": 1}


@pytest.mark.parametrize("side", ["mlp", "gp"])
def test_a_critic_in_the_zoos_vecnormalize_is_evaluated_as_sb3_evaluates_it(
    side: str, tmp_path: Path
) -> None:
    """``mlp_normalize`` (``gp_normalize``): only the MLP (GP) critic's runs of a normalising
    entry train in ``VecNormalize`` (with the entry's gamma), the spec records it, and the
    evaluations equal SB3's ``evaluate_policy`` on evaluation environments normalised with the
    training statistics, as rl-baselines3-zoo evaluates; the critic's values are scaled back
    to returns by the inverse of ``VecNormalize.normalize_reward``."""
    config = dataclasses.replace(
        TINY, envs=("Pendulum-v1",), seeds=(0,), n_eval_episodes=3, **{f"{side}_normalize": True}
    )
    mlp, gp = config.specs()
    spec, other = (mlp, gp) if side == "mlp" else (gp, mlp)
    assert (spec.normalize, other.normalize) == (True, False)
    assert "normalize" not in other.as_dict() and spec.as_dict()["normalize"] is True
    assert not any(s.normalize for s in dataclasses.replace(config, envs=TINY.envs).specs())

    seen: dict[str, Any] = {}

    class AtTheEnd(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_training_end(self) -> None:
            venv = self.model.get_env()
            assert isinstance(venv, VecNormalize) and venv.gamma == 0.9 == self.model.gamma
            evaluation = VecNormalize(
                DummyVecEnv([lambda: gym.make("Pendulum-v1")] * 3),
                training=False,
                norm_reward=False,
            )
            sync_envs_normalization(venv, evaluation)
            evaluation.seed(EVAL_SEED)
            seen["returns"], _ = evaluate_policy(
                self.model, evaluation, n_eval_episodes=3, return_episode_rewards=True, warn=False
            )
            measure = MeasureCallback(spec, [], None, None)  # type: ignore[arg-type]
            measure.init_callback(self.model)
            seen["unscaled"] = measure._value_scale() * venv.normalize_reward(np.array([-3.7]))

    result = run_one(spec, tmp_path, recorders=[AtTheEnd()])
    # SB3's vectorised environments hand out rewards in float32.
    assert result["eval"]["returns"][-1] == pytest.approx(seen["returns"], rel=1e-6)
    assert seen["unscaled"] == pytest.approx([-3.7], rel=1e-6)  # normalize_reward: float32
    assert result["spec"]["normalize"] is True
    with pytest.raises(ValueError, match="other settings"):
        pending_runs([dataclasses.replace(spec, normalize=False)], tmp_path)


def test_gp_actor_normalize_normalises_the_gp_critics_actors_alone(tmp_path: Path) -> None:
    """``gp_actor_normalize``: only the GP critic's runs of an entry that normalises
    observations get ``normalize_actor_obs``, on raw environments; the spec records it, a run
    evaluates the policy's own actions (SB3's ``evaluate_policy`` on raw environments), and the
    result refuses to share a folder with runs without it."""
    config = dataclasses.replace(
        TINY, envs=("Pendulum-v1",), seeds=(0,), n_eval_episodes=3, gp_actor_normalize=True
    )
    mlp, gp = config.specs()
    assert (mlp.actor_normalize, gp.actor_normalize, gp.normalize) == (False, True, False)
    assert "actor_normalize" not in mlp.as_dict() and gp.as_dict()["actor_normalize"] is True
    assert not any(s.actor_normalize for s in dataclasses.replace(config, envs=TINY.envs).specs())
    with pytest.raises(ValueError, match="choose one"):
        dataclasses.replace(config, gp_normalize=True).specs()
    with pytest.raises(ValueError, match="are for a GP critic"):
        build_model(dataclasses.replace(mlp, actor_normalize=True))

    seen: dict[str, Any] = {}

    class AtTheEnd(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_training_end(self) -> None:
            assert not isinstance(self.model.get_env(), VecNormalize)
            norm = self.model.policy.actor_normalizer
            seen["count"], seen["steps"] = float(norm.running_count), self.model.num_timesteps
            evaluation = DummyVecEnv([lambda: gym.make("Pendulum-v1")] * 3)
            evaluation.seed(EVAL_SEED)
            seen["returns"], _ = evaluate_policy(
                self.model, evaluation, n_eval_episodes=3, return_episode_rewards=True, warn=False
            )

    result = run_one(gp, tmp_path, recorders=[AtTheEnd()])
    assert seen["count"] == pytest.approx(seen["steps"], abs=1e-3)  # every step observed
    assert result["eval"]["returns"][-1] == pytest.approx(seen["returns"], rel=1e-6)
    assert result["spec"]["actor_normalize"] is True
    with pytest.raises(ValueError, match="other settings"):
        pending_runs([dataclasses.replace(gp, actor_normalize=False)], tmp_path)
