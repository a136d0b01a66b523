"""The SB3-side example scripts, in tiny configurations (they are not otherwise run by CI)."""

from __future__ import annotations

import argparse
import copy
import dataclasses
import functools
import json
import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from scipy import stats
from stable_baselines3 import A2C
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.monitor import Monitor

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.envs.wall_maze import CORNER_LAYOUT, WallMaze
from sb3_geogp.policies import DEFAULT_ADAPTATION
from sb3_geogp.toolbox.tables import NO_INTERVAL
from tests.test_examples_engine import load_script


def test_benchmark_training_runs_every_critic(tmp_path: Path) -> None:
    """A tiny run of the training benchmark (SB3 inside): every critic, adaptive ones too."""
    bench = load_script("benchmark_training")
    out = tmp_path / "bench.json"
    argv = ["--workloads", "A2C CartPole-v1", "--seeds", "0", "--scale", "0.005", "--adapt"]
    bench.main([*argv, "--max-basis", "16", "--out", str(out)])
    results = json.loads(out.read_text())["results"]["A2C CartPole-v1"]
    assert set(results) == {
        "mlp",
        "rbf",
        "geodesic",
        "rbf+adapt",
        "geodesic+adapt",
        "laplacian+adapt",
    }
    for critic, runs in results.items():
        assert runs[0]["wall"] > 0
        assert (runs[0]["update"] > 0) == (critic != "mlp")


def test_benchmark_training_critics_option(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--critics`` runs exactly the named critics; ``+shared`` builds the one-factor kernel."""
    from sb3_geogp.kernels.geodesic import GeodesicKernel

    bench = load_script("benchmark_training")
    built: list[bool] = []
    init = GeodesicKernel.__init__

    @functools.wraps(init)  # the kernel's options are read from its signature
    def recording_init(self: GeodesicKernel, *args: object, **kwargs: object) -> None:
        init(self, *args, **kwargs)  # type: ignore[arg-type]
        built.append(self.ard)

    monkeypatch.setattr(GeodesicKernel, "__init__", recording_init)
    out = tmp_path / "bench.json"
    argv = ["--workloads", "A2C CartPole-v1", "--seeds", "0", "--scale", "0.005"]
    critics = ["geodesic+adapt", "geodesic+adapt+shared"]
    bench.main([*argv, "--max-basis", "16", "--critics", *critics, "--out", str(out)])
    assert list(json.loads(out.read_text())["results"]["A2C CartPole-v1"]) == critics
    assert built == [True, False]
    for bad in ("geodesic+fast", "mlp+adapt", "gpr", "geodesic+gap4", "geodesic+adapt+gap"):
        with pytest.raises(SystemExit):
            bench.main([*argv, "--critics", bad])


def test_benchmark_training_actornorm_normalises_the_actor(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``+actornorm`` gives the policy ``normalize_actor_obs=True``, and the GP nothing."""
    from sb3_geogp.normalization import ActorObservationNormalizer

    bench = load_script("benchmark_training")
    built: list[int] = []
    init = ActorObservationNormalizer.__init__

    def recording_init(self: ActorObservationNormalizer, dim: int, *args: float) -> None:
        init(self, dim, *args)
        built.append(dim)

    monkeypatch.setattr(ActorObservationNormalizer, "__init__", recording_init)
    for critic, expected in (("rbf+adapt", []), ("rbf+adapt+actornorm", [4])):
        built.clear()
        bench.run("A2C CartPole-v1", bench.critic_name(critic), 0, 16, 0.005)
        assert built == expected, critic
    assert bench.gp_kwargs_of(["adapt", "actornorm"]) == bench.gp_kwargs_of(["adapt"])


def test_benchmark_training_adapting_a2c_critic_is_the_drop_ins() -> None:
    """The A2C workload's ``rbf+adapt`` is the critic ``A2C(GPActorCriticPolicy, env)`` builds
    (the same forgetting and adaptation); only a critic that does not adapt gets the fixed
    ``forgetting=0.9``."""
    bench = load_script("benchmark_training")
    workload = "A2C CartPole-v1"
    env = make_vec_env("CartPole-v1", n_envs=2, seed=0)
    default = A2C(GPActorCriticPolicy, env, seed=0).policy.gp
    gp_kwargs = bench.critic_gp_kwargs(workload, "rbf+adapt", 256)
    benched = A2C(
        GPActorCriticPolicy, env, seed=0, policy_kwargs={"gp_kwargs": gp_kwargs}
    ).policy.gp
    assert type(benched.kernel) is type(default.kernel)
    assert benched.forgetting == default.forgetting
    assert benched.adaptation == default.adaptation
    assert bench.critic_gp_kwargs(workload, "rbf", 256)["forgetting"] == 0.9
    assert bench.critic_gp_kwargs(workload, "rbf+adapt+f1", 256)["forgetting"] == 1.0
    env.close()


def test_benchmark_training_times_the_drift_measurement_of_ppos_default_only(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """PPO's default critic measures the actor's drift at every rollout's end and the benchmark
    times it; ``+nodrift`` is 0.36's critic, which measures nothing (and counts no time)."""
    from stable_baselines3 import PPO

    from sb3_geogp import GPActorCriticPolicy
    from sb3_geogp.policies import default_drift_forgetting

    bench = load_script("benchmark_training")
    rate = default_drift_forgetting(PPO)
    assert rate > 0
    calls: list[float] = []
    measure = GPActorCriticPolicy.measure_drift

    def counting(self: GPActorCriticPolicy, *args: Any, **kwargs: Any) -> float:
        calls.append(self.gp.drift_forgetting)
        return measure(self, *args, **kwargs)

    monkeypatch.setattr(GPActorCriticPolicy, "measure_drift", counting)
    # 600 steps: three of the zoo's 256-step CartPole rollouts.
    default = bench.run("PPO CartPole-v1", "laplacian+adapt", 0, 16, 0.02)
    assert calls == [rate] * 3
    assert default["drift"] > 0.0
    calls.clear()
    nodrift = bench.run("PPO CartPole-v1", "laplacian+adapt+nodrift", 0, 16, 0.02)
    assert calls == [0.0] * 3
    assert nodrift["drift"] < default["drift"]
    run = {"update": 2.0, "predict": 1.0, "adaptation": 0.5, "drift": 1.0}
    assert bench.adaptation_share(run) == (0.5 + 1.0) / (2.0 + 1.0 + 1.0)


@pytest.mark.parametrize("kernel", ["laplacian", "rbf", "matern"])
def test_benchmark_training_refuses_a_suffix_the_kernel_cannot_take(kernel: str) -> None:
    """``+shared`` is the geodesic kernel's option: on another kernel it is refused as the
    arguments are read, not by a traceback once the critics before it have run."""
    bench = load_script("benchmark_training")
    assert bench.critic_name("geodesic+adapt+shared") == "geodesic+adapt+shared"
    with pytest.raises(argparse.ArgumentTypeError, match="'ard' is an option of the geodesic k"):
        bench.critic_name(f"{kernel}+adapt+shared")


def test_benchmark_training_setting_suffixes_build_those_settings() -> None:
    import dataclasses

    from sb3_geogp.adaptation import CHEAP_ADAPTATION, Adaptation, as_adaptation
    from sb3_geogp.policies import DEFAULT_ADAPTATION

    bench = load_script("benchmark_training")
    options = bench.gp_kwargs_of(["adapt", "thin512", "gap4", "shared"])
    assert options["kernel_kwargs"] == {"ard": False}
    expected = Adaptation(max_gap=4, score_points=512, fold_points=512)
    assert as_adaptation(options["adapt"]) == expected
    assert bench.gp_kwargs_of(["adapt"]) == {"adapt": True}
    assert bench.gp_kwargs_of(["adapt", "notrend"]) == {"adapt": True, "trend": "none"}
    assert bench.gp_kwargs_of(["adapt", "f1"]) == {"adapt": True, "forgetting": 1.0}
    assert bench.gp_kwargs_of(["adapt", "basis128"]) == {"adapt": True, "max_basis": 128}
    assert bench.gp_kwargs_of(["basis"]) is None  # a count suffix needs its count
    # +returns configures the callback, not the GP: 0.23's targets.
    assert bench.gp_kwargs_of(["adapt", "returns"]) == {"adapt": True}
    assert bench.callback_kwargs_of(["adapt", "returns"]) == {"target": "returns"}
    assert bench.callback_kwargs_of(["adapt", "f1"]) == {}
    # +cheap: the preset, settings on top of it.
    assert as_adaptation(bench.gp_kwargs_of(["cheap"])["adapt"]) == CHEAP_ADAPTATION
    cheap = as_adaptation(bench.gp_kwargs_of(["cheap", "steps2"])["adapt"])
    assert cheap == dataclasses.replace(CHEAP_ADAPTATION, steps=2)
    rare = as_adaptation(bench.gp_kwargs_of(["adapt", "gap16", "nosettle"])["adapt"])
    assert rare == Adaptation(max_gap=16, settle=False)
    folded = as_adaptation(bench.gp_kwargs_of(["adapt", "score256", "fold1024"])["adapt"])
    assert folded == Adaptation(score_points=256, fold_points=1024)
    floor = as_adaptation(bench.gp_kwargs_of(["adapt", "floor80"])["adapt"])
    assert floor == Adaptation(fit_floor=0.8)
    snap = as_adaptation(bench.gp_kwargs_of(["adapt", "fold256", "snapshot"])["adapt"])
    assert snap == Adaptation(fold_points=256, summary="snapshot")
    lagged = as_adaptation(bench.gp_kwargs_of(["adapt", "snapshot", "lagged"])["adapt"])
    assert lagged == Adaptation(summary="snapshot", forgetting_score="lagged")
    whole = as_adaptation(bench.gp_kwargs_of(["adapt", "snapshot", "whole"])["adapt"])
    assert whole == Adaptation(summary="snapshot", whole_batch=True)
    # PPO's default of 0.35-0.38, spelled out; 0.39-0.42 with the fit spacing; since 0.43 widening
    spelled = [
        "adapt",
        "gap16",
        "nosettle",
        "score256",
        "fold256",
        "floor80",
        "snapshot",
        "prior10",
        "whole",
    ]
    unspaced = as_adaptation(bench.gp_kwargs_of(spelled)["adapt"])
    assert unspaced == dataclasses.replace(
        DEFAULT_ADAPTATION, fit_spacing=None, follow_spread=False
    )
    spaced = as_adaptation(bench.gp_kwargs_of([*spelled, "spacing4096"])["adapt"])
    assert spaced == dataclasses.replace(DEFAULT_ADAPTATION, follow_spread=False)
    widened = as_adaptation(bench.gp_kwargs_of([*spelled, "spacing4096", "widen"])["adapt"])
    assert widened == DEFAULT_ADAPTATION
    assert bench.gp_kwargs_of(["nosettle"]) is None  # a setting needs +adapt or +cheap


def test_critic_fit_scores_each_rollout_as_sb3_does() -> None:
    """The recorder's explained variance per rollout equals SB3's own ``train/explained_variance``
    of the same rollout (computed by SB3 from the same buffer, for the MLP critic)."""
    import numpy as np
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback

    critic_fit = load_script("critic_fit")
    logged: list[float] = []

    class ReadSB3(BaseCallback):
        # At a rollout start SB3's logger still holds the values ``train`` just recorded.
        def _on_step(self) -> bool:
            return True

        def _on_rollout_start(self) -> None:
            value = self.model.logger.name_to_value.get("train/explained_variance")
            if value is not None:
                logged.append(float(value))

    model = PPO("MlpPolicy", "CartPole-v1", n_steps=64, batch_size=64, seed=0, device="cpu")
    recorder = critic_fit.ExplainedVariance()
    model.learn(64 * 5, callback=[recorder, ReadSB3()])
    assert len(logged) == 4 and len(recorder.explained) == 5
    np.testing.assert_allclose(recorder.explained[:4], logged, rtol=1e-5, atol=1e-6)


def test_critic_fit_tiny_run_writes_table_and_figure(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    critic_fit = load_script("critic_fit")
    argv = ["--envs", "CartPole-v1", "--critics", "mlp", "rbf", "--seeds", "0", "--scale", "0.01"]
    critic_fit.main([*argv, "--out", str(tmp_path)])
    runs = [json.loads(p.read_text()) for p in sorted((tmp_path / "runs").glob("*.json"))]
    assert {r["critic"] for r in runs} == {"mlp", "rbf"}
    for r in runs:
        n = len(r["explained_variance"])
        assert n >= 2 and r["tail_rollouts"] == n - int(0.8 * n)
        tail = r["explained_variance"][n - r["tail_rollouts"] :]
        assert abs(r["tail_mean"] - sum(tail) / len(tail)) < 1e-12
    assert "CartPole-v1" in (tmp_path / "critic_fit.md").read_text()
    assert (tmp_path / "critic_fit.png").stat().st_size > 0
    # Resuming with other GP options, another budget or another share of rollouts averaged
    # (each run's tail mean is kept in its file) would mix two readings in one table: refused,
    # in one line.
    capsys.readouterr()
    for other in (["--gp-option", "forgetting=0.9"], ["--scale", "0.02"], ["--last", "0.75"]):
        with pytest.raises(SystemExit):
            critic_fit.main([*argv, "--out", str(tmp_path), *other])
        assert "pass another --out" in capsys.readouterr().err


def test_critic_fit_leaves_undefined_scores_out_of_its_means(tmp_path: Path) -> None:
    """A rollout whose returns do not vary has no explained variance (NaN): the run file keeps
    it as ``null`` (strict JSON), its run's mean and the tables' means leave it out and say how
    many runs had none, the paired differences use the seeds both critics have, and the
    figure draws the rest."""

    from sb3_geogp.comparison.run import write_json_atomic

    critic_fit = load_script("critic_fit")
    assert critic_fit._score(float("nan")) is None and critic_fit._score(0.25) == 0.25
    write_json_atomic(tmp_path / "run.json", {"scores": [critic_fit._score(float("nan"))]})
    assert json.loads((tmp_path / "run.json").read_text()) == {"scores": [None]}

    def run(critic: str, seed: int, score: float | None) -> dict[str, Any]:
        return dict(env_id="CartPole-v1", critic=critic, seed=seed, tail_mean=score,
                    tail_pooled=score, timesteps=[1, 2],
                    explained_variance=[0.0, score])  # fmt: skip

    results = [run("mlp", s, v) for s, v in enumerate((0.4, 0.6, 0.8))]
    results += [run("laplacian", s, v) for s, v in enumerate((0.5, None, 0.95))]
    table = critic_fit.seed_table(results, ["mlp", "laplacian"], "tail_mean", "heading")
    assert (
        table[-1]
        == "| `CartPole-v1` | 0.600 [0.40, 0.80], 0/3 | 0.725 [0.50, 0.95], 1/3 (1 undefined) |"
    )
    paired = critic_fit.paired_differences(results, ["mlp", "laplacian"])
    # Seeds 0 and 2: +0.1, +0.15, too few for an interval.
    assert paired[-1].endswith(f"+0.125 ({NO_INTERVAL}) (2) |")
    critic_fit.plot(results, tmp_path / "fit.png")
    assert (tmp_path / "fit.png").stat().st_size > 0


def test_critic_fit_lag_table_averages_each_run_then_pairs_by_seed() -> None:
    """The lagged ceiling's row: per run the mean over the rollouts that have one (the first
    scored rollout may not), then over seeds; the ceiling and the critic's score minus it,
    paired by seed, here worked out by hand (two seeds: the mean alone)."""
    critic_fit = load_script("critic_fit")
    moments = [2.0, 1.0, 1.0, 0.5, 0.25]  # any valid pooled moments: the pooled cells' input

    def rollout(ceiling: float, lag: float | None) -> dict[str, Any]:
        row: dict[str, Any] = dict(explained=ceiling, truth_sd=1.0)
        if lag is not None:
            row["lag"] = dict(explained=lag, moments=moments, mc_critic_moments=moments,
                              value_rmse=2.0, truth_sd=1.0)  # fmt: skip
        return row

    def run(seed: int, critic: float, ceilings: list[float], lags: list[float | None]) -> Any:
        rollouts = [rollout(c, g) for c, g in zip(ceilings, lags, strict=True)]
        return dict(env_id="Acrobot-v1", critic="laplacian", seed=seed, tail_mean=critic,
                    tail_pooled=critic, ceiling=dict(rollouts=rollouts, tail_mean=np.mean(ceilings),
                    tail_pooled=0.9, with_lag=True))  # fmt: skip

    runs = [run(0, 0.6, [0.9, 0.9], [None, 0.5]), run(1, 0.7, [0.95, 0.95], [0.6, 0.8])]
    cells = critic_fit._lag_cells(runs)
    # lagged ceilings per run: 0.5 (its first rollout has none) and 0.7; neither reaches 0.9
    assert cells[0] == "0.650" and cells[1] == "0.600 [0.50, 0.70], 0/2"
    assert cells[2] == "0.925" and cells[-4] == "2.00" and cells[-3] == "1.00"
    # ceiling - lag: 0.9 - 0.5 and 0.95 - 0.7; critic - lag: 0.6 - 0.5 and 0.7 - 0.7
    assert cells[-2] == f"+0.325 ({NO_INTERVAL}) (2)"
    assert cells[-1] == f"+0.050 ({NO_INTERVAL}) (2)"
    table = critic_fit.lag_table(runs, ["laplacian"])
    assert table[-1].startswith("| `Acrobot-v1` | laplacian | 0.650 |")


def _each_run(
    critic_fit: Any, argv: list[str], variants: dict[str, list[str]], tmp_path: Path, run: str
) -> list[dict[str, Any]]:
    """``critic_fit`` run with ``argv`` plus each variant's arguments, each into its own folder
    under ``tmp_path``; the run file ``run`` of each, in the variants' order."""
    for name, extra in variants.items():
        critic_fit.main([*argv, *extra, "--out", str(tmp_path / name)])
    return [json.loads((tmp_path / name / "runs" / run).read_text()) for name in variants]


def test_critic_fit_feeds_the_gp_critic_the_target_asked_for(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--target`` reaches the GP critic's callback, unset PPO's default (Monte Carlo returns):
    the first rollout (scored before any feed) is the same, the later ones differ from the
    returns-fed run; the run records its target, and a resume with another target (a folder of
    returns-fed runs, as before 0.24, resumed with the default) or a horizon without
    ``--target monte_carlo`` is refused."""
    critic_fit = load_script("critic_fit")
    argv = ["--envs", "CartPole-v1", "--critics", "rbf", "--seeds", "0", "--scale", "0.02"]
    variants = {"returns": ["--target", "returns"], "default": []}
    returns, mc = _each_run(critic_fit, argv, variants, tmp_path, "rbf__CartPole-v1__s0.json")
    assert mc["target"] == "monte_carlo" and "target" not in returns
    assert mc["explained_variance"][0] == returns["explained_variance"][0]
    assert mc["explained_variance"][1:] != returns["explained_variance"][1:]
    capsys.readouterr()
    with pytest.raises(SystemExit):
        critic_fit.main([*argv, "--out", str(tmp_path / "returns")])
    assert "pass another --out" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        critic_fit.main([*argv, "--horizon", "10", "--out", str(tmp_path / "h")])
    assert not (tmp_path / "h").exists()


def test_critic_fit_ceiling_leaves_the_run_as_it_was(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--ceiling`` adds the scored rollouts' ceilings, and ``--lag`` their lagged ceilings,
    without changing a single score of the run (their Monte Carlo draws have their own random
    stream); a run resumed with another ``--ceiling`` or ``--lag``, and ``--lag`` without
    ``--ceiling``, are refused."""
    critic_fit = load_script("critic_fit")
    argv = ["--envs", "CartPole-v1", "--critics", "mlp", "--seeds", "0", "--scale", "0.01"]
    variants = {"plain": [], "ceiling": ["--ceiling", "4"], "lag": ["--ceiling", "4", "--lag"]}
    plain, with_ceiling, with_lag = _each_run(
        critic_fit, argv, variants, tmp_path, "mlp__CartPole-v1__s0.json"
    )
    assert with_ceiling["explained_variance"] == plain["explained_variance"]
    assert with_lag["explained_variance"] == plain["explained_variance"]
    # every scored rollout has a previous one here (the last 20 % of 5), so every one a lag
    lagged = [c["lag"] for c in with_lag["ceiling"]["rollouts"]]
    assert len(lagged) == plain["tail_rollouts"] and with_lag["ceiling"]["with_lag"]
    assert all(lag["explained"] <= 1 and lag["value_rmse"] >= 0 for lag in lagged)
    assert "The lagged ceiling" in (tmp_path / "lag" / "critic_fit.md").read_text()
    assert "lag" not in with_ceiling["ceiling"]["rollouts"][0]
    ceilings = with_ceiling["ceiling"]["rollouts"]
    assert len(ceilings) == plain["tail_rollouts"] and "ceiling" not in plain
    assert all(c["explained"] <= 1 and c["truth_sd"] > 0 for c in ceilings)
    assert all(-1 <= c["advantage_correlation"] <= 1 for c in ceilings)
    summary = (tmp_path / "ceiling" / "critic_fit.md").read_text()
    assert "The ceiling" in summary and "advantages: correlation |" in summary
    assert (tmp_path / "ceiling" / "ceiling.png").stat().st_size > 0
    capsys.readouterr()
    with pytest.raises(SystemExit):
        critic_fit.main([*argv, "--out", str(tmp_path / "plain"), "--ceiling", "4"])
    assert "another --ceiling" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        critic_fit.main([*argv, "--out", str(tmp_path / "ceiling"), "--ceiling", "4", "--lag"])
    assert "--lag" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        critic_fit.main([*argv, "--lag", "--out", str(tmp_path / "no_ceiling")])
    assert not (tmp_path / "no_ceiling").exists()
    with pytest.raises(SystemExit):  # no restartable dynamics for it: refused before any run
        critic_fit.main(
            ["--envs", "MountainCarContinuous-v0", "--ceiling", "4", "--out", str(tmp_path / "p")]
        )
    assert not (tmp_path / "p").exists()


def test_critic_fit_capacity_fits_models_beside_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--capacity`` records, for every scored rollout, the held-out scores of the five models
    (fresh GPs of the run's critic's options among them), the lag reading from the second
    scored rollout on; the table is written; a resume without it and a run without
    ``--ceiling`` are refused."""
    critic_fit = load_script("critic_fit")
    argv = ["--envs", "CartPole-v1", "--critics", "rbf", "--seeds", "0", "--scale", "0.02"]
    critic_fit.main(
        [*argv, "--ceiling", "4", "--capacity", "--last", "0.5", "--out", str(tmp_path)]
    )
    run = json.loads((tmp_path / "runs" / "rbf__CartPole-v1__s0.json").read_text())
    rollouts = run["ceiling"]["rollouts"]
    assert run["ceiling"]["with_capacity"] and len(rollouts) >= 2
    models = {key.split("|")[0] for key in rollouts[0]["capacity"] if "|" in key}
    assert models == {"gp", "gp, spread", "gp, rbf, spread", "mlp", "knn"}
    assert "gp|lag" not in rollouts[0]["capacity"] and "gp|lag" in rollouts[1]["capacity"]
    assert "What value models fitted once" in (tmp_path / "critic_fit.md").read_text()
    capsys.readouterr()
    with pytest.raises(SystemExit):
        critic_fit.main([*argv, "--ceiling", "4", "--last", "0.5", "--out", str(tmp_path)])
    assert "--capacity" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        critic_fit.main([*argv, "--capacity", "--out", str(tmp_path / "no_ceiling")])


def test_critic_fit_pairs_differences_by_seed() -> None:
    """Each critic minus the first, over the seeds both have, with the t interval scipy gives
    (from 5 seeds; with fewer, the difference alone)."""
    import scipy.stats as sps

    critic_fit = load_script("critic_fit")
    mlp, rbf = [0.5, 0.7, 0.2, 0.4, 0.9], [0.6, 1.0, 0.2, 0.6, 0.8, 0.0]
    tails = {("mlp", s): t for s, t in enumerate(mlp)} | {("rbf", s): t for s, t in enumerate(rbf)}
    results = [
        {"env_id": "CartPole-v1", "critic": c, "seed": s, "tail_mean": t}
        for (c, s), t in tails.items()
    ]
    row = critic_fit.paired_differences(results, ["mlp", "rbf"])[-1]
    diffs = np.array(rbf[:5]) - np.array(mlp)  # seed 5 has no MLP run
    mean, half = diffs.mean(), sps.t.ppf(0.975, 4) * diffs.std(ddof=1) / np.sqrt(5)
    expected = f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}] (5)"
    assert row == f"| `CartPole-v1` | {expected} |"
    two = [r for r in results if r["seed"] < 2]
    row = critic_fit.paired_differences(two, ["mlp", "rbf"])[-1]
    assert row == f"| `CartPole-v1` | +0.200 ({NO_INTERVAL}) (2) |"
    assert critic_fit.paired_differences(results, ["mlp"]) == []


class _PushUpLeft:
    """A stand-in policy: always the action (-1, 1)."""

    def predict(self, obs: object, deterministic: bool = True) -> tuple[object, None]:
        return np.array([-1.0, 1.0], dtype=np.float32), None


def test_wall_maze_pilot_tiny_run_and_its_goal_test(tmp_path: Path) -> None:
    pilot = load_script("wall_maze_pilot")
    argv = ["--slide", "--goal", "0.1", "0.9", "--goal-radius", "0.12", "--algos", "ppo"]
    argv += ["--seeds", "100", "--timesteps", "1000", "--map", "--grid", "5", "--workers", "1"]
    pilot.main([*argv, "--out", str(tmp_path)])
    text = (tmp_path / "pilot.md").read_text()
    assert "'slide': True" in text and "ppo seed 100" in text
    runs = list((tmp_path / "runs").glob("*.json"))
    assert len(runs) == 1 and json.loads(runs[0].read_text())["spec"]["critic"] == "mlp"
    rows = text.split("```\n")[1].splitlines()[:5]
    assert len(rows) == 5 and all(len(row) == 5 for row in rows)
    assert (tmp_path / "failure_map.png").stat().st_size > 0
    with pytest.raises(SystemExit, match="another --out"):
        pilot.main(["--max-step", "0.1", "--out", str(tmp_path)])
    # A grid with no start off the walls (the one point of a 1 x 1 grid is on the wall at
    # y = 0.5) is refused before the map's training.
    with pytest.raises(SystemExit, match="larger --grid"):
        pilot.main([*argv, "--grid", "1", "--out", str(tmp_path)])
    # Its run is not reused for another budget (whole rollouts: 1000 steps ran 2048) or
    # threshold: refused, naming the difference.
    for other in (["--timesteps", "5000"], ["--threshold", "-300"]):
        with pytest.raises(SystemExit, match=r"made with other (settings|threshold)"):
            pilot.main([*argv, *other, "--out", str(tmp_path)])
    # The map's goal test: a constant push up-left from the top side reaches the corner goal
    # when moves slide, and not in the published layout.
    for layout, reaches in ((WallMaze(CORNER_LAYOUT), True), (WallMaze(), False)):
        assert pilot._reaches_goal(_PushUpLeft(), layout, np.array([0.6, 0.9])) == reaches


def test_adaptation_schedule_replays_the_recorded_stream(tmp_path: Path) -> None:
    """A tiny record-and-replay: caps above every batch's size change nothing (the thinned
    runs are single points), a second call replays the saved stream, unchanged, to the same
    figures, and the MLP reference is scored on the same batches."""
    schedule = load_script("adaptation_schedule")
    uncapped = {**DEFAULT_ADAPTATION.as_dict(), "score_points": 10**6, "fold_points": 10**6}
    settings = {
        "default": {},
        "uncapped": uncapped,
        "small basis": {"gp_options": {"max_basis": 4}},
    }
    argv = [
        "--envs",
        "CartPole-v1",
        "--seeds",
        "0",
        "--timesteps",
        "1200",
        "--mlp",
        "--same-policy",
    ]
    argv += ["--settings", json.dumps(settings), "--out", str(tmp_path)]
    schedule.main(argv)
    first = json.loads((tmp_path / "results.json").read_text())["results"]["CartPole-v1"]["0"]
    stream = tmp_path / "streams" / "CartPole-v1__s0__t1200.pt"
    recorded = stream.stat().st_mtime_ns
    assert [p.name for p in (tmp_path / "streams").iterdir()] == [stream.name]  # no partial
    assert first["default"]["n_batches"] >= 4
    ev = first["default"]["explained_variance"]
    assert len(ev) == first["default"]["n_batches"] - 1
    assert ev == first["uncapped"]["explained_variance"]
    assert first["small basis"]["n_basis"] <= 4 < first["default"]["n_basis"]
    schedule.main(argv)
    again = json.loads((tmp_path / "results.json").read_text())["results"]["CartPole-v1"]["0"]
    assert stream.stat().st_mtime_ns == recorded
    assert again["default"]["explained_variance"] == ev
    table = (tmp_path / "table.md").read_text()
    assert "| `CartPole-v1` | uncapped |" in table
    # The MLP reference is scored on the same batches, untimed.
    mlp = again[schedule.MLP]
    assert len(mlp["explained_variance"]) == len(ev) and mlp["share"] is None
    assert f"| `CartPole-v1` | {schedule.MLP} | – | – |" in table
    assert (tmp_path / "frontier.png").stat().st_size > 0
    # --same-policy scores the first setting's GP critic and the MLP on every later batch.
    same = json.loads((tmp_path / "results.json").read_text())["same_policy"]["CartPole-v1"]
    assert set(same) == {"GP critic, default", schedule.MLP}
    assert all(len(r["0"]["same"]) == len(ev) for r in same.values())
    assert "| `CartPole-v1` | GP critic, default |" in (tmp_path / "same_policy.md").read_text()
    # CartPole's rollouts are 8 x 32 steps: fewer than 512 score no batch, refused up front
    with pytest.raises(SystemExit):
        schedule.main([*argv[:5], "511", "--out", str(tmp_path / "short")])
    assert not (tmp_path / "short").exists()


def test_adaptation_schedule_replays_a_drifting_critic_as_it_learnt() -> None:
    """A critic that forgets by the actor's drift (``drift_forgetting``): the recorder keeps
    each batch's drift, and a fresh critic of the same setting fed the stream ends bit for bit
    where the run's own critic ended; fed the batches without their drifts it does not."""
    schedule = load_script("adaptation_schedule")
    spec = schedule.ppo_spec("CartPole-v1", 0, 768, {"gp_options": {"drift_forgetting": 12.6}})
    model = schedule.build_model(spec)
    own = schedule.gp_critic(model)
    recorder = schedule.StreamRecorder(own)
    model.learn(768, callback=[schedule.GPValueCallback(target=spec.target), recorder])
    drifts = [schedule.batch_parts(b)[3] for b in recorder.batches]
    assert drifts[0] == 0.0 and all(d > 0 for d in drifts[1:])
    probe = th.as_tensor(model.rollout_buffer.observations.reshape(-1, 4), dtype=th.float64)
    for batches, same in ((recorder.batches, True), ([b[:3] for b in recorder.batches], False)):
        learner = schedule._GPLearner(schedule.gp_shadow(spec))
        schedule._scored(batches, learner.predict, learner.learn)
        assert th.equal(learner.predict(probe), own.predict(probe, return_var=False)[0]) == same


def test_adaptation_schedule_names_another_critics_stream_apart(tmp_path: Path) -> None:
    """The default recording keeps its name (earlier streams stay valid); another --record
    gets its own, the same for the same setting whatever its key order."""
    schedule = load_script("adaptation_schedule")

    def path(record: dict[str, Any]) -> Path:
        return schedule.stream_path(tmp_path, "sb3_geogp/PaperPendulum-v0", 3, 1200, record)

    assert path({}) == tmp_path / "sb3_geogp-PaperPendulum-v0__s3__t1200.pt"
    laplacian = path({"kernel": "laplacian", "target": None})
    assert laplacian.name.startswith("sb3_geogp-PaperPendulum-v0__s3__t1200__")
    assert laplacian == path({"target": None, "kernel": "laplacian"})
    assert laplacian != path({"kernel": "laplacian"}) != path({})


def _smooth_batches(n_batches: int, size: int, seed: int) -> list[tuple[th.Tensor, ...]]:
    """Batches of a fixed smooth function of a pendulum-like 2-d state (no episode starts)."""
    generator = th.Generator().manual_seed(seed)
    high = th.tensor([3.0, 8.0])
    batches = []
    for _ in range(n_batches):
        x = (2 * th.rand(size, 2, generator=generator) - 1) * high
        batches.append((x, th.cos(x[:, 0]) + 0.1 * x[:, 1], None))
    return batches


def test_adaptation_schedule_batch_reference_learns_a_fixed_function() -> None:
    """Fitted in batch on each newest batch, the default GP's basis predicts the next batch
    of a fixed smooth function of the state almost exactly, with either kernel, refitted or
    at the on-line GP's hyperparameters."""
    schedule = load_script("adaptation_schedule")
    batches = _smooth_batches(4, 300, seed=0)
    for options in ({}, {"euclidean": True}, {"refit": False}):
        r = schedule.replay_batch("sb3_geogp/PaperPendulum-v0", 0, batches, **options)
        assert len(r["explained_variance"]) == 3 and r["share"] is None
        assert min(r["explained_variance"]) > 0.9, (options, r["explained_variance"])


def test_adaptation_schedule_exact_references_learn_a_fixed_function() -> None:
    """Exact GPs on the newest batch or two predict the next batch of a fixed smooth function
    of the state almost exactly, with fitted or with the on-line GP's hyperparameters."""
    schedule = load_script("adaptation_schedule")
    batches = _smooth_batches(3, 150, seed=1)
    for name, options in schedule.EXACT.items():
        r = schedule.replay_exact("sb3_geogp/PaperPendulum-v0", 0, batches, **options)
        assert len(r["explained_variance"]) == 2 and r["share"] is None
        assert min(r["explained_variance"]) > 0.9, (name, r["explained_variance"])


def assert_study_resumes(study: Any, argv: list[str], out: Path, actor: str, figure: str) -> None:
    """A shadow study run again with ``argv`` keeps ``actor``'s finished run (not run again),
    and its table has the actor's MLP-shadow row and its figure is written; run again with
    another budget, it refuses the folder rather than reuse runs of the first."""
    done = out / "runs" / f"{actor}__s0.json"
    written = done.stat().st_mtime_ns
    assert study.main(argv) == 0
    assert done.stat().st_mtime_ns == written
    assert f"| {actor} | {study.MLP} |" in (out / "table.md").read_text()
    assert (out / figure).stat().st_size > 0
    at = argv.index("--timesteps") + 1
    steps = int(argv[at])
    longer = [*argv[:at], str(2 * steps), *argv[at + 1 :]]
    with pytest.raises(SystemExit, match=f"timesteps: {steps} there, {2 * steps} now"):
        study.main(longer)
    assert done.stat().st_mtime_ns == written


def test_action_gap_scores_every_critic_on_the_same_states(tmp_path: Path) -> None:
    """A tiny run per actor: the default GP shadow scores exactly as the geodesic run's own
    critic (it is fed the same rollouts), a finished run is not run again, and the table and
    the figure are written."""
    gaps = load_script("action_gap")
    argv = ["--seeds", "0", "--timesteps", "1536", "--every", "2", "--states", "24"]
    argv += ["--rollouts", "4", "--horizon", "30", "--out", str(tmp_path)]
    assert gaps.main(argv) == 0
    results = json.loads((tmp_path / "results.json").read_text())["results"]
    rows = results["geodesic"]["0"]["rows"]
    assert [r["step"] for r in rows] == [512, 1024, 1536]
    for row in rows:
        assert row[gaps.OWN] == row["geodesic GP (default)"]
        for name in (gaps.MLP, *gaps.CRITICS):
            assert 0 <= row[name]["n_decisive"] <= 24
    assert set(results["mlp"]["0"]["rows"][0]) == set(rows[0])
    assert_study_resumes(gaps, argv, tmp_path, "geodesic", "action_gap.png")


def test_action_gap_table_pairs_the_differences_with_the_critic_asked_for() -> None:
    """Six seeds whose late sign accuracies are given: the paired column against ``"A"`` is
    ``B - A`` with its t interval over the five seeds where both scored (a seed without
    decisive states, None, left out), against the MLP shadow by default; early checkpoints not
    read; from fewer than five seeds, the difference alone."""
    gaps = load_script("action_gap")

    def scored(value: float | None) -> dict[str, float | None]:
        return {"sign_accuracy": value, "weighted_sign_accuracy": value}

    def run(a: float | None, b: float, mlp: float) -> dict[str, Any]:
        late = {"A": a, "B": b, gaps.MLP: mlp}
        early = {"step": 10, **{n: scored(0.0) for n in late}}
        return {"rows": [early, {"step": 90, **{n: scored(v) for n, v in late.items()}}]}

    a = [0.5, 0.4, None, 0.6, 0.3, 0.5]
    b = [0.7, 0.5, 0.9, 0.6, 0.6, 0.8]
    results = {"mlp": {s: run(a[s], b[s], 0.6) for s in range(6)}}
    diffs = np.array([0.2, 0.1, 0.0, 0.3, 0.3])  # B - A where A scored
    mean, half = diffs.mean(), stats.t.ppf(0.975, 4) * diffs.std(ddof=1) / np.sqrt(5)
    text = gaps.table(results, timesteps=100, against="A")
    assert "| − A [95% CI] |" in text
    ci = f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]"
    assert f"| mlp | B | {np.mean(b):.3f} [0.50, 0.90] | {np.mean(b):.3f} | {ci} | 6 |" in text
    assert "| mlp | A | 0.460 [0.30, 0.60] | 0.460 | – | 6 |" in text
    assert f"| − {gaps.MLP} [95% CI] |" in gaps.table(results, timesteps=100)
    three = {"mlp": {s: results["mlp"][s] for s in range(3)}}
    assert f"| mlp | B | 0.700 [0.50, 0.90] | 0.700 | +0.150 ({NO_INTERVAL}) | 3 |" in gaps.table(
        three, timesteps=100, against="A"
    )


def test_advantage_error_scores_every_critic_against_the_same_reference(tmp_path: Path) -> None:
    """A tiny run per actor: the default GP shadow scores exactly as the Laplacian run's own
    critic (it is fed the same rollouts), a finished run is not run again, and the table and
    the figure are written."""
    study = load_script("advantage_error")
    argv = ["--seeds", "0", "--timesteps", "4096", "--rollouts", "4", "--horizon", "20"]
    argv += ["--skip", "0", "--out", str(tmp_path)]
    assert study.main(argv) == 0
    results = json.loads((tmp_path / "results.json").read_text())["results"]
    rows = results["laplacian"]["0"]["rows"]
    assert [r["step"] for r in rows] == [4096]
    for row in rows:
        assert row[study.OWN] == row["Laplacian GP (PPO default)"]
        assert 0 < row["reliability"] <= 1
        for name in (study.MLP, *study.CRITICS):
            assert -1 <= row[name]["correlation"] <= 1 and row[name]["value_rmse"] > 0
            # the parts recorded with the scores make them up again
            s = row[name]
            b, rho = s["advantage_slope"], s["advantage_residual"]
            assert s["correlation"] == pytest.approx(b / math.hypot(b, rho), rel=1e-9)
            assert s["value_rmse"] == pytest.approx(math.hypot(s["value_bias"], s["value_spread"]))
    assert set(results["mlp"]["0"]["rows"][0]) == set(rows[0])
    assert_study_resumes(study, argv, tmp_path, "laplacian", "advantage_error.png")
    # the table with the parts, read from the same runs; rows without a part are refused
    assert study.main([*argv, "--metrics", "correlation", "error_gain"]) == 0
    text = (tmp_path / "table.md").read_text()
    assert "| correlation | − SB3 MLP critic (shadow) [95 % CI] | error_gain |" in text
    stripped = {a: {int(k): v for k, v in by_seed.items()} for a, by_seed in results.items()}
    for row in stripped["mlp"][0]["rows"]:
        del row[study.OWN]["error_gain"]
    with pytest.raises(ValueError, match=r"mlp's runs have no \['error_gain'\]"):
        study.table(stripped, 0, metrics=["error_gain"])


def test_advantage_error_ceiling_of_the_correlation_is_zero_where_halves_disagree() -> None:
    """Attenuation: a reference of reliability ``r`` caps a correlation at ``sqrt(r)``; split
    halves that disagree (``r < 0``, which Monte Carlo noise gives) cap it at 0, not NaN."""
    study = load_script("advantage_error")
    rows = [{"reliability": r} for r in (0.81, -0.04, 1.0, float("nan"))]
    got = study.correlation_ceiling(rows)
    np.testing.assert_array_equal(got[:3], [0.9, 0.0, 1.0])
    assert np.isnan(got[3])


def test_advantage_error_runs_on_a_maze_and_pairs_against_the_critic_asked_for(
    tmp_path: Path,
) -> None:
    """On WallMaze-v0 (2-D actions, restarted by ``value_ceiling.TASKS``) a Laplacian GP shadow
    fed the run's rollouts scores exactly as the Laplacian run's own critic, with SB3's returns
    and with Monte Carlo targets, and ``--against`` pairs the table with the critic it
    names."""
    study = load_script("advantage_error")
    critics = {
        "Laplacian GP": {"kernel": "laplacian"},
        "geodesic GP": {"kernel": "geodesic"},
        "oracle GP": {"kernel": "geodesic", "walls": True},
    }
    argv = ["--env", "sb3_geogp/WallMaze-v0", "--actors", "laplacian", "--seeds", "0"]
    argv += ["--timesteps", "2048", "--rollouts", "2", "--horizon", "30", "--skip", "0"]
    argv += ["--critics", json.dumps(critics), "--against", "geodesic GP"]
    assert study.main([*argv, "--out", str(tmp_path)]) == 0
    rows = json.loads((tmp_path / "results.json").read_text())["results"]["laplacian"]["0"]["rows"]
    assert [r["step"] for r in rows] == [1024, 2048]
    for row in rows:
        assert row[study.OWN] == row["Laplacian GP"]
        for name in (study.MLP, *critics):
            assert -1 <= row[name]["correlation"] <= 1 and row[name]["value_rmse"] > 0
    text = (tmp_path / "table.md").read_text()
    assert "| − geodesic GP [95 % CI] |" in text and "| laplacian | geodesic GP | " in text
    with pytest.raises(SystemExit):
        study.main([*argv[:-1], "no such critic", "--out", str(tmp_path / "bad")])
    # Monte Carlo targets: the run's own GP critic's feed, teed to the shadows
    mc = [*argv[:-4], "--critics", json.dumps({"Laplacian GP": critics["Laplacian GP"]})]
    assert study.main([*mc, "--target", "monte_carlo", "--out", str(tmp_path / "mc")]) == 0
    mc_rows = json.loads((tmp_path / "mc" / "results.json").read_text())["results"]["laplacian"]
    assert all(row[study.OWN] == row["Laplacian GP"] for row in mc_rows["0"]["rows"])
    assert mc_rows["0"]["rows"][-1][study.OWN] != rows[-1][study.OWN]  # other targets
    with pytest.raises(SystemExit):  # an MLP critic has no such feed
        study.main([*mc, "--actors", "mlp", "--target", "monte_carlo", "--out", str(tmp_path)])
    kernels = study.oracle_kernels("sb3_geogp/WallMaze-v0", critics)
    assert list(kernels) == ["oracle GP"] and kernels["oracle GP"].blocked is not None
    with pytest.raises(ValueError, match="geodesic shadows on a maze"):
        study.oracle_kernels("sb3_geogp/WallMaze-v0", {"x": {"kernel": "rbf", "walls": True}})


def test_advantage_error_runs_gp_shadows_beside_sb3s_critic_with_each_critics_feed(
    tmp_path: Path,
) -> None:
    """``--actors mlp --target defaults``: SB3's MLP critic trains the agent and a GP shadow
    learns beside it; the MLP shadow starts as the run's own critic (same scores at the first
    rollout end, before either learns) and the GP shadow learns (other scores later)."""
    study = load_script("advantage_error")
    argv = ["--env", "CartPole-v1", "--actors", "mlp", "--target", "defaults", "--seeds", "0"]
    argv += ["--critics", json.dumps({"Laplacian GP": {"kernel": "laplacian"}})]
    argv += ["--timesteps", "768", "--rollouts", "2", "--horizon", "20", "--skip", "0"]
    argv += ["--against", study.OWN, "--out", str(tmp_path)]
    assert study.main(argv) == 0
    rows = json.loads((tmp_path / "results.json").read_text())["results"]["mlp"]["0"]["rows"]
    assert len(rows) == 3 and rows[0][study.MLP] == rows[0][study.OWN]
    assert rows[-1]["Laplacian GP"] != rows[0]["Laplacian GP"]
    assert "| − run's own critic [95 % CI] |" in (tmp_path / "table.md").read_text()


def test_same_policy_separates_a_changed_function_from_a_fixed_one() -> None:
    """On batches of one fixed function, fitting other environments of the same batch first
    predicts the held-out half no better than the past batches did; when the function flips
    sign from batch to batch, only the copy that learnt the batch's first half predicts it.
    A batch whose middle is not an environment boundary is refused."""
    schedule = load_script("adaptation_schedule")
    generator = th.Generator().manual_seed(0)
    high = th.tensor([3.0, 8.0])
    starts = th.zeros(400, dtype=th.bool)
    starts[[0, 100, 200, 300]] = True  # four environments of 100 steps

    def batch(sign: float) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        x = (2 * th.rand(400, 2, generator=generator) - 1) * high
        return x, sign * (th.cos(x[:, 0]) + 0.1 * x[:, 1]), starts

    def learner() -> object:
        # 0.13's PPO critic: forgetting per batch (400-point batches that flip sign need more
        # than the default's 0.03 per 4,096 points, 0.71 per batch), scored by shrinking (the
        # lagged score rightly keeps batches two back, whose sign is the new batch's).
        shrink = dataclasses.replace(DEFAULT_ADAPTATION, forgetting_score="shrink").as_dict()
        spec = schedule.ppo_spec(
            "sb3_geogp/PaperPendulum-v0", 0, 1, {**shrink, "gp_options": {"forgetting": 1.0}}
        )
        return schedule._GPLearner(schedule.gp_shadow(spec))

    fixed = schedule.same_policy([batch(1.0) for _ in range(5)], learner())
    assert len(fixed["next"]) == len(fixed["same"]) == 4
    assert min(fixed["next"]) > 0.9 and abs(fixed["tail_same"] - fixed["tail_next"]) < 0.05
    flipped = schedule.same_policy([batch((-1.0) ** i) for i in range(5)], learner())
    # Every batch: the copy that saw the new sign predicts better; once the forgetting has
    # adapted to the flips (the last batch) it predicts well, the past batches not at all.
    assert all(s > n for s, n in zip(flipped["same"], flipped["next"], strict=True))
    assert max(flipped["next"]) < 0 and flipped["tail_same"] > 0.5
    x, y, _ = batch(1.0)
    with pytest.raises(ValueError, match="row 200"):
        schedule.same_policy([(x, y, th.zeros(400, dtype=th.bool))], learner())


def test_same_policy_copies_of_the_mlp_critic_learn_as_the_original() -> None:
    """Pendulum's PPO policy uses gSDE, whose exploration weights torch cannot deep-copy; the
    copy :func:`same_policy` makes must still be faithful: after the same batch, the copy and
    the original predict identically, and differently from before."""
    schedule = load_script("adaptation_schedule")
    generator = th.Generator().manual_seed(0)
    x, y = th.randn(64, 3, generator=generator), th.randn(64, generator=generator)
    original = schedule._MLPLearner("Pendulum-v1", 0)
    original.learn(x, y)
    before = original.predict(x)
    twin = copy.deepcopy(original)
    for learner in (original, twin):
        learner.learn(x, y)
    assert th.equal(original.predict(x), twin.predict(x))
    assert not th.equal(original.predict(x), before)


def test_device_check_on_the_cpu_passes_and_writes_its_figures(tmp_path: Path) -> None:
    """The script's own checks (finite values, save/load on the CPU) hold; on the CPU the
    engine gaps are exactly 0."""
    device_check = load_script("device_check")
    out = tmp_path / "device.json"
    argv = ["--device", "cpu", "--timesteps", "256", "--batches", "2", "--points", "64"]
    assert device_check.main([*argv, "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["failed"] == []
    engines = [f"engine_{k}_{a}" for k in device_check.KERNELS for a in device_check.ADAPTATIONS]
    assert {report[e]["mean_gap"] for e in engines} == {0.0}
    assert report["train_ppo_cpu"]["finite"] and report["train_a2c_cpu"]["load_gap"] == 0.0
    assert all(report[f"train_{a}_cpu"]["same_rollout"] for a in ("ppo", "a2c"))


def test_acrobot_stall_height_is_gymnasiums_and_a_tiny_run_writes_its_figures(
    tmp_path: Path,
) -> None:
    """The tip height from observations equals gymnasium's own, from the joint angles (its
    goal test is ``-cos(s0) - cos(s1 + s0) > 1``); one rollout per critic is recorded."""
    script = load_script("acrobot_stall")
    env = gym.make("Acrobot-v1")
    obs, _ = env.reset(seed=0)
    observations, heights = [], []
    for _ in range(200):
        obs, *_ = env.step(env.action_space.sample())
        s = env.unwrapped.state
        observations.append(obs)
        heights.append(-np.cos(s[0]) - np.cos(s[1] + s[0]))
    np.testing.assert_allclose(script.tip_height(np.array(observations)), heights, atol=1e-6)
    assert script.main(["--seeds", "0", "--timesteps", "4096", "--out", str(tmp_path)]) == 0
    results = json.loads((tmp_path / "acrobot_stall.json").read_text())
    assert set(results) == set(script.CRITICS)
    for runs in results.values():
        (rows,) = runs.values()
        assert [r["timesteps"] for r in rows] == [4096]
        assert -1 <= rows[0]["corr"] <= 1 and rows[0]["goals"] <= rows[0]["ended"]
        assert rows[0]["explained"] <= 1 and -1 <= rows[0]["returns_corr"] <= 1
    assert (tmp_path / "acrobot_stall.png").stat().st_size > 0


def test_acrobot_stall_counts_a_goal_reached_on_the_last_step() -> None:
    """gymnasium's Acrobot-v1 put at the goal on its 500th step (terminated, return -499), and
    one that runs out (-500): one goal of two episodes."""
    script = load_script("acrobot_stall")
    infos = []
    for at_goal in (True, False):
        env = Monitor(gym.make("Acrobot-v1"))
        env.reset(seed=0)
        for _ in range(script.CAP - 1):
            env.step(1)  # no torque: the hanging arm never swings up
        if at_goal:
            env.unwrapped.state = np.array([np.pi, 0.0, 0.0, 0.0])  # tip height 2 > 1
        _, _, terminated, truncated, info = env.step(1)
        # Truncated too at the goal, unless rl_zoo3 (imported by other tests) has patched
        # gymnasium's TimeLimit to report only the termination there.
        assert terminated == at_goal and (truncated or terminated)
        infos.append(info)
    assert [i["episode"]["l"] for i in infos] == [script.CAP] * 2
    recorder = script.RolloutRecorder()
    recorder.locals = {"infos": infos}
    recorder._on_step()
    assert (recorder._ended, recorder._goals) == (2, 1)


def test_acrobot_stall_gp_option_replaces_the_gp_critics_and_reaches_the_critic(
    tmp_path: Path,
) -> None:
    """``--gp LABEL=JSON`` runs the MLP and that GP critic only, built with those options: a
    fixed forgetting of 0.5 is the forgetting recorded; a bad option is refused by name."""
    script = load_script("acrobot_stall")
    fixed = '{"adapt": false, "forgetting": 0.5}'
    argv = ["--seeds", "0", "--timesteps", "4096", "--gp", f"fixed={fixed}", "--out", str(tmp_path)]
    assert script.main(argv) == 0
    results = json.loads((tmp_path / "acrobot_stall.json").read_text())
    assert list(results) == ["MLP", "fixed"]
    assert [r["forgetting"] for r in results["fixed"]["0"]] == [0.5]
    assert "forgetting" not in results["MLP"]["0"][0]
    with pytest.raises(argparse.ArgumentTypeError, match="JSON object of GP options"):
        script.gp_critic("fixed=[0.5]")


def test_train_ppo_pendulum_saves_where_asked_and_the_model_reloads(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The README's complete script: one PPO rollout (4 envs x 1024 steps), saved to --out."""
    from stable_baselines3 import PPO

    script = load_script("train_ppo_pendulum")
    script.main(1024, str(tmp_path / "model"))
    model = PPO.load(tmp_path / "model.zip")
    assert model.num_timesteps == 4096 and model.policy.gp.n_basis > 0
    assert f"GP critic: {model.policy.gp.n_basis} basis vectors" in capsys.readouterr().out


def test_long_training_run_records_every_rollout_and_checks_the_state(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A short A2C run (4 envs x 5 steps a rollout): one row per rollout with the GP's own
    figures, the checks passed, and a planted NaN in the state is caught. 190 steps are
    trained and reported as the 10 whole rollouts SB3 collects, 200 steps."""
    script = load_script("long_training_run")
    argv = ["--algo", "a2c", "--env", "CartPole-v1", "--timesteps", "190", "--no-progress"]
    assert script.main([*argv, "--memory-every", "3", "--out", str(tmp_path)]) == 0
    assert "A2C CartPole-v1, 200 steps, seed 0: 10 rollouts in" in capsys.readouterr().out
    result = json.loads((tmp_path / "long_training_run.json").read_text())
    table = result["per_rollout"]
    assert result["rollouts"] == 10
    assert table["timesteps"] == [20.0 * (i + 1) for i in range(10)]
    assert [i for i, m in enumerate(table["resident_mib"]) if m is not None] == [0, 3, 6, 9]
    # the default device is SB3's "auto": a GPU's allocated memory is read where there is one
    assert ("device_mib" in table) == th.cuda.is_available()
    assert all(0 < n <= 256 for n in table["n_basis"]) and min(table["noise_var"]) > 0
    assert result["checks"]["passed"] and (tmp_path / "long_training_run.png").stat().st_size
    record = {k: np.array([math.nan if v is None else v for v in vs]) for k, vs in table.items()}

    planted = {"alpha": th.tensor([1.0, math.nan])}  # what checks() reads: a GP state
    model = SimpleNamespace(policy=SimpleNamespace(gp=SimpleNamespace(state_dict=lambda: planted)))
    verdict = script.checks(model, record)
    assert not verdict["passed"] and verdict["nonfinite_state"] == ["alpha"]


def test_long_training_run_record_outgrows_its_plan_without_losing_a_rollout() -> None:
    """The record is preallocated for the planned rollouts (its own growth would be read as
    the training's memory); a run that collects more keeps every one, in order."""
    script = load_script("long_training_run")
    env = make_vec_env("CartPole-v1", n_envs=4, seed=0)
    model = A2C(GPActorCriticPolicy, env, seed=0)
    recorder = script.Recorder(memory_every=4, rollouts=3)
    model.learn(200, callback=[GPValueCallback(), recorder])
    record = recorder.record
    assert record["timesteps"].tolist() == [20.0 * (i + 1) for i in range(10)]
    assert np.flatnonzero(np.isfinite(record["resident_mib"])).tolist() == [0, 4, 8]
    assert np.isfinite(record["update_ms"]).all() and (record["n_basis"] > 0).all()
