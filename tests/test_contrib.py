"""sb3-contrib: TRPO with GPActorCriticPolicy, MaskablePPO with MaskableGPActorCriticPolicy."""

from __future__ import annotations

import re
import subprocess
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces

pytest.importorskip("sb3_contrib")

from sb3_contrib import ARS, QRDQN, TQC, TRPO, CrossQ, MaskablePPO, RecurrentPPO
from sb3_contrib.common.envs import InvalidActionEnvDiscrete
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import (
    GPActorCriticPolicy,
    GPValueCallback,
    LaplacianKernel,
    MaskableGPActorCriticPolicy,
)
from sb3_geogp.callbacks import default_feed
from sb3_geogp.policies import SUPPORTED_ALGORITHMS
from tests.test_policies import assert_actor_normalised_between_rollouts

UNSUPPORTED = re.escape(SUPPORTED_ALGORITHMS)

#: What sb3-contrib's TRPO logs with n_critic_updates=0: numpy's mean of an empty list.
EMPTY_VALUE_LOSSES = ("Mean of empty slice", "invalid value encountered in scalar divide")


class MaskedOneHot(gym.ObservationWrapper[np.ndarray, int, int]):
    """sb3-contrib's InvalidActionEnvDiscrete with one-hot Box observations.

    The state is one of ``dim`` values; the reward is 1 for the action equal to it. At every
    step ``n_invalid`` other actions are masked out; ``invalid_taken`` counts the steps that
    took one of them anyway.
    """

    def __init__(self, dim: int = 6, n_invalid: int = 3) -> None:
        super().__init__(InvalidActionEnvDiscrete(dim, ep_length=20, n_invalid_actions=n_invalid))
        self.observation_space = spaces.Box(0.0, 1.0, shape=(dim,), dtype=np.float32)
        self.invalid_taken = 0

    def observation(self, observation: int) -> np.ndarray:
        return np.eye(self.observation_space.shape[0], dtype=np.float32)[observation]

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        inner = self.env.unwrapped
        assert isinstance(inner, InvalidActionEnvDiscrete)
        self.invalid_taken += int(action in inner.invalid_actions)
        obs, reward, terminated, truncated, info = super().step(action)
        return obs, float(reward), terminated, truncated, info

    def action_masks(self) -> list[bool]:
        inner = self.env.unwrapped
        assert isinstance(inner, InvalidActionEnvDiscrete)
        return inner.action_masks()


def maskable_model(seed: int = 0, env_fn: Callable[[], gym.Env] = MaskedOneHot) -> MaskablePPO:
    env = make_vec_env(env_fn, n_envs=2, seed=seed)
    return MaskablePPO(
        MaskableGPActorCriticPolicy,
        env,
        n_steps=64,
        batch_size=64,
        n_epochs=2,
        seed=seed,
        policy_kwargs=dict(gp_kwargs=dict(kernel="rbf", max_basis=32)),
    )


def actor_params(model: BaseAlgorithm) -> dict[str, th.Tensor]:
    return {k: v.detach().clone() for k, v in model.policy.named_parameters()}


# ------------------------------------------------------------------------------------------------
# TRPO
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kernel", ["rbf", "geodesic", None])
def test_trpo_trains_the_actor_and_feeds_the_gp(kernel: str | None) -> None:
    env = make_vec_env("Pendulum-v1", n_envs=2, seed=0)
    named = {} if kernel is None else {"kernel": kernel}
    model = TRPO(
        GPActorCriticPolicy,
        env,
        n_steps=64,
        seed=0,
        policy_kwargs=dict(gp_kwargs=dict(max_basis=32, **named)),
    )
    if kernel is None:  # TRPO is no A2C: the default kernel is the Laplacian one
        assert isinstance(model.policy.gp.kernel, LaplacianKernel)
    # TRPO skips parameters named "value" in its actor step: none of the actor's is.
    assert not any("value" in name for name, _ in model.policy.named_parameters())
    before = actor_params(model)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        model.learn(4 * 128, callback=GPValueCallback())
    assert model.n_critic_updates == 0  # the GP learns in the callback instead
    assert {str(w.message) for w in record} <= set(EMPTY_VALUE_LOSSES)
    # TRPO's default target, Monte Carlo returns: each env's one completed 200-step episode.
    assert model.policy.gp.n_basis > 0 and int(model.policy.gp.n_seen) == 2 * 200
    assert np.isnan(model.logger.name_to_value["train/value_loss"])
    after = actor_params(model)
    assert any(not th.equal(after[k], before[k]) for k in before), "the actor did not move"
    obs = th.as_tensor(model.rollout_buffer.observations.reshape(-1, 3))
    values = model.policy.predict_values(obs)
    assert values.shape == (128, 1) and th.isfinite(values).all()
    assert not th.equal(values, th.zeros_like(values))


@pytest.mark.parametrize("algo", [TRPO, MaskablePPO])
def test_the_ppo_familys_default_feed_is_ppos(algo: type[BaseAlgorithm]) -> None:
    """TRPO and MaskablePPO get PPO's default feed: Monte Carlo returns, cut after 200 steps
    where ``gamma ** 200 >= 0.5``."""
    for gamma, horizon in ((0.9999, 200), (0.99, None)):
        assert default_feed(algo, gamma) == default_feed(PPO, gamma) == ("monte_carlo", horizon)


def test_trpo_without_the_callback_names_it() -> None:
    model = TRPO(GPActorCriticPolicy, "Pendulum-v1", n_steps=64, batch_size=64, seed=0)
    with pytest.raises(RuntimeError, match="GPValueCallback"):
        model.learn(64)


# ------------------------------------------------------------------------------------------------
# MaskablePPO
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "callback_kwargs",
    [dict(target="returns"), {}, dict(target="monte_carlo", recompute_advantages=True)],
    ids=["returns", "default", "monte-carlo-recomputed"],
)
def test_maskable_ppo_trains_within_the_masks_and_feeds_the_gp(
    callback_kwargs: dict[str, Any],
) -> None:
    model = maskable_model()
    before = actor_params(model)
    model.learn(3 * 128, callback=GPValueCallback(**callback_kwargs))
    policy = model.policy
    assert isinstance(policy, MaskableGPActorCriticPolicy)
    # Monte Carlo targets (MaskablePPO's default): only completed episodes (of 20 steps) are fed.
    n_fed = 3 * 128 if callback_kwargs.get("target") == "returns" else 3 * 120
    assert policy.gp.n_basis > 0 and int(policy.gp.n_seen) == n_fed
    after = actor_params(model)
    assert any(not th.equal(after[k], before[k]) for k in before), "the actor did not move"
    assert model.env.get_attr("invalid_taken") == [0, 0]
    obs = th.as_tensor(np.eye(6, dtype=np.float32))
    values = policy.predict_values(obs)
    assert values.shape == (6, 1) and th.isfinite(values).all()
    assert not th.equal(values, th.zeros_like(values))


def test_maskable_ppo_on_discrete_observations_trains_as_on_their_one_hot_box() -> None:
    """sb3-contrib's env with its own Discrete observations and with the hand-made one-hot Box
    of MaskedOneHot: the same run, bit for bit."""

    def trained(env_fn: Callable[[], gym.Env]) -> MaskablePPO:
        # Built and trained in turn: building a model seeds the global generators.
        return maskable_model(env_fn=env_fn).learn(2 * 128, callback=GPValueCallback())

    raw = trained(lambda: InvalidActionEnvDiscrete(6, ep_length=20, n_invalid_actions=3))
    one_hot = trained(MaskedOneHot)
    assert isinstance(raw.observation_space, spaces.Discrete)
    assert int(raw.policy.gp.n_seen) == 2 * 120
    values = raw.policy.predict_values(th.arange(6)[:, None])
    assert th.equal(values, one_hot.policy.predict_values(th.eye(6)))
    for name, value in actor_params(raw).items():
        assert th.equal(value, actor_params(one_hot)[name]), name


@pytest.mark.parametrize("target", ["returns", None])
def test_maskable_deferred_values_equal_step_by_step(target: str | None) -> None:
    """MaskablePPO bootstraps each rollout with its own ``predict_values`` but, unlike SB3's
    algorithms, does not hand it to ``on_rollout_end``: the deferred path must still give the
    buffer, actor and GP of sb3-contrib's step-by-step values (20-step episodes run on at the
    end of every 64-step rollout, so the bootstrap counts)."""

    def run(deferred: bool) -> MaskablePPO:
        model = maskable_model()
        model.learn(4 * 128, callback=GPValueCallback(target=target, deferred_values=deferred))
        return model

    deferred, stepwise = run(True), run(False)
    for name in ("values", "returns", "advantages"):
        a, b = (getattr(m.rollout_buffer, name) for m in (deferred, stepwise))
        np.testing.assert_array_equal(a, b, err_msg=name)
    a, b = actor_params(deferred), actor_params(stepwise)
    assert all(th.equal(a[k], b[k]) for k in a)
    obs = th.as_tensor(np.eye(6, dtype=np.float32))
    assert th.equal(deferred.policy.predict_values(obs), stepwise.policy.predict_values(obs))


def test_maskable_ppo_without_the_callback_names_it() -> None:
    with pytest.raises(RuntimeError, match="GPValueCallback"):
        maskable_model().learn(64)


def test_maskable_save_load_is_exact(tmp_path: Path) -> None:
    model = maskable_model()
    model.learn(128, callback=GPValueCallback())
    obs = th.as_tensor(np.eye(6, dtype=np.float32))
    masks = np.ones((6, 6), dtype=bool)
    masks[:, 0] = False
    expected_values = model.policy.predict_values(obs)
    expected_actions, _ = model.predict(obs.numpy(), deterministic=True, action_masks=masks)
    assert not (expected_actions == 0).any()
    model.save(tmp_path / "model.zip")
    loaded = MaskablePPO.load(tmp_path / "model.zip", env=make_vec_env(MaskedOneHot, n_envs=2))
    assert isinstance(loaded.policy, MaskableGPActorCriticPolicy)
    assert th.equal(loaded.policy.predict_values(obs), expected_values)
    actions, _ = loaded.predict(obs.numpy(), deterministic=True, action_masks=masks)
    np.testing.assert_array_equal(actions, expected_actions)
    assert loaded.policy.gp_kwargs == model.policy.gp_kwargs
    loaded.learn(128, callback=GPValueCallback(), reset_num_timesteps=False)  # and it trains on
    # MaskablePPO's default target, Monte Carlo returns: each call's 64 steps per env complete
    # three 20-step episodes (an episode open at the end of a call is not fed).
    assert int(loaded.policy.gp.n_seen) == 2 * (2 * 3 * 20)


def test_maskable_actor_starts_as_maskable_mlp_policy() -> None:
    def build(policy: Any, **policy_kwargs: Any) -> MaskablePPO:
        env = make_vec_env(MaskedOneHot, n_envs=2, seed=3)
        return MaskablePPO(policy, env, n_steps=64, seed=3, policy_kwargs=policy_kwargs)

    mlp = build("MlpPolicy")
    gp = build(MaskableGPActorCriticPolicy, gp_kwargs=dict(kernel="rbf"))
    critic = ("mlp_extractor.value_net.", "value_net.")
    state = gp.policy.state_dict()
    for name, tensor in mlp.policy.state_dict().items():
        if not name.startswith(critic):
            assert th.equal(state[name], tensor), name


# ------------------------------------------------------------------------------------------------
# What is not supported
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("algo", "env_id", "policy"),
    [
        (RecurrentPPO, "Pendulum-v1", GPActorCriticPolicy),
        (SAC, "Pendulum-v1", GPActorCriticPolicy),
        (TQC, "Pendulum-v1", GPActorCriticPolicy),
        (CrossQ, "Pendulum-v1", GPActorCriticPolicy),
        (ARS, "Pendulum-v1", GPActorCriticPolicy),  # builds its policy without lr_schedule
        (QRDQN, "CartPole-v1", GPActorCriticPolicy),
        (MaskablePPO, "CartPole-v1", GPActorCriticPolicy),
        (PPO, "CartPole-v1", MaskableGPActorCriticPolicy),
        (TRPO, "CartPole-v1", MaskableGPActorCriticPolicy),
        (RecurrentPPO, "CartPole-v1", MaskableGPActorCriticPolicy),
    ],
    ids=lambda x: getattr(x, "__name__", x),
)
def test_other_algorithms_raise_at_construction(
    algo: type[BaseAlgorithm], env_id: str, policy: type
) -> None:
    with pytest.raises(TypeError, match=UNSUPPORTED) as error:
        algo(policy, env_id)
    assert str(error.value).startswith(f"{algo.__name__} cannot train a {policy.__name__}")


def test_callback_checks_the_algorithm_too() -> None:
    """A GP policy put into a model after its construction meets the same check in learn."""
    model = MaskablePPO("MlpPolicy", make_vec_env(MaskedOneHot, n_envs=1), n_steps=64)
    model.policy = GPActorCriticPolicy(model.observation_space, model.action_space, lambda _: 1e-3)
    with pytest.raises(TypeError, match=UNSUPPORTED):
        model.learn(64, callback=GPValueCallback())


@pytest.mark.parametrize("algo", [TRPO, MaskablePPO])
def test_the_actor_is_normalised_between_rollouts(algo: type[BaseAlgorithm]) -> None:
    """``normalize_actor_obs`` under TRPO and MaskablePPO, as under PPO and A2C
    (tests/test_policies.py): MaskablePPO's log-probabilities under the rollout's masks."""
    kwargs = dict(normalize_actor_obs=True, gp_kwargs=dict(kernel="rbf", max_basis=32))
    if algo is MaskablePPO:
        env = make_vec_env(MaskedOneHot, n_envs=2, seed=0)
        model = algo(MaskableGPActorCriticPolicy, env, n_steps=64, batch_size=64, n_epochs=2,
                     seed=0, policy_kwargs=kwargs)  # fmt: skip
    else:
        env = make_vec_env("Pendulum-v1", n_envs=2, seed=0)
        model = algo(GPActorCriticPolicy, env, n_steps=64, seed=0, policy_kwargs=kwargs)
    assert_actor_normalised_between_rollouts(model, n_rollouts=3, rollout=128)


def test_sb3_geogp_imports_without_sb3_contrib() -> None:
    code = (
        "import sys, sb3_geogp, sb3_geogp.policies, sb3_geogp.callbacks\n"
        "from sb3_geogp import GPActorCriticPolicy, GPValueCallback\n"
        "assert 'sb3_contrib' not in sys.modules\n"
        "import sb3_geogp.contrib\n"
        "assert sb3_geogp.MaskableGPActorCriticPolicy is "
        "sb3_geogp.contrib.MaskableGPActorCriticPolicy\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr


def test_maskable_drift_is_the_kl_of_the_masked_distributions() -> None:
    """Under MaskablePPO the actor's drift compares the masked action distributions: masked
    actions carry no probability, and the rest renormalise (numpy's KL of those)."""
    env = InvalidActionEnvDiscrete(dim=6, n_invalid_actions=3)
    model = MaskablePPO(
        MaskableGPActorCriticPolicy,
        env,
        n_steps=32,
        seed=0,
        device="cpu",
        policy_kwargs=dict(gp_kwargs=dict(drift_forgetting=1.0)),
    )
    rng = np.random.default_rng(0)
    obs = rng.integers(6, size=(20, 1)).astype(np.float32)
    masks = rng.uniform(size=(20, 6)) < 0.6
    masks[:, 0] = True  # at least one allowed action per state

    def probs() -> np.ndarray:
        logits = model.policy.get_distribution(th.as_tensor(obs)).distribution.logits
        p = np.exp(logits.detach().numpy().astype(np.float64)) * masks
        return p / p.sum(axis=1, keepdims=True)

    model.policy.measure_drift(obs, masks)
    before = probs()
    with th.no_grad():
        model.policy.action_net.bias += th.linspace(-1.0, 1.0, 6)
    after = probs()
    allowed = before > 0
    expected = np.mean(np.sum(np.where(allowed, before * np.log(before / after), 0.0), axis=1))
    assert expected > 0.05
    assert model.policy.measure_drift(obs, masks) == pytest.approx(expected, rel=1e-4)
