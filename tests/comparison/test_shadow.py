"""Shadow critics: built as the comparison builds its critics, fed what the run's critic is fed."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import CallbackList

from sb3_geogp import GPValueCallback
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.shadow import MLPShadow, ShadowFeed, gp_critic, gp_shadow, ppo_spec


def test_ppo_spec_names_the_critic_and_its_options() -> None:
    spec = ppo_spec(
        "CartPole-v1", 3, 1000, {"kernel": "rbf", "max_gap": 4, "gp_options": {"max_basis": 8}}
    )
    options = dict(spec.gp_kwargs)
    assert (spec.critic, spec.seed, spec.algo, spec.total_timesteps) == ("rbf", 3, "ppo", 1000)
    assert options["max_basis"] == 8 and options["adapt"] == {"max_gap": 4}
    assert ppo_spec("CartPole-v1", 0, 1000, {}).critic == "geodesic"


def test_a_shadow_with_the_runs_settings_reproduces_the_runs_critic() -> None:
    """Fed every rollout by ShadowFeed, a GP shadow built from the run's spec ends bit for bit
    where the run's own GP critic ends; a shadow with other settings does not."""
    spec = ppo_spec("CartPole-v1", 0, 768, {})
    model = build_model(spec)
    same = gp_shadow(spec)
    other = gp_shadow(ppo_spec("CartPole-v1", 0, 1, {"gp_options": {"max_basis": 8}}))
    feed = ShadowFeed([same.update, other.update])
    model.learn(768, callback=CallbackList([GPValueCallback(target="returns"), feed]))
    own = gp_critic(model)
    probe = th.as_tensor(model.rollout_buffer.observations.reshape(-1, 4), dtype=th.float64)
    assert same.n_basis == own.n_basis
    th.testing.assert_close(
        same.predict(probe, return_var=False)[0], own.predict(probe, return_var=False)[0]
    )
    assert other.n_basis <= 8 < own.n_basis


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


def test_mlp_shadow_starts_as_the_comparisons_mlp_critic() -> None:
    spec = dataclasses.replace(ppo_spec("CartPole-v1", 4, 1, {}), critic="mlp")
    model = build_model(spec)
    x = th.as_tensor(np.random.default_rng(1).normal(size=(16, 4)))
    with th.no_grad():
        expected = model.policy.predict_values(x.float())[:, 0]
    th.testing.assert_close(MLPShadow("CartPole-v1", 4).predict(x), expected, rtol=0, atol=0)
