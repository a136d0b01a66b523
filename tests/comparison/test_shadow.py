"""Shadow critics: built as the comparison builds its critics, fed what the run's critic is fed."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

from sb3_geogp import GPValueCallback
from sb3_geogp.callbacks import Target, default_feed, time_limit_truncations
from sb3_geogp.comparison import shadow
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.shadow import (
    MLP,
    OWN,
    ActorDrift,
    MLPShadow,
    OwnReturnsFeed,
    ShadowFeed,
    TeeFeed,
    gp_critic,
    gp_shadow,
    learn_with_shadows,
    ppo_spec,
    study_parser,
)
from sb3_geogp.targets import per_env
from tests.test_callbacks import (
    GAMMA,
    FeedRecorder,
    expected_monte_carlo,
    make_scripted,
    scripted_vec_env,
)


def test_ppo_spec_names_the_critic_and_its_options() -> None:
    spec = ppo_spec(
        "CartPole-v1", 3, 1000, {"kernel": "rbf", "max_gap": 4, "gp_options": {"max_basis": 8}}
    )
    options = dict(spec.gp_kwargs)
    assert (spec.critic, spec.seed, spec.algo, spec.total_timesteps) == ("rbf", 3, "ppo", 1000)
    assert options["max_basis"] == 8 and options["adapt"] == {"max_gap": 4}
    assert ppo_spec("CartPole-v1", 0, 1000, {}).critic == "geodesic"


@pytest.mark.parametrize("env_id", ["CartPole-v1", "Acrobot-v1"])
def test_ppo_spec_feeds_sb3_returns_unless_asked(env_id: str) -> None:
    """SB3's returns by default (the shadows' feed); ``"target": None`` is the drop-in
    policy's own feed under PPO, as GPValueCallback chooses it for the zoo's discount; neither
    key reaches the adaptation settings."""
    assert (ppo_spec(env_id, 0, 1, {}).target, ppo_spec(env_id, 0, 1, {}).horizon) == (
        "returns",
        None,
    )
    spec = ppo_spec(env_id, 0, 1, {"kernel": "laplacian", "target": None, "max_gap": 2})
    assert (spec.target, spec.horizon) == default_feed(PPO, spec.hyperparams["gamma"])
    assert dict(spec.gp_kwargs)["adapt"] == {"max_gap": 2}
    asked = ppo_spec(env_id, 0, 1, {"target": "monte_carlo", "horizon": 50})
    assert (asked.target, asked.horizon) == ("monte_carlo", 50)


@pytest.mark.parametrize("rate", [0.0, 12.6])
def test_a_shadow_with_the_runs_settings_reproduces_the_runs_critic(rate: float) -> None:
    """Fed every rollout by ShadowFeed through ActorDrift's learners, a GP shadow built from
    the run's spec ends bit for bit where the run's own GP critic ends, forgetting by the
    actor's drift where the run's critic does (a shadow fed without the drift then does not
    end there); a shadow with other settings does not."""
    options = {"drift_forgetting": rate}
    spec = ppo_spec("CartPole-v1", 0, 768, {"gp_options": options})
    model = build_model(spec)
    same, undrifted = gp_shadow(spec), gp_shadow(spec)
    other = gp_shadow(ppo_spec("CartPole-v1", 0, 1, {"gp_options": {**options, "max_basis": 8}}))
    drift = ActorDrift()
    feed = ShadowFeed([drift.learner(same), drift.learner(other), undrifted.update])
    callbacks = CallbackList([GPValueCallback(target="returns"), drift, feed])
    model.learn(768, callback=callbacks)
    own = gp_critic(model)
    probe = th.as_tensor(model.rollout_buffer.observations.reshape(-1, 4), dtype=th.float64)
    assert same.n_basis == own.n_basis
    values = [gp.predict(probe, return_var=False)[0] for gp in (same, own, undrifted)]
    assert th.equal(values[0], values[1])
    assert th.equal(values[2], values[1]) == (rate == 0)
    assert other.n_basis <= 8 < own.n_basis


@pytest.mark.parametrize(
    ("target", "n_steps"), [("monte_carlo", 4), ("monte_carlo", 2), ("returns", 4)]
)
def test_tee_feed_gives_the_shadows_what_the_runs_critic_learns(
    target: Target, n_steps: int
) -> None:
    """On the scripted env (episodes span rollouts, one terminates, one is truncated) the
    shadows get every batch the run's GP critic is fed, as it is fed: with Monte Carlo targets
    the hand-computed returns of completed episodes (none from a rollout in which no episode
    ends: 2 steps, episodes of 3 and 5); and a GP shadow built as the run's critic ends bit for
    bit where it ends."""
    model = make_scripted(PPO, n_steps=n_steps)
    recorder = FeedRecorder(model.policy, keep_empty=False)
    seen: list[tuple[np.ndarray, ...]] = []
    shadow = gp_critic(make_scripted(PPO, n_steps=n_steps))
    drift = ActorDrift()
    tee = TeeFeed([lambda *batch: seen.append(tuple(b.numpy() for b in batch)),
                   drift.learner(shadow)], target)  # fmt: skip
    model.learn(4 * 8, callback=[drift, tee])
    fed = [b for b in recorder.batches if len(b[1])]
    assert len(fed) == len(seen) > 0
    if n_steps == 2:  # rollouts in which no episode ended came, and were not passed on
        assert len(recorder.batches) > len(fed)
    checked = 0
    for (x, y, starts), (sx, sy, s_starts) in zip(fed, seen, strict=True):
        np.testing.assert_array_equal(sx, x)
        np.testing.assert_array_equal(sy, y)
        np.testing.assert_array_equal(s_starts, starts)
        if target == "monte_carlo":  # env 0's episodes end by termination: no bootstrap
            for (env_id, _, t), value in zip(x, y, strict=True):
                if env_id == 0:
                    assert value == pytest.approx(expected_monte_carlo(0, int(t)), rel=1e-6)
                    checked += 1
    assert checked == (15 if target == "monte_carlo" else 0)  # 16 steps: 5 episodes of 3
    probe = th.as_tensor(np.concatenate([x for x, _, _ in fed]), dtype=th.float64)
    own = gp_critic(model)
    assert th.equal(
        shadow.predict(probe, return_var=False)[0], own.predict(probe, return_var=False)[0]
    )


@pytest.mark.parametrize("gae_lambda", [1.0, 0.9])
def test_a_shadows_own_returns_are_its_gae_returns(gae_lambda: float) -> None:
    """On the scripted env (reward ``1 + t``; env 1 truncated by its time limit), rollout by
    rollout: a shadow whose values are the run's own MLP critic's gets the returns SB3 computed
    with that critic; a shadow whose values are 0 gets, at each step, the rewards summed with
    weights ``(gamma * lambda)^j`` to its episode's end or the rollout's, without SB3's
    bootstrap of the run's critic at the truncations (its own is 0)."""
    gamma = 0.9
    model = PPO(
        "MlpPolicy", scripted_vec_env(), n_steps=8, batch_size=16, n_epochs=1, seed=0,
        gamma=gamma, gae_lambda=gae_lambda,
    )  # fmt: skip
    got: dict[str, list[np.ndarray]] = {"own": [], "zero": []}
    expected: dict[str, list[np.ndarray]] = {"own": [], "zero": []}
    truncated: list[int] = []

    def zero_returns(obs: np.ndarray, starts: np.ndarray) -> np.ndarray:
        T, n_envs, _ = obs.shape
        out = np.zeros((T, n_envs))
        for e, t in np.ndindex(n_envs, T):
            k, weight = t, 1.0
            while True:
                out[t, e] += weight * (1.0 + obs[k, e, 2])
                if k + 1 == T or starts[k + 1, e]:
                    break
                k, weight = k + 1, weight * gamma * gae_lambda
        return out

    class Expected(BaseCallback):
        def _on_step(self) -> bool:
            truncated.extend(env for _, env, _ in time_limit_truncations(model, self.locals))
            return True

        def _on_rollout_end(self) -> None:
            buffer = model.rollout_buffer
            obs, starts = buffer.observations, buffer.episode_starts
            for name, y in (("own", buffer.returns), ("zero", zero_returns(obs, starts))):
                expected[name].append(per_env(obs, y, starts)[1])

    feeds = [
        OwnReturnsFeed(lambda x, y, s, name=name: got[name].append(y.numpy()), value)
        for name, value in (("own", shadow.own_value(model)), ("zero", lambda s: np.zeros(len(s))))
    ]
    model.learn(4 * 16, callback=CallbackList([Expected(), *feeds]))
    assert truncated and len(got["own"]) == len(expected["own"]) == 4
    for name in got:
        for mine, want in zip(got[name], expected[name], strict=True):
            np.testing.assert_allclose(mine, want, rtol=1e-5, atol=1e-5)


def values_after_defaults(
    model: OnPolicyAlgorithm, settings: dict[str, dict[str, Any]]
) -> dict[str, shadow.NumpyValue]:
    """Every critic's values after ``model`` (a CartPole-v1 run of seed 0) has learnt 512
    steps with GP shadows of ``settings`` and ``target="defaults"``."""
    seen: dict[str, shadow.NumpyValue] = {}

    class Idle(BaseCallback):
        def _on_step(self) -> bool:
            return True

    def checkpoints(values: dict[str, shadow.NumpyValue]) -> BaseCallback:
        seen.update(values)
        return Idle()

    scorer = learn_with_shadows(
        model, "CartPole-v1", 0, 512, settings, checkpoints, None, "defaults"
    )
    assert isinstance(scorer, Idle)
    return seen


def test_with_each_critics_default_feed_the_gp_shadow_follows_the_runs_critic() -> None:
    """``target="defaults"``: a GP shadow built as the run's default critic learns what that
    critic learns (the drop-in's feed) and ends bit for bit where it ends; the MLP shadow learns
    too (from its own returns, tested above)."""
    setting = {"kernel": "laplacian", "target": None}
    model = build_model(ppo_spec("CartPole-v1", 0, 512, setting))
    seen = values_after_defaults(model, {"same": setting})
    probe = np.random.default_rng(0).uniform(-0.2, 0.2, (64, 4))
    own = gp_critic(model)
    assert own.n_seen > 0
    np.testing.assert_array_equal(seen["same"](probe), seen[OWN](probe))
    untrained = MLPShadow("CartPole-v1", 0).predict(th.as_tensor(probe)).numpy()
    assert not np.allclose(seen[MLP](probe), untrained)


def scripted_return(env_id: int, t: int, value: float, horizon: int | None) -> float:
    """Hand sum of step ``t``'s Monte Carlo target on the scripted env (reward ``1 + t``; env 0
    terminates after 3 steps, env 1 is truncated after 5) for a critic whose value is ``value``
    everywhere: the discounted rewards to the episode's end, or to the ``horizon`` cut, plus the
    discounted value there (none after a termination)."""
    length = 3 if env_id == 0 else 5
    stop = length if horizon is None else min(length, t + horizon)
    tail = 0.0 if stop == length and env_id == 0 else value
    return sum(GAMMA ** (k - t) * (1 + k) for k in range(t, stop)) + GAMMA ** (stop - t) * tail


@pytest.mark.parametrize("horizon", [None, 2])
@pytest.mark.parametrize("value", [0.0, 7.0])
def test_monte_carlo_feed_gives_a_shadow_its_own_monte_carlo_returns(
    horizon: int | None, value: float
) -> None:
    """Beside a run of SB3's MLP critic on the scripted env (episodes span rollouts), a shadow
    whose value is a constant gets every step of a completed episode once, with the hand sum of
    its return: SB3's bootstrap of the run's critic at the truncations is replaced by the
    shadow's value, and so is the value at the ``horizon`` cut."""
    model = PPO(
        "MlpPolicy", scripted_vec_env(), n_steps=4, batch_size=8, n_epochs=1, seed=0, gamma=GAMMA
    )
    batches: list[tuple[np.ndarray, ...]] = []
    feed = shadow.MonteCarloFeed(
        lambda *batch: batches.append(tuple(b.numpy() for b in batch)),
        lambda s: np.full(len(s), value),
        horizon,
    )
    model.learn(4 * 8, callback=feed)
    x = np.concatenate([b[0] for b in batches])
    y = np.concatenate([b[1] for b in batches])
    steps = {(int(e), int(ep), int(t)) for e, ep, t in x}
    assert len(steps) == len(x) == 30  # 5 episodes of 3 steps and 3 of 5, each step once
    for (env_id, _, t), target in zip(x, y, strict=True):
        expected = scripted_return(int(env_id), int(t), value, horizon)
        assert target == pytest.approx(expected, rel=1e-6)


def test_monte_carlo_feed_with_the_runs_values_gives_what_the_runs_gp_critic_learns() -> None:
    """A shadow whose values are the run's own GP critic's gets, batch by batch, what
    GPValueCallback's Monte Carlo feed gives that critic (the reference), truncation
    bootstraps included."""
    model = make_scripted(PPO, n_steps=4)
    recorder = FeedRecorder(model.policy, keep_empty=False)
    seen: list[tuple[np.ndarray, ...]] = []
    feed = shadow.MonteCarloFeed(
        lambda *batch: seen.append(tuple(b.numpy() for b in batch)), shadow.own_value(model), None
    )
    model.learn(4 * 8, callback=CallbackList([feed, GPValueCallback(target="monte_carlo")]))
    fed = [b for b in recorder.batches if len(b[1])]
    assert len(fed) == len(seen) > 0
    for (x, y, starts), (sx, sy, s_starts) in zip(fed, seen, strict=True):
        np.testing.assert_array_equal(sx, x)
        np.testing.assert_allclose(sy, y, rtol=1e-6)
        np.testing.assert_array_equal(s_starts, starts)


def test_with_each_critics_default_feed_a_gp_shadow_learns_beside_sb3s_critic() -> None:
    """``target="defaults"`` on a run of SB3's MLP critic: the GP shadow, built as the drop-in
    builds its critic, learns the returns of completed episodes (MonteCarloFeed, above)."""
    model = build_model(dataclasses.replace(ppo_spec("CartPole-v1", 0, 512, {}), critic="mlp"))
    setting = {"kernel": "laplacian"}
    seen = values_after_defaults(model, {"gp": setting})
    probe = np.random.default_rng(0).uniform(-0.2, 0.2, (64, 4))
    fresh = shadow.posterior_mean(gp_shadow(ppo_spec("CartPole-v1", 0, 1, setting)))
    assert not np.allclose(seen["gp"](probe), fresh(probe))


def test_a_gp_shadow_fed_sb3s_returns_follows_the_runs_critic_fed_them() -> None:
    """``own_feed`` with the setting's ``"target": "returns"``: a GP shadow built as a run's GP
    critic fed SB3's returns gets the GAE returns of its own values, so it follows that
    critic (to float32 rounding: SB3 computes its returns in float32)."""
    setting = {"kernel": "laplacian", "target": "returns"}
    spec = ppo_spec("CartPole-v1", 0, 1024, setting)
    model = build_model(spec)
    follower = gp_shadow(spec)
    drift = ActorDrift()
    learn = drift.learner(follower)
    feed = shadow.own_feed(learn, shadow.posterior_mean(follower), setting, model)
    model.learn(1024, callback=CallbackList([GPValueCallback(target="returns"), drift, feed]))
    probe = np.random.default_rng(0).uniform(-0.2, 0.2, (64, 4))
    own = shadow.posterior_mean(gp_critic(model))(probe)
    assert follower.n_seen == gp_critic(model).n_seen > 0
    np.testing.assert_allclose(shadow.posterior_mean(follower)(probe), own, rtol=1e-5)


def test_monte_carlo_shadows_need_a_gp_critic() -> None:
    model = build_model(dataclasses.replace(ppo_spec("CartPole-v1", 0, 64, {}), critic="mlp"))
    with pytest.raises(ValueError, match="GP critic"):
        learn_with_shadows(
            model, "CartPole-v1", 0, 64, {}, lambda v: BaseCallback(), None, "monte_carlo"
        )
    with pytest.raises(ValueError, match="target must be"):
        learn_with_shadows(model, "CartPole-v1", 0, 64, {}, lambda v: BaseCallback(), None, "td")  # type: ignore[arg-type]


def test_mlp_shadow_learns_its_targets_and_its_step_size() -> None:
    mlp = MLPShadow("CartPole-v1", 0)
    rng = np.random.default_rng(0)
    x = th.as_tensor(rng.normal(size=(256, 4)))
    y = 3.0 + x[:, 0]  # a function of the state the untrained critic does not know
    before = mlp.predict(x).clone()
    mlp.learn(x, y, learning_rate=0.0)
    th.testing.assert_close(mlp.predict(x), before, rtol=0, atol=0)
    error_before = float((before.double() - y).square().mean())
    for _ in range(5):
        mlp.learn(x, y)
    error_after = float((mlp.predict(x).double() - y).square().mean())
    assert error_after < 0.05 * error_before
    assert mlp.model.policy.optimizer.param_groups[0]["lr"] == mlp.model.lr_schedule(1.0)


class OptimizerRates(BaseCallback):
    """The step size PPO's ``train()`` set on its optimizer for each rollout, read at the
    next rollout's start and at the end of training."""

    def __init__(self) -> None:
        super().__init__()
        self.used: list[float] = []
        self._first = True

    def _on_step(self) -> bool:
        return True

    def _on_rollout_start(self) -> None:
        if not self._first:
            self.used.append(self.model.policy.optimizer.param_groups[0]["lr"])
        self._first = False

    def _on_training_end(self) -> None:
        self.used.append(self.model.policy.optimizer.param_groups[0]["lr"])


def test_mlp_shadow_learns_each_rollout_at_ppos_step_size_for_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """CartPole-v1's zoo PPO decays its step size linearly: on each rollout the MLP shadow
    learns at the rate PPO's own ``train()`` uses on it (it took the previous rollout's)."""
    given: list[float] = []
    learn = MLPShadow.learn

    def recording(self: MLPShadow, x: th.Tensor, y: th.Tensor, learning_rate: float) -> None:
        given.append(learning_rate)
        learn(self, x, y, learning_rate)

    monkeypatch.setattr(MLPShadow, "learn", recording)
    timesteps = 768  # three rollouts of 8 envs x 32 steps
    spec = dataclasses.replace(ppo_spec("CartPole-v1", 0, timesteps, {}), critic="mlp")
    rates = OptimizerRates()
    learn_with_shadows(build_model(spec), "CartPole-v1", 0, timesteps, {}, lambda v: rates)
    assert len(given) == len(rates.used) == 3 and len(set(given)) == 3
    assert given == pytest.approx(rates.used, rel=1e-12, abs=0)


def test_mlp_shadow_starts_as_the_comparisons_mlp_critic() -> None:
    spec = dataclasses.replace(ppo_spec("CartPole-v1", 4, 1, {}), critic="mlp")
    model = build_model(spec)
    x = th.as_tensor(np.random.default_rng(1).normal(size=(16, 4)))
    with th.no_grad():
        expected = model.policy.predict_values(x.float())[:, 0]
    th.testing.assert_close(MLPShadow("CartPole-v1", 4).predict(x), expected, rtol=0, atol=0)


def test_each_study_run_keeps_the_provenance_of_the_code_that_made_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A study resumed by later code (here: another commit) keeps each run's own record, and
    ``results.json`` lists both; a run file written before runs kept one reads as ``None``."""
    parser = study_parser("toy", ["a"], 10, {}, tmp_path / "study")
    (tmp_path / "study" / "runs").mkdir(parents=True)
    (tmp_path / "study" / "runs" / "a__s9.json").write_text('{"score": 9}')  # as before 0.31.5

    def run(actor: str, seed: int, args: argparse.Namespace) -> dict[str, Any]:
        return {"score": seed}

    def study(seeds: list[str], commit: str) -> dict[str, Any]:
        monkeypatch.setattr(shadow, "provenance", lambda: {"git_commit": commit})
        args = parser.parse_args(["--seeds", *seeds])
        shadow.run_study(args, run, lambda results: "", lambda results, path: None, "f.png")
        return dict(json.loads((tmp_path / "study" / "results.json").read_text()))

    study(["0"], "AAAA")
    results = study(["0", "1", "9"], "BBBB")
    runs = results["results"]["a"]
    assert [runs[s].get("provenance") for s in ("0", "1", "9")] == [
        {"git_commit": "AAAA"}, {"git_commit": "BBBB"}, None,
    ]  # fmt: skip
    assert results["provenance"] == [{"git_commit": "AAAA"}, {"git_commit": "BBBB"}, None]
