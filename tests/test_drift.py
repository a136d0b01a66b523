"""The policy's drift between feeds (sb3_geogp.drift) and the GP critic's forgetting by it."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3 import A2C, PPO

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.measurement import RolloutRecorder
from sb3_geogp.drift import PolicyDrift, kl_per_state
from tests.test_sparse_gp import assert_same_state, snapshot


def test_kl_per_state_is_the_closed_form_for_gaussians_and_categoricals() -> None:
    rng = np.random.default_rng(0)
    m1, m2 = rng.normal(size=(2, 5, 3))
    s1, s2 = np.exp(rng.normal(size=(2, 5, 3)))
    gauss = kl_per_state(
        th.distributions.Normal(th.tensor(m1), th.tensor(s1)),
        th.distributions.Normal(th.tensor(m2), th.tensor(s2)),
    )
    expected = np.sum(np.log(s2 / s1) + (s1**2 + (m1 - m2) ** 2) / (2 * s2**2) - 0.5, axis=1)
    np.testing.assert_allclose(gauss.numpy(), expected, rtol=1e-12)
    p, q = (rng.dirichlet(np.ones(4), size=5) for _ in range(2))
    cat = kl_per_state(
        th.distributions.Categorical(probs=th.tensor(p)),
        th.distributions.Categorical(probs=th.tensor(q)),
    )
    np.testing.assert_allclose(cat.numpy(), np.sum(p * np.log(p / q), axis=1), rtol=1e-12)
    # MultiDiscrete: one categorical per action dimension, the divergences add up.
    both = kl_per_state(
        [th.distributions.Categorical(probs=th.tensor(p))] * 2,
        [th.distributions.Categorical(probs=th.tensor(q))] * 2,
    )
    np.testing.assert_allclose(both.numpy(), 2 * cat.numpy(), rtol=1e-12)


def _ppo(env_id: str, **kwargs: Any) -> PPO:
    return PPO(
        GPActorCriticPolicy,
        env_id,
        n_steps=64,
        batch_size=64,
        seed=0,
        device="cpu",
        policy_kwargs=dict(gp_kwargs=dict(max_basis=32, drift_forgetting=5.0)),
        **kwargs,
    )


def test_a_widened_gaussian_actor_drifts_by_the_closed_form() -> None:
    """Raising a Gaussian actor's log standard deviations by ``u`` moves it, at every state, by
    ``KL(N(m, s) || N(m, s e^u)) = u + e^(-2u) / 2 - 1 / 2`` per action dimension; an actor
    left as it was moves by exactly 0."""
    model = _ppo("Pendulum-v1")
    obs = np.random.default_rng(1).uniform(-1, 1, size=(500, 3)).astype(np.float32)
    drift = PolicyDrift(max_states=100)
    assert drift.measure(model.policy, obs) == 0.0  # nothing to compare with yet
    assert drift.measure(model.policy, obs) == 0.0
    u = 0.3
    with th.no_grad():
        model.policy.log_std += u
    assert drift.measure(model.policy, obs) == pytest.approx(u + math.exp(-2 * u) / 2 - 0.5)


def test_a_discrete_actor_drifts_by_the_mean_kl_on_the_previous_states() -> None:
    model = _ppo("CartPole-v1")
    rng = np.random.default_rng(2)
    first, second = rng.uniform(-0.2, 0.2, size=(2, 40, 4)).astype(np.float32)
    drift = PolicyDrift(max_states=256)

    def probs(states: np.ndarray) -> np.ndarray:
        with th.no_grad():
            return model.policy.get_distribution(th.tensor(states)).distribution.probs.numpy()

    drift.measure(model.policy, first)
    before = probs(first)
    with th.no_grad():
        model.policy.action_net.bias += th.tensor([1.0, -1.0])
    after = probs(first)
    expected = np.mean(np.sum(before * np.log(before / after), axis=1))
    assert expected > 0.1
    assert drift.measure(model.policy, second) == pytest.approx(expected, rel=1e-5)


class _Logged(RolloutRecorder):
    """The GP callback's logged values at every rollout end (run it after the GP callback)."""

    def row(self) -> dict[str, Any]:
        return dict(self.model.logger.name_to_value)


@pytest.mark.parametrize("algo", [PPO, A2C])
def test_an_actor_that_does_not_learn_forgets_nothing(algo: type) -> None:
    """With a learning rate of 0 the actor never moves: every drift measured is 0 and the
    critic ends bit for bit as one without drift forgetting; with learning the drift is
    positive and the factor logged is ``exp(-r drift)``."""
    kwargs = dict(n_steps=64, batch_size=64) if algo is PPO else dict(n_steps=8)

    def trained(rate: float, lr: float) -> tuple[Any, list[dict[str, Any]]]:
        model = algo(
            GPActorCriticPolicy,
            "Pendulum-v1",
            learning_rate=lr,
            seed=3,
            device="cpu",
            policy_kwargs=dict(gp_kwargs=dict(max_basis=32, drift_forgetting=rate)),
            **kwargs,
        )
        logged = _Logged()
        model.learn(640, callback=[GPValueCallback(target="returns"), logged])
        return model, logged.rows

    still, rows = trained(5.0, 0.0)
    assert [r["gp/policy_kl"] for r in rows] == [0.0] * len(rows)
    unforgetting, _ = trained(0.0, 0.0)
    states = [snapshot(m.policy.gp) for m in (still, unforgetting)]
    for state in states:
        del state["_extra_state"]  # the options: drift_forgetting 5 against 0
    assert_same_state(*states)
    _, rows = trained(5.0, 3e-3)
    kl = np.array([r["gp/policy_kl"] for r in rows])
    assert kl[0] == 0.0 and (kl[1:] > 0).all()
    factor = np.array([r["gp/drift_factor"] for r in rows])
    np.testing.assert_allclose(factor, np.exp(-5.0 * kl), rtol=1e-12)


def test_drift_forgetting_survives_save_and_load(tmp_path) -> None:
    model = _ppo("Pendulum-v1", learning_rate=3e-3)
    model.learn(256, callback=GPValueCallback(target="returns"))
    model.save(tmp_path / "model.zip")
    loaded = PPO.load(tmp_path / "model.zip", device="cpu")
    assert loaded.policy.gp.drift_forgetting == 5.0
    obs = th.tensor(np.random.default_rng(4).uniform(-1, 1, size=(20, 3)))
    with th.no_grad():
        for a, b in zip(model.policy.gp.predict(obs), loaded.policy.gp.predict(obs), strict=True):
            th.testing.assert_close(a, b, rtol=0, atol=0)
    assert_same_state(snapshot(model.policy.gp), snapshot(loaded.policy.gp))
    loaded.set_env(gym.make("Pendulum-v1"))
    loaded.learn(128, callback=GPValueCallback(target="returns"), reset_num_timesteps=False)
    assert loaded.policy.gp.n_batches == model.policy.gp.n_batches + 2


@pytest.mark.parametrize(
    ("algo", "gp_kwargs", "rate"),
    [(PPO, {}, 12.6), (PPO, dict(drift_forgetting=0.0), 0.0), (A2C, {}, 0.0)],
    ids=["ppo-default", "ppo-off", "a2c-default"],
)
def test_the_default_critic_forgets_by_drift_under_ppo_alone(
    algo: type, gp_kwargs: dict[str, Any], rate: float
) -> None:
    """Since 0.37 PPO's default critic forgets by ``exp(-12.6 KL)`` (the factor logged is that
    of the KL logged); A2C's forgets nothing by drift, nor does PPO's with
    ``drift_forgetting=0``."""
    kwargs = dict(n_steps=64, batch_size=64) if algo is PPO else dict(n_steps=8)
    model = algo(
        GPActorCriticPolicy,
        "Pendulum-v1",
        learning_rate=3e-3,
        seed=3,
        device="cpu",
        policy_kwargs=dict(gp_kwargs=dict(max_basis=32, **gp_kwargs)),
        **kwargs,
    )
    assert model.policy.gp.drift_forgetting == rate
    logged = _Logged()
    model.learn(320, callback=[GPValueCallback(target="returns"), logged])
    if rate == 0:  # nothing measured, nothing forgotten by drift
        assert not any("gp/policy_kl" in r or "gp/drift_factor" in r for r in logged.rows)
        return
    kl = np.array([r["gp/policy_kl"] for r in logged.rows])
    factor = np.array([r["gp/drift_factor"] for r in logged.rows])
    assert kl[0] == 0.0 and (kl[1:] > 0).all()
    np.testing.assert_allclose(factor, np.exp(-rate * kl), rtol=1e-12)


def test_a_ppo_critic_saved_without_drift_forgetting_loads_without_it() -> None:
    """A state saved by 0.36's default PPO critic (``drift_forgetting`` 0) or before 0.36
    (no such option): a policy with today's default critic (12.6) loading it rebuilds its
    critic with the saved 0, and predicts as saved."""
    trained = _ppo("Pendulum-v1", learning_rate=3e-3)
    trained.policy.gp.drift_forgetting = 0.0  # as 0.36's default critic was built
    trained.learn(256, callback=GPValueCallback(target="returns"))
    state = trained.policy.state_dict()
    obs = th.tensor(np.random.default_rng(4).uniform(-1, 1, size=(20, 3)))
    options = state["value_net.gp._extra_state"]
    before_0_36 = {k: v for k, v in options.items() if k != "drift_forgetting"}
    for saved in (options, before_0_36):
        fresh = PPO(
            GPActorCriticPolicy,
            "Pendulum-v1",
            seed=1,
            device="cpu",
            policy_kwargs=dict(gp_kwargs=dict(max_basis=32)),
        )
        assert fresh.policy.gp.drift_forgetting == 12.6
        fresh.policy.load_state_dict({**state, "value_net.gp._extra_state": saved})
        assert fresh.policy.gp.drift_forgetting == 0.0
        with th.no_grad():
            th.testing.assert_close(
                fresh.policy.gp.predict(obs)[0], trained.policy.gp.predict(obs)[0], rtol=0, atol=0
            )


def test_a_feed_of_several_rollouts_forgets_their_drifts_summed() -> None:
    """With ``feed_every=3`` the drift passed at each feed is the sum of the three rollouts'
    measured drifts."""
    model = _ppo("Pendulum-v1", learning_rate=3e-3)
    policy = model.policy
    measured: list[float] = []
    passed: list[float] = []
    measure, update = policy.measure_drift, policy.update_critic

    def measuring(*args: Any) -> float:
        measured.append(measure(*args))
        return measured[-1]

    def updating(*args: Any, drift: float = 0.0) -> dict[str, float]:
        if len(args[1]):
            passed.append(drift)
        return update(*args, drift=drift)

    policy.measure_drift = measuring  # type: ignore[method-assign]
    policy.update_critic = updating  # type: ignore[method-assign]
    model.learn(64 * 9, callback=GPValueCallback(target="returns", feed_every=3))
    assert len(measured) == 9 and len(passed) == 3
    np.testing.assert_allclose(passed, np.add.reduceat(measured, [0, 3, 6]), rtol=1e-12)
    assert passed[1] > 0


def test_the_drift_of_feeds_without_targets_waits_for_the_next_batch() -> None:
    """Monte Carlo targets on 200-step episodes, 64-step rollouts: most feeds have no target
    (no episode ended). The GP absorbs every drift measured, each with the next batch it
    absorbs: the drifts it was given sum to those measured up to its last batch."""
    model = _ppo("Pendulum-v1", learning_rate=3e-3)
    policy, gp = model.policy, model.policy.gp
    measured: list[float] = []
    absorbed: list[tuple[int, float]] = []  # (rollouts measured by then, drift)
    measure, update = policy.measure_drift, gp.update

    def measuring(*args: Any) -> float:
        measured.append(measure(*args))
        return measured[-1]

    def updating(*args: Any, drift: float = 0.0) -> None:
        absorbed.append((len(measured), drift))
        update(*args, drift=drift)

    policy.measure_drift = measuring  # type: ignore[method-assign]
    gp.update = updating  # type: ignore[method-assign]
    model.learn(64 * 16, callback=GPValueCallback(target="monte_carlo"))
    assert 2 <= len(absorbed) < len(measured) == 16  # feeds without targets happened
    last = absorbed[-1][0]
    np.testing.assert_allclose(sum(d for _, d in absorbed), sum(measured[:last]), rtol=1e-12)
    assert absorbed[-1][1] > measured[last - 1] > 0  # the last batch took earlier drifts too


@pytest.mark.parametrize("empty", [True, False])
def test_a_bad_drift_is_refused_before_anything_changes(empty: bool) -> None:
    model = _ppo("Pendulum-v1")
    policy = model.policy
    obs = np.random.default_rng(5).uniform(-1, 1, size=(30, 3)).astype(np.float32)
    n = 0 if empty else 30
    policy.update_critic(obs[:n], np.ones(n), np.ones(n, dtype=bool), drift=0.2)
    before = (snapshot(policy.gp), policy._drift_waiting)
    with pytest.raises(ValueError, match="drift must be a non-negative finite number"):
        policy.update_critic(obs[:n], np.ones(n), np.ones(n, dtype=bool), drift=-0.1)
    assert_same_state(before[0], snapshot(policy.gp))
    assert policy._drift_waiting == before[1] == (0.2 if empty else 0.0)
