"""GPActorCriticPolicy with PPO and A2C: spaces, training, values, save/load, determinism."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import explained_variance
from stable_baselines3.common.vec_env import SubprocVecEnv

from sb3_geogp import GPActorCriticPolicy, GPValueCallback, RBFKernel

ALGOS = [PPO, A2C]
KERNELS = ["geodesic", "rbf"]
ENVS = {"box": "Pendulum-v1", "discrete": "CartPole-v1"}


def algo_kwargs(algo: type[BaseAlgorithm], n_envs: int) -> dict[str, Any]:
    """Small rollouts: 128 points per rollout whatever the number of envs."""
    n_steps = 128 // n_envs
    if algo is PPO:
        return dict(n_steps=n_steps, batch_size=64, n_epochs=2)
    return dict(n_steps=n_steps)


def make_model(
    algo: type[BaseAlgorithm],
    env_id: str = "Pendulum-v1",
    kernel: str = "geodesic",
    n_envs: int = 1,
    seed: int = 0,
    **gp_kwargs: Any,
) -> BaseAlgorithm:
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
    gp = dict(kernel=kernel, max_basis=64, **gp_kwargs)
    return algo(
        GPActorCriticPolicy,
        env,
        policy_kwargs=dict(gp_kwargs=gp),
        seed=seed,
        **algo_kwargs(algo, n_envs),
    )


def flat_obs(model: BaseAlgorithm) -> th.Tensor:
    buf = model.rollout_buffer
    return th.as_tensor(buf.observations.reshape(-1, *buf.obs_shape))


def visited_observations(env_id: str, n: int) -> th.Tensor:
    """``n`` observations of a random-action trajectory, shape (n, *obs_shape)."""
    env = gym.make(env_id)
    obs, _ = env.reset(seed=123)
    env.action_space.seed(123)
    out = []
    for _ in range(n):
        out.append(obs)
        obs, *_ = env.step(env.action_space.sample())
    return th.as_tensor(np.stack(out), dtype=th.float32)


class ValueProbe(BaseCallback):
    """Records the critic's values on fixed probe observations after every rollout."""

    def __init__(self, probe: th.Tensor) -> None:
        super().__init__()
        self.probe = probe
        self.values: list[np.ndarray] = []
        self.ev_before: list[float] = []
        self.changes: list[tuple[np.ndarray, th.Tensor]] = []

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self.ev_before.append(self.logger.name_to_value.get("gp/explained_variance", np.nan))
        # The rollout's values as collected (before the update) and after the update.
        buf = self.model.rollout_buffer
        self.changes.append(
            (buf.values.ravel().copy(), self.model.policy.predict_values(flat_obs(self.model)))
        )
        self.values.append(self.model.policy.predict_values(self.probe).numpy().copy())


# ------------------------------------------------------------------------------------------------
# Learning, over the full matrix
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("n_envs", [1, 4])
@pytest.mark.parametrize("action", ["box", "discrete"])
@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("algo", ALGOS)
def test_learn_values_change_and_explain_returns(
    algo: type[BaseAlgorithm], kernel: str, action: str, n_envs: int
) -> None:
    # A2C's returns bootstrap from the critic over short rollouts, so they shift from one
    # rollout to the next; without forgetting the GP averages them all (see docs/usage.md).
    forgetting = 1.0 if algo is PPO else 0.9
    model = make_model(algo, ENVS[action], kernel, n_envs, forgetting=forgetting)
    policy = model.policy
    assert isinstance(policy, GPActorCriticPolicy)
    probe = visited_observations(ENVS[action], 8)
    assert th.equal(policy.predict_values(probe), th.zeros(8, 1))  # empty GP: prior mean 0
    values = ValueProbe(probe)
    model.learn(4 * 128, callback=CallbackList([GPValueCallback(), values]))

    assert len(values.values) == 4
    assert all(np.isfinite(v).all() for v in values.values)
    assert not np.allclose(values.values[0], 0.0)
    for before, after in values.changes:
        assert th.isfinite(after).all()
        assert not np.allclose(before, after.numpy().ravel()), "values did not change in update"
    assert policy.gp.n_basis > 0
    # The critic explains the returns it was fed on the last rollout.
    pred = policy.predict_values(flat_obs(model)).numpy().ravel()
    ev = explained_variance(pred, model.rollout_buffer.returns.ravel())
    assert ev > 0.2, f"explained variance of the fed returns is {ev:.3f}"
    assert ev > values.ev_before[-1], "absorbing the rollout did not improve the fit"


# ------------------------------------------------------------------------------------------------
# The policy as SB3 sees it
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("algo", ALGOS)
def test_optimizer_holds_only_actor_parameters(algo: type[BaseAlgorithm]) -> None:
    model = make_model(algo)
    policy = model.policy
    expected = th.optim.Adam if algo is PPO else th.optim.RMSprop
    assert type(policy.optimizer) is expected
    opt_params = {id(p) for group in policy.optimizer.param_groups for p in group["params"]}
    assert opt_params == {id(p) for p in policy.parameters()}
    assert list(policy.value_net.parameters()) == []
    assert policy.net_arch == dict(pi=[64, 64], vf=[])
    assert len(policy.gp.state_dict()) > 0  # the GP state is buffers


@pytest.mark.parametrize("algo", ALGOS)
def test_values_are_float32_column_on_policy_device(algo: type[BaseAlgorithm]) -> None:
    model = make_model(algo)
    model.learn(128, callback=GPValueCallback())
    policy = model.policy
    obs = th.as_tensor(model.observation_space.sample()[None])
    for batch in (obs, flat_obs(model)):
        values = policy.predict_values(batch)
        assert values.shape == (batch.shape[0], 1)
        assert values.dtype == th.float32
        assert values.device == policy.device
    actions, values, log_prob = policy(flat_obs(model)[:5])
    assert values.shape == (5, 1) and values.dtype == th.float32
    policy.set_training_mode(False)
    values, log_prob, _entropy = policy.evaluate_actions(flat_obs(model)[:5], actions)
    assert values.shape == (5, 1) and not values.requires_grad
    assert log_prob.requires_grad
    policy.set_training_mode(True)
    assert policy.training and policy.gp.training
    policy.to("cpu")
    assert policy.gp.alpha.device.type == "cpu"


def test_policy_kwargs_options_reach_the_gp_and_constructor_parameters() -> None:
    gp_kwargs = dict(
        kernel="geodesic",
        kernel_kwargs=dict(attach="nearest", n_neighbors=2),
        max_basis=32,
        noise_var=0.1,
        forgetting=0.9,
        dtype="float32",
    )
    model = PPO(
        GPActorCriticPolicy,
        "Pendulum-v1",
        n_steps=64,
        batch_size=64,
        policy_kwargs=dict(gp_kwargs=gp_kwargs, net_arch=[32]),
    )
    gp = model.policy.gp
    assert gp.max_basis == 32 and gp.forgetting == 0.9 and gp.alpha.dtype == th.float32
    assert gp.kernel.attach == "nearest" and gp.kernel.n_neighbors == 2
    assert float(gp.noise_var) == pytest.approx(0.1)
    assert model.policy.net_arch == dict(pi=[32], vf=[])
    assert model.policy._get_constructor_parameters()["gp_kwargs"] == gp_kwargs


def test_separate_critic_features_extractor() -> None:
    model = PPO(
        GPActorCriticPolicy,
        "Pendulum-v1",
        n_steps=64,
        batch_size=64,
        n_epochs=1,
        policy_kwargs=dict(share_features_extractor=False, gp_kwargs=dict(max_basis=16)),
    )
    model.learn(128, callback=GPValueCallback())
    obs = flat_obs(model)
    assert model.policy.critic_features(obs).shape == (64, 3)
    values = model.policy.predict_values(obs)
    assert values.shape == (64, 1) and th.isfinite(values).all()


def test_kernel_instance_is_copied_per_policy() -> None:
    kernel = RBFKernel(lengthscale=0.5)
    kwargs = dict(policy_kwargs=dict(gp_kwargs=dict(kernel=kernel)), n_steps=64, batch_size=64)
    a = PPO(GPActorCriticPolicy, "Pendulum-v1", **kwargs)
    b = PPO(GPActorCriticPolicy, "Pendulum-v1", **kwargs)
    assert a.policy.gp.kernel is not b.policy.gp.kernel
    assert a.policy.gp.kernel is not kernel
    assert th.allclose(a.policy.gp.lengthscale, th.full((3,), 0.5, dtype=th.float64))


class _ShapedEnv(gym.Env[np.ndarray, Any]):
    """(2, 3)-shaped Box observations, any action space; reward favours small observations."""

    def __init__(self, action_space: spaces.Space) -> None:
        self.observation_space = spaces.Box(-1.0, 1.0, shape=(2, 3), dtype=np.float32)
        self.action_space = action_space
        self._t = 0

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self._t = 0
        return self.observation_space.sample(), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._t += 1
        obs = self.np_random.uniform(-1, 1, size=(2, 3)).astype(np.float32)
        return obs, float(-np.abs(obs).sum()), False, self._t >= 20, {}


@pytest.mark.parametrize(
    "action_space",
    [spaces.MultiDiscrete([3, 2]), spaces.MultiBinary(3), spaces.Box(-1, 1, (2,))],
    ids=["multidiscrete", "multibinary", "box"],
)
@pytest.mark.parametrize("algo", ALGOS)
def test_multidim_observations_and_other_action_spaces(
    algo: type[BaseAlgorithm], action_space: spaces.Space
) -> None:
    env = make_vec_env(lambda: _ShapedEnv(action_space), n_envs=2, seed=0)
    model = algo(
        GPActorCriticPolicy,
        env,
        policy_kwargs=dict(gp_kwargs=dict(kernel="rbf", max_basis=32)),
        seed=0,
        **algo_kwargs(algo, 2),
    )
    assert model.policy.gp.input_dim == 6
    model.learn(256, callback=GPValueCallback())
    values = model.policy.predict_values(flat_obs(model))
    assert values.shape == (128, 1) and th.isfinite(values).all()


# ------------------------------------------------------------------------------------------------
# Errors
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("algo", ALGOS)
def test_learn_without_callback_raises_naming_the_callback(algo: type[BaseAlgorithm]) -> None:
    model = make_model(algo)
    with pytest.raises(RuntimeError, match="GPValueCallback"):
        model.learn(256)
    # Other callbacks alone do not count.
    model = make_model(algo)
    with pytest.raises(RuntimeError, match="GPValueCallback"):
        model.learn(256, callback=ValueProbe(th.zeros(1, 3)))


def test_fed_then_unfed_rollout_raises() -> None:
    model = make_model(PPO)
    model.learn(128, callback=GPValueCallback())
    with pytest.raises(RuntimeError, match="GPValueCallback"):
        model.learn(128, reset_num_timesteps=False)


_IMAGE = spaces.Box(0, 255, shape=(32, 32, 3), dtype=np.uint8)
_BOX = spaces.Box(-1, 1, shape=(3,))


@pytest.mark.parametrize(
    ("obs_space", "action_space", "match"),
    [
        (spaces.Dict({"a": _BOX}), spaces.Discrete(2), "Dict observation"),
        (_IMAGE, spaces.Discrete(2), "image observation"),
        (spaces.Discrete(4), spaces.Discrete(2), "supports Box observations"),
        (_BOX, spaces.Tuple([spaces.Discrete(2)]), "action space"),
    ],
    ids=["dict-obs", "image-obs", "discrete-obs", "tuple-action"],
)
def test_unsupported_spaces_raise(
    obs_space: spaces.Space, action_space: spaces.Space, match: str
) -> None:
    with pytest.raises(ValueError, match=match):
        GPActorCriticPolicy(obs_space, action_space, lambda _: 1e-3)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(net_arch=dict(pi=[8], vf=[8])), "vf"),
        (dict(gp_kwargs=dict(input_dim=3)), "input_dim"),
        (dict(gp_kwargs=dict(dtype="float")), "float"),  # torch.float is float32: accepted
        (dict(gp_kwargs=dict(dtype="banana")), "banana"),
        (dict(gp_kwargs=dict(kernel="matern")), "kernel"),
        (dict(gp_kwargs=dict(max_basis=0)), "max_basis"),
    ],
)
def test_bad_options_raise(kwargs: dict[str, Any], match: str) -> None:
    if kwargs.get("gp_kwargs", {}).get("dtype") == "float":
        policy = GPActorCriticPolicy(_BOX, spaces.Discrete(2), lambda _: 1e-3, **kwargs)
        assert policy.gp.alpha.dtype == th.float32
        return
    with pytest.raises(ValueError, match=match):
        GPActorCriticPolicy(_BOX, spaces.Discrete(2), lambda _: 1e-3, **kwargs)


# ------------------------------------------------------------------------------------------------
# Save / load, determinism
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("algo", ALGOS)
def test_save_load_is_exact_and_training_continues(
    algo: type[BaseAlgorithm], kernel: str, tmp_path: Path
) -> None:
    model = make_model(algo, kernel=kernel, n_envs=2)
    model.learn(256, callback=GPValueCallback())
    obs = flat_obs(model)
    expected = model.policy.predict_values(obs)
    assert not th.equal(expected, th.zeros_like(expected))

    model.save(tmp_path / "model.zip")
    with zipfile.ZipFile(tmp_path / "model.zip") as archive, archive.open("policy.pth") as f:
        # tensors and the GP's stored options (plain dicts): SB3's weights_only loading works
        state = th.load(io.BytesIO(f.read()), weights_only=True)
    assert any(key.startswith("value_net.gp.") for key in state)
    loaded = algo.load(tmp_path / "model.zip", env=make_vec_env("Pendulum-v1", n_envs=2))
    assert isinstance(loaded.policy, GPActorCriticPolicy)
    assert th.equal(loaded.policy.predict_values(obs), expected)
    assert loaded.policy.gp.n_basis == model.policy.gp.n_basis
    assert loaded.policy.gp_kwargs == model.policy.gp_kwargs
    for name, value in model.policy.state_dict().items():
        other = loaded.policy.state_dict()[name]
        assert th.equal(other, value) if isinstance(value, th.Tensor) else other == value, name

    model.policy.save(str(tmp_path / "policy.pth"))
    policy = GPActorCriticPolicy.load(str(tmp_path / "policy.pth"))
    assert th.equal(policy.predict_values(obs), expected)

    seen = int(loaded.policy.gp.n_seen)
    loaded.learn(256, callback=GPValueCallback(), reset_num_timesteps=False)
    assert int(loaded.policy.gp.n_seen) == seen + 256
    assert not th.equal(loaded.policy.predict_values(obs), expected)


@pytest.mark.parametrize("algo", ALGOS)
def test_same_seed_same_results(algo: type[BaseAlgorithm]) -> None:
    runs = []
    for _ in range(2):
        model = make_model(algo, n_envs=2, seed=3)
        model.learn(384, callback=GPValueCallback())
        runs.append((model.policy.state_dict(), model.policy.predict_values(flat_obs(model))))
    (state_a, values_a), (state_b, values_b) = runs
    assert th.equal(values_a, values_b)
    assert state_a.keys() == state_b.keys()
    for name, a in state_a.items():
        b = state_b[name]
        assert th.equal(a, b) if isinstance(a, th.Tensor) else a == b, name


@pytest.mark.slow
def test_subproc_vec_env() -> None:
    env = make_vec_env("Pendulum-v1", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv)
    try:
        model = PPO(
            GPActorCriticPolicy,
            env,
            policy_kwargs=dict(gp_kwargs=dict(max_basis=32)),
            seed=0,
            **algo_kwargs(PPO, 2),
        )
        model.learn(256, callback=GPValueCallback())
        assert model.policy.gp.n_basis > 0
        assert th.isfinite(model.policy.predict_values(flat_obs(model))).all()
    finally:
        env.close()


def test_bounded_observations_set_the_lengthscale_before_any_data() -> None:
    """The std of a uniform on the bounds where bounded; NaN (chosen from data) elsewhere."""
    env = _ShapedEnv(spaces.Discrete(2))
    low, high = env.observation_space.low.ravel(), env.observation_space.high.ravel()
    expected = (high.astype(np.float64) - low) / np.sqrt(12)
    model = PPO(GPActorCriticPolicy, env, n_steps=64, batch_size=64)
    np.testing.assert_allclose(model.policy.gp.lengthscale.numpy(), expected, rtol=1e-12)
