"""GPValueCallback: feeding layout, target maths on a scripted env, timing, logging, errors."""

from __future__ import annotations

import re
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from gymnasium.wrappers import TimeLimit
from stable_baselines3 import A2C, PPO, SAC
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, VecFrameStack, VecNormalize

from sb3_geogp import GPActorCriticPolicy, GPCriticWarning, GPValueCallback, callbacks
from sb3_geogp.callbacks import (
    CUT_WEIGHT,
    DEFAULT_HORIZON,
    DEFAULT_TARGET,
    Target,
    default_feed,
    default_target,
)
from sb3_geogp.defaults import BoundsCoverage, bounds_lengthscale
from sb3_geogp.policies import SUPPORTED_ALGORITHMS
from sb3_geogp.targets import (
    discounted_returns,
    horizon_bootstraps,
    horizon_returns,
    per_env,
    split_completed,
)
from tests.test_sparse_gp import assert_same_state, snapshot

GAMMA = 0.9
PRIOR = 10.0  # target_mean: what the (unfed) GP predicts everywhere


class ScriptedEnv(gym.Env[np.ndarray, int]):
    """Deterministic episodes: observation ``[env_id, episode, t]``, reward ``1 + t``.

    With ``terminate_at`` the episode terminates after that many steps; otherwise it runs
    until a ``TimeLimit`` wrapper truncates it.
    """

    def __init__(self, env_id: int, terminate_at: int | None) -> None:
        self.observation_space = spaces.Box(0.0, 1e6, shape=(3,), dtype=np.float32)
        self.action_space = spaces.Discrete(2)
        self.env_id = env_id
        self.terminate_at = terminate_at
        self.episode = -1
        self.t = 0

    def _obs(self) -> np.ndarray:
        return np.array([self.env_id, self.episode, self.t], dtype=np.float32)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.episode += 1
        self.t = 0
        return self._obs(), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        reward = 1.0 + self.t
        self.t += 1
        terminated = self.terminate_at is not None and self.t >= self.terminate_at
        return self._obs(), reward, terminated, False, {}


def scripted_vec_env() -> DummyVecEnv:
    """Env 0 terminates after 3 steps; env 1 is truncated by a time limit after 5."""
    return DummyVecEnv(
        [lambda: ScriptedEnv(0, 3), lambda: TimeLimit(ScriptedEnv(1, None), max_episode_steps=5)]
    )


def expected_monte_carlo(env_id: int, t: int) -> float:
    """Hand-computed target of step ``t``: env 0 terminates, env 1 bootstraps at truncation."""
    if env_id == 0:
        return sum(GAMMA ** (k - t) * (1 + k) for k in range(t, 3))
    return sum(GAMMA ** (k - t) * (1 + k) for k in range(t, 5)) + GAMMA ** (5 - t) * PRIOR


def make_scripted(
    algo: type[BaseAlgorithm] = PPO, n_steps: int = 4, gamma: float = GAMMA
) -> BaseAlgorithm:
    kwargs: dict[str, Any] = dict(n_steps=n_steps, gamma=gamma, gae_lambda=1.0, seed=0)
    if algo is PPO:
        kwargs.update(batch_size=2 * n_steps, n_epochs=1)
    return algo(
        GPActorCriticPolicy,
        scripted_vec_env(),
        policy_kwargs=dict(gp_kwargs=dict(kernel="rbf", max_basis=16, target_mean=PRIOR)),
        **kwargs,
    )


class FeedRecorder:
    """Replaces ``policy.update_critic``: records every batch; optionally keeps the GP empty."""

    def __init__(self, policy: GPActorCriticPolicy, keep_empty: bool) -> None:
        self.original = policy.update_critic
        self.keep_empty = keep_empty
        self.batches: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        policy.update_critic = self  # type: ignore[method-assign]

    def __call__(
        self,
        obs: np.ndarray,
        targets: np.ndarray,
        starts: np.ndarray,
        values: Any = None,
        drift: float = 0.0,
    ) -> dict[str, float]:
        self.batches.append((np.array(obs), np.array(targets), np.array(starts)))
        n = 0 if self.keep_empty else len(targets)
        return self.original(
            obs[:n], targets[:n], starts[:n], None if values is None else values[:n], drift
        )


class BufferRecorder(BaseCallback):
    """Copies the rollout buffer at rollout end (run it after GPValueCallback)."""

    def __init__(self) -> None:
        super().__init__()
        self.rollouts: list[dict[str, np.ndarray]] = []
        self.logged: list[dict[str, Any]] = []

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        buf = self.model.rollout_buffer
        self.rollouts.append(
            {
                name: getattr(buf, name).copy()
                for name in ("observations", "rewards", "returns", "values", "advantages")
            }
            | {"episode_starts": buf.episode_starts.copy()}
        )
        self.logged.append(dict(self.logger.name_to_value))


class ProbeRecorder(BaseCallback):
    """The critic's values of fixed states at every rollout end (run it after GPValueCallback)."""

    def __init__(self, probe: th.Tensor) -> None:
        super().__init__()
        self.probe = probe
        self.values: list[np.ndarray] = []

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        with th.no_grad():
            self.values.append(self.model.policy.predict_values(self.probe).numpy()[:, 0])


# ------------------------------------------------------------------------------------------------
# Pure target maths
# ------------------------------------------------------------------------------------------------
def test_discounted_returns_restart_after_episode_ends() -> None:
    rewards = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    ends = np.array([False, True, False, False, True])
    expected = [1 + 0.5 * 2, 2, 3 + 0.5 * 4 + 0.25 * 5, 4 + 0.5 * 5, 5]
    np.testing.assert_allclose(discounted_returns(rewards, ends, 0.5), expected)


@pytest.mark.parametrize("horizon", [1, 2, 3, 50])
def test_horizon_returns_against_a_loop_over_the_window(horizon: int) -> None:
    """Brute force: walk ``H`` steps from ``t``, stop at an episode end, else add
    ``gamma^H V``; with a horizon longer than every episode they are the Monte Carlo returns."""
    rng = np.random.default_rng(horizon)
    n, gamma = 40, 0.9
    rewards = rng.normal(size=n)
    ends = rng.random(n) < 0.15
    ends[-1] = True
    value_of = rng.normal(size=n)  # V of each state
    boots = horizon_bootstraps(ends, horizon, n)
    got = horizon_returns(rewards, ends, gamma, boots, value_of[np.maximum(boots, 0)])
    for t in range(n):
        expected, k = 0.0, 0
        while True:
            expected += gamma**k * rewards[t + k]
            if ends[t + k]:
                assert boots[t] == -1
                break
            k += 1
            if k == horizon:
                assert boots[t] == t + horizon
                expected += gamma**horizon * value_of[t + horizon]
                break
        assert got[t] == pytest.approx(expected, rel=1e-12), t
    if horizon == 50:
        np.testing.assert_allclose(got, discounted_returns(rewards, ends, gamma), rtol=1e-12)


def test_horizon_bootstraps_refuse_steps_without_their_window() -> None:
    ends = np.array([False, False, False])
    np.testing.assert_array_equal(horizon_bootstraps(ends, 2, 1), [2])
    with pytest.raises(ValueError, match="more data"):
        horizon_bootstraps(ends, 2, 2)


def test_split_completed() -> None:
    starts = np.array([True, False, True, False, False])
    ends, n = split_completed(starts, last_done=False)
    np.testing.assert_array_equal(ends, [False, True, False, False, False])
    assert n == 2
    assert split_completed(starts, last_done=True)[1] == 5
    assert split_completed(np.array([False, False]), last_done=False)[1] == 0


def test_per_env_orders_a_rollout_env_by_env() -> None:
    """Against a loop over (env, step): every env's steps in time order, a trajectory start on
    each env's first step and wherever an episode starts."""
    n_steps, n_envs = 3, 2
    obs = np.arange(n_steps * n_envs * 2, dtype=np.float32).reshape(n_steps, n_envs, 2)
    targets = 10.0 * np.arange(n_steps * n_envs).reshape(n_steps, n_envs)
    starts = np.array([[0, 0], [0, 1], [1, 0]], dtype=np.float32)
    x, y, s = per_env(obs, targets, starts)
    order = [(e, t) for e in range(n_envs) for t in range(n_steps)]
    np.testing.assert_array_equal(x, [obs[t, e] for e, t in order])
    np.testing.assert_array_equal(y, [targets[t, e] for e, t in order])
    np.testing.assert_array_equal(s, [t == 0 or starts[t, e] == 1 for e, t in order])
    assert starts[0, 0] == 0  # the input is left as it was


# ------------------------------------------------------------------------------------------------
# Feeding on the scripted env
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("calls", [1, 4])
@pytest.mark.parametrize("algo", [PPO, A2C])
def test_monte_carlo_targets_match_hand_computed_returns(
    algo: type[BaseAlgorithm], calls: int
) -> None:
    """Episodes span rollouts (n_steps=4 < 5); truncation bootstraps, termination does not.
    In ``calls`` learn() calls that continue the environment (``reset_num_timesteps=False``),
    each with its own callback, episodes also span the calls: every step of every completed
    episode is fed exactly once, as in one call."""
    model = make_scripted(algo, n_steps=4)
    recorder = FeedRecorder(model.policy, keep_empty=True)  # V(terminal) stays PRIOR
    for call in range(calls):
        model.learn(
            4 * 8 // calls,
            callback=GPValueCallback(target="monte_carlo"),
            reset_num_timesteps=call == 0,
        )

    fed: dict[int, list[tuple[int, int, float, bool]]] = {0: [], 1: []}
    for obs, targets, starts in recorder.batches:
        for (env_id, episode, t), y, start in zip(obs, targets, starts, strict=True):
            fed[int(env_id)].append((int(episode), int(t), float(y), bool(start)))
    for env_id, length in ((0, 3), (1, 5)):
        rows = fed[env_id]
        n_complete = (32 // 2) // length  # steps per env // episode length
        # Every step of every completed episode exactly once, env by env, in time order.
        assert [(e, t) for e, t, _, _ in rows] == [
            (e, t) for e in range(n_complete) for t in range(length)
        ]
        for _episode, t, y, start in rows:
            assert y == pytest.approx(expected_monte_carlo(env_id, t), rel=1e-6)
            assert start == (t == 0)


def expected_horizon(env_id: int, t: int, horizon: int) -> float:
    """Hand-computed ``horizon``-step target of step ``t`` (the empty GP's value is PRIOR)."""
    length = 3 if env_id == 0 else 5
    rewards = [1.0 + k for k in range(length)]
    if env_id == 1:
        rewards[-1] += GAMMA * PRIOR  # SB3's time-limit bootstrap
    if t + horizon <= length - 1:
        window = sum(GAMMA**k * rewards[t + k] for k in range(horizon))
        return window + GAMMA**horizon * PRIOR
    return sum(GAMMA ** (k - t) * rewards[k] for k in range(t, length))


@pytest.mark.parametrize("horizon", [1, 2, 4])
def test_horizon_targets_match_hand_computed_returns(horizon: int) -> None:
    """Every step once, env by env in time order, as soon as its window has arrived (episodes
    span rollouts: n_steps=4 < 5); the window stops at a termination or truncation."""
    model = make_scripted(A2C, n_steps=4)
    recorder = FeedRecorder(model.policy, keep_empty=True)  # V stays PRIOR
    model.learn(4 * 8, callback=GPValueCallback(target="monte_carlo", horizon=horizon))
    fed: dict[int, list[tuple[int, int, float]]] = {0: [], 1: []}
    for obs, targets, _ in recorder.batches:
        for (env_id, episode, t), y in zip(obs, targets, strict=True):
            fed[int(env_id)].append((int(episode), int(t), float(y)))
    for env_id, length in ((0, 3), (1, 5)):
        steps = [(e, t) for e in range(16 // length + 1) for t in range(length)][:16]
        rows = fed[env_id]
        # All but the last steps whose window is still open, in time order.
        n_open = 0 if 16 % length == 0 else min(horizon, 16 % length)
        assert [(e, t) for e, t, _ in rows] == steps[: 16 - n_open]
        for _episode, t, y in rows:
            assert y == pytest.approx(expected_horizon(env_id, t, horizon), rel=1e-6)


def _fed(
    algo: type[BaseAlgorithm], callback: GPValueCallback, gamma: float = GAMMA
) -> list[np.ndarray]:
    """Targets of every batch ``callback`` feeds a scripted model of ``algo`` with discount
    ``gamma`` (GP kept empty)."""
    model = make_scripted(algo, n_steps=4, gamma=gamma)
    recorder = FeedRecorder(model.policy, keep_empty=True)
    model.learn(4 * 8, callback=callback)
    return [np.concatenate([obs, targets[:, None]], axis=1) for obs, targets, _ in recorder.batches]


def _same_batches(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    """Whether two feeds (:func:`_fed`) are the same batches, value for value."""
    return len(a) == len(b) and all(
        x.shape == y.shape and np.array_equal(x, y) for x, y in zip(a, b, strict=True)
    )


@pytest.mark.parametrize(("algo", "expected"), [(PPO, "monte_carlo"), (A2C, "returns")])
def test_default_target_is_the_algorithms(algo: type[BaseAlgorithm], expected: str) -> None:
    """Unset, the target is the algorithm's default, resolved when training starts: the
    batches fed are those of that target passed explicitly, and not those of the other."""
    callback = GPValueCallback()
    assert callback.target is None
    default = _fed(algo, callback)
    assert callback.target == expected == default_target(algo)
    other = "returns" if expected == "monte_carlo" else "monte_carlo"
    for target, same in ((expected, True), (other, False)):
        explicit = _fed(algo, GPValueCallback(target=target))  # type: ignore[arg-type]
        assert _same_batches(explicit, default) == same, target
    assert default_target(None) == DEFAULT_TARGET == "monte_carlo"


@pytest.mark.parametrize(("gamma", "cut"), [(0.9, True), (0.8, False)])
def test_default_feed_cuts_the_ppo_familys_monte_carlo_returns_where_the_tail_weighs(
    monkeypatch: pytest.MonkeyPatch, gamma: float, cut: bool
) -> None:
    """Unset, PPO's Monte Carlo returns are cut after :data:`DEFAULT_HORIZON` steps where
    ``gamma ** DEFAULT_HORIZON >= CUT_WEIGHT`` (0.5): the batches are those of that horizon
    passed explicitly, else the uncut ones. The horizon is set to 4 here, below the scripted
    episodes' 5 steps: ``0.9 ** 4`` = 0.66 cuts, ``0.8 ** 4`` = 0.41 does not. A2C's returns
    have no horizon."""
    monkeypatch.setattr(callbacks, "DEFAULT_HORIZON", 4)
    callback = GPValueCallback()
    default = _fed(PPO, callback, gamma)
    assert (callback.target, callback.horizon) == ("monte_carlo", 4 if cut else None)
    explicit = _fed(PPO, GPValueCallback(target="monte_carlo", horizon=4), gamma)
    uncut = _fed(PPO, GPValueCallback(target="monte_carlo"), gamma)
    assert _same_batches(default, explicit) == cut and _same_batches(default, uncut) != cut
    a2c = GPValueCallback()
    _fed(A2C, a2c, gamma)
    assert (a2c.target, a2c.horizon) == ("returns", None)


@pytest.mark.parametrize(
    ("gamma", "horizon"),
    # 0.5 ** (1 / 200) = 0.99654: the least gamma whose 200th power weighs 0.5.
    [(0.9999, 200), (0.9966, 200), (0.9965, None), (0.99, None), (0.98, None)],
)
def test_the_default_cut_of_200_steps_needs_gamma_above_0_99654(
    gamma: float, horizon: int | None
) -> None:
    """MountainCarContinuous-v0's zoo ``gamma`` (0.9999) is cut, Acrobot-v1's (0.99) and
    CartPole-v1's (0.98) are not; A2C is fed SB3's returns whatever its discount."""
    assert (DEFAULT_HORIZON, CUT_WEIGHT) == (200, 0.5)
    assert default_feed(PPO, gamma) == ("monte_carlo", horizon)
    assert default_feed(A2C, gamma) == ("returns", None)


@pytest.mark.parametrize(("horizon", "same"), [(5, True), (500, True), (4, False)])
def test_a_horizon_no_episode_reaches_changes_nothing(horizon: int, same: bool) -> None:
    """Cut after at least the longest episode (5 steps here), the Monte Carlo returns are fed
    as uncut ones, in the same batches (docs/results.md, "Monte Carlo returns cut after 500
    steps": the identity that confines ``horizon=500`` to tasks with longer episodes)."""
    uncut = _fed(PPO, GPValueCallback(target="monte_carlo"))
    cut = _fed(PPO, GPValueCallback(target="monte_carlo", horizon=horizon))
    assert _same_batches(cut, uncut) == same


def test_horizon_needs_monte_carlo_and_a_positive_integer() -> None:
    for bad in (0, -1, 2.5):
        with pytest.raises(ValueError, match="horizon"):
            GPValueCallback(target="monte_carlo", horizon=bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="horizon"):
        GPValueCallback(horizon=5)
    assert GPValueCallback(target="monte_carlo", horizon=5.0).horizon == 5  # type: ignore[arg-type]


@pytest.mark.parametrize(("horizon", "wait"), [(None, "ends, and"), (3, "ends or 3 steps have")])
def test_monte_carlo_feeds_nothing_until_an_episode_completes(
    horizon: int | None, wait: str
) -> None:
    """2 steps per env: no episode done and no 3-step window complete; the warning names what
    the steps wait for."""
    model = make_scripted(A2C, n_steps=2)
    recorder = FeedRecorder(model.policy, keep_empty=False)
    with pytest.warns(GPCriticWarning, match=r"nothing in this learn\(\) call \(1 rollout\)") as w:
        model.learn(4, callback=GPValueCallback(target="monte_carlo", horizon=horizon))
    assert any(f"its episode {wait}" in str(r.message) for r in w)
    assert [len(b[1]) for b in recorder.batches] == [0]
    assert model.policy.gp.n_basis == 0
    model.learn(4, callback=GPValueCallback(target="monte_carlo"), reset_num_timesteps=False)


def test_a_discount_assigned_after_building_warns_and_the_targets_keep_sb3s() -> None:
    """SB3 computes returns and advantages with the rollout buffer's gamma, set when the model
    is built: ``model.gamma = 0.5`` afterwards warns, and the terminating env's Monte Carlo
    targets are still discounted by the buffer's ``GAMMA``."""
    model = make_scripted(A2C, n_steps=4)
    model.gamma = 0.5
    recorder = FeedRecorder(model.policy, keep_empty=True)
    with pytest.warns(
        GPCriticWarning, match=f"model.gamma is 0.5 but its rollout buffer's is {GAMMA:g}"
    ):
        model.learn(4 * 8, callback=GPValueCallback(target="monte_carlo"))
    fed = [
        (t, y)
        for obs, targets, _ in recorder.batches
        for (env_id, _, t), y in zip(obs, targets, strict=True)
        if env_id == 0
    ]
    assert len(fed) == 15  # 5 episodes of 3 steps
    for t, y in fed:
        assert y == pytest.approx(expected_monte_carlo(0, int(t)), rel=1e-6)


def test_learning_in_chunks_trains_as_one_learn_call() -> None:
    """PPO's default callback (Monte Carlo returns cut at 200 steps) on CartPole-v1: two
    ``learn()`` calls continuing the environment, each with a new callback, train the actor
    and the GP bit for bit as one call; a call that resets the environment drops the
    unfinished episodes."""

    def model() -> PPO:
        env = make_vec_env("CartPole-v1", n_envs=2, seed=0)
        return PPO(GPActorCriticPolicy, env, n_steps=64, batch_size=64, n_epochs=1, seed=0)

    one = model().learn(256, callback=GPValueCallback())
    chunks = model().learn(128, callback=GPValueCallback())
    left = chunks.policy.unfinished_episodes
    assert sum(len(rewards) for _, rewards, _ in left.pending) > 0  # steps carried over
    chunks.learn(128, callback=GPValueCallback(), reset_num_timesteps=False)
    assert_same_state(one.policy.state_dict(), chunks.policy.state_dict())
    reset = model().learn(128, callback=GPValueCallback())
    reset.learn(128, callback=GPValueCallback())
    assert int(reset.policy.gp.n_seen) < int(one.policy.gp.n_seen)


class StopAt(BaseCallback):
    """Stops ``learn()`` at its ``n``-th step, inside a rollout, as SB3's ``StopTrainingOn...``
    callbacks do."""

    def __init__(self, n: int) -> None:
        super().__init__()
        self.n = n

    def _on_step(self) -> bool:
        return self.n_calls < self.n


@pytest.mark.parametrize("algo", [PPO, A2C])
def test_a_learn_call_stopped_inside_a_rollout_hands_over_no_broken_episode(
    algo: type[BaseAlgorithm],
) -> None:
    """SB3 drops a rollout that a callback stops, and the episodes running then lack its
    steps: the next call continuing the environment feeds, env by env, exactly the completed
    episodes of its own rollouts (brute force from SB3's buffers), its first step a
    trajectory start; and ``forward`` gives the GP's values again after the stop."""
    model = make_scripted(algo, n_steps=4)
    recorder = FeedRecorder(model.policy, keep_empty=True)  # the GP stays at PRIOR
    model.learn(4 * 8, callback=[GPValueCallback(target="monte_carlo"), StopAt(6)])
    assert model.num_timesteps == 2 * 6  # inside the second rollout
    obs = th.tensor([[0.0, 0.0, 1.0]])
    with th.no_grad():
        assert model.policy(obs)[1].item() == pytest.approx(PRIOR)

    before = len(recorder.batches)
    buffers = BufferRecorder()
    model.learn(
        4 * 8, callback=[GPValueCallback(target="monte_carlo"), buffers], reset_num_timesteps=False
    )
    fed = recorder.batches[before:]
    for env in (0, 1):
        stream = {
            name: np.concatenate([r[name][:, env] for r in buffers.rollouts])
            for name in ("observations", "rewards", "episode_starts")
        }
        starts = stream["episode_starts"].astype(bool)
        starts[0] = True
        n = int(np.flatnonzero(starts)[-1])  # the steps of the episodes ended before the last
        expected = np.zeros(n)
        for t in reversed(range(n)):
            ends = starts[t + 1]
            expected[t] = stream["rewards"][t] + (0.0 if ends else GAMMA * expected[t + 1])
        rows = [
            (x, y, start) for b in fed for x, y, start in zip(*b, strict=True) if int(x[0]) == env
        ]
        assert len(rows) >= n
        np.testing.assert_array_equal([x for x, _, _ in rows[:n]], stream["observations"][:n])
        np.testing.assert_allclose([y for _, y, _ in rows[:n]], expected, rtol=1e-6)
        assert [s for _, _, s in rows[:n]] == list(starts[:n])


@pytest.mark.parametrize("target", ["returns", "monte_carlo"])
def test_on_fed_sees_exactly_what_the_gp_was_fed(target: Target) -> None:
    """The hook gets each batch after the GP, as ``update_critic`` got it (env by env)."""

    class Hooked(GPValueCallback):
        def __init__(self) -> None:
            super().__init__(target=target)
            self.seen: list[tuple[np.ndarray, ...]] = []

        def on_fed(self, obs: np.ndarray, targets: np.ndarray, starts: np.ndarray) -> None:
            self.seen.append((obs, targets, starts))

    model = make_scripted(PPO, n_steps=4)
    recorder = FeedRecorder(model.policy, keep_empty=False)
    hooked = Hooked()
    model.learn(4 * 2 * 3, callback=hooked)
    assert len(hooked.seen) == len(recorder.batches) == 3
    for seen, fed in zip(hooked.seen, recorder.batches, strict=True):
        for a, b in zip(seen, fed, strict=True):
            np.testing.assert_array_equal(a, b)


def test_returns_target_is_the_buffer_returns_env_by_env() -> None:
    model = make_scripted(PPO, n_steps=4)
    recorder = FeedRecorder(model.policy, keep_empty=True)
    buffers = BufferRecorder()
    model.learn(2 * 4 * 3, callback=CallbackList([GPValueCallback(target="returns"), buffers]))
    assert len(recorder.batches) == len(buffers.rollouts) == 3
    for (obs, targets, starts), rollout in zip(recorder.batches, buffers.rollouts, strict=True):
        for env in range(2):
            rows = slice(4 * env, 4 * env + 4)
            np.testing.assert_array_equal(obs[rows], rollout["observations"][:, env])
            np.testing.assert_array_equal(targets[rows], rollout["returns"][:, env])
            expected_starts = rollout["episode_starts"][:, env].astype(bool)
            expected_starts[0] = True
            np.testing.assert_array_equal(starts[rows], expected_starts)
            # Hand-computed: gae_lambda=1 gives discounted rewards to the rollout's end, then
            # the critic's value (PRIOR, the GP is empty) unless the episode ended there.
            for i, (_, episode, t) in enumerate(rollout["observations"][:, env]):
                y, k, ended = 0.0, 0, False
                for step in range(i, 4):
                    t_step = rollout["observations"][step, env, 2]
                    if step > i and t_step == 0:
                        ended = True
                        break
                    reward = 1.0 + t_step
                    length = 3 if env == 0 else 5
                    if env == 1 and t_step == length - 1:
                        reward += GAMMA * PRIOR  # SB3's time-limit bootstrap
                    y += GAMMA**k * reward
                    k += 1
                    if t_step == length - 1:
                        ended = True
                        break
                if not ended:
                    y += GAMMA**k * PRIOR
                assert targets[rows][i] == pytest.approx(y, rel=1e-5), (env, episode, t)


def test_feed_every_feeds_the_held_rollouts_each_env_stitched_in_time() -> None:
    """``feed_every=2`` under A2C: the GP sees nothing after odd rollouts (so their values come
    from the critic of the last feed) and, after even ones, both rollouts' returns, each env's
    eight steps in time order with one trajectory start; a fifth rollout, held when ``learn``
    ends, is fed then."""
    model = make_scripted(A2C, n_steps=4)
    recorder = FeedRecorder(model.policy, keep_empty=False)
    buffers = BufferRecorder()
    probe = th.tensor([[0.0, 0.0, 1.0], [1.0, 2.0, 3.0]])
    critics = ProbeRecorder(probe)
    feed = GPValueCallback(feed_every=2)
    model.learn(2 * 4 * 5, callback=CallbackList([feed, buffers, critics]))
    assert [len(b[1]) for b in recorder.batches] == [0, 16, 0, 16, 0, 8]
    fed = [b for b in recorder.batches if len(b[1])]
    groups = [buffers.rollouts[0:2], buffers.rollouts[2:4], buffers.rollouts[4:]]
    for (obs, targets, starts), group in zip(fed, groups, strict=True):
        n = 4 * len(group)
        for env in range(2):
            rows = slice(n * env, n * env + n)
            stacked = {k: np.concatenate([r[k][:, env] for r in group]) for k in group[0]}
            np.testing.assert_array_equal(obs[rows], stacked["observations"])
            np.testing.assert_array_equal(targets[rows], stacked["returns"])
            expected_starts = stacked["episode_starts"].astype(bool)
            expected_starts[0] = True
            np.testing.assert_array_equal(starts[rows], expected_starts)
    # The critic moves only where it is fed: after rollouts 1 and 3 (the fifth is fed later).
    values = critics.values
    np.testing.assert_array_equal(values[0], np.full(2, PRIOR, dtype=np.float32))
    for held, fed_before in ((2, 1), (4, 3)):
        np.testing.assert_array_equal(values[held], values[fed_before])
        assert not np.allclose(values[fed_before], values[fed_before - 1])


def test_feed_every_monte_carlo_feeds_what_every_rollout_would_have() -> None:
    """Monte Carlo targets do not depend on when they are fed (an empty GP, so the time-limit
    bootstraps are the prior on both sides): ``feed_every=3``'s batches are
    ``feed_every=1``'s, three at a time."""
    batches = []
    for every in (1, 3):
        model = make_scripted(PPO, n_steps=4)
        recorder = FeedRecorder(model.policy, keep_empty=True)
        model.learn(2 * 4 * 6, callback=GPValueCallback(target="monte_carlo", feed_every=every))
        batches.append(recorder.batches)
    every_rollout, every_third = batches
    assert [len(b[1]) for b in every_third][0::3] == [0, 0]
    for i, joined in enumerate(every_third[2::3]):
        group = every_rollout[3 * i : 3 * i + 3]
        for k in range(3):
            np.testing.assert_array_equal(joined[k], np.concatenate([b[k] for b in group]))


@pytest.mark.parametrize("bad", [0, -2, 1.5, 4.0, True, "2", None])
def test_feed_every_must_be_a_positive_integer(bad: Any) -> None:
    with pytest.raises(ValueError, match="feed_every must be a positive integer"):
        GPValueCallback(feed_every=bad)


@pytest.mark.parametrize("kernel", ["geodesic", "rbf"])
def test_monte_carlo_end_to_end_explains_its_targets(kernel: str) -> None:
    """Pendulum episodes (200 steps) complete in later rollouts; the GP fits what it was fed.

    gamma=0.9 (as in rl-baselines3-zoo) keeps the targets a function of the state: with a
    long horizon the return-to-go of a time-limited episode depends on the time left, which
    the observation does not show.
    """
    model = PPO(
        GPActorCriticPolicy,
        make_vec_env("Pendulum-v1", n_envs=2, seed=2),
        gamma=0.9,
        n_steps=150,
        batch_size=100,
        n_epochs=1,
        seed=2,
        policy_kwargs=dict(gp_kwargs=dict(kernel=kernel, max_basis=64)),
    )
    recorder = FeedRecorder(model.policy, keep_empty=False)
    model.learn(2 * 150 * 3, callback=GPValueCallback(target="monte_carlo"))
    # Rollout 1 (steps 0-149): nothing complete; rollout 2 (150-299): episode 1 of each env,
    # stitched from both rollouts; rollout 3 (300-449): episode 2.
    assert [len(b[1]) for b in recorder.batches] == [0, 400, 400]
    obs, targets, starts = recorder.batches[-1]
    assert np.flatnonzero(starts).tolist() == [0, 200]
    pred = model.policy.predict_values(th.as_tensor(obs)).numpy().ravel()
    ev = 1 - np.var(targets - pred) / np.var(targets)
    assert ev > 0.3, f"explained variance of the fed Monte-Carlo returns is {ev:.3f}"


# ------------------------------------------------------------------------------------------------
# Timing of the advantages
# ------------------------------------------------------------------------------------------------
def _pendulum(algo: type[BaseAlgorithm], n_envs: int = 2) -> BaseAlgorithm:
    kwargs: dict[str, Any] = dict(n_steps=64, seed=1)
    if algo is PPO:
        kwargs.update(batch_size=64, n_epochs=1)
    return algo(
        GPActorCriticPolicy,
        make_vec_env("Pendulum-v1", n_envs=n_envs, seed=1),
        policy_kwargs=dict(gp_kwargs=dict(max_basis=32)),
        **kwargs,
    )


class ValuesAtRolloutEnd(BaseCallback):
    """Before GPValueCallback: copies of the buffer's values/advantages as SB3 left them."""

    def __init__(self) -> None:
        super().__init__()
        self.values: list[np.ndarray] = []
        self.advantages: list[np.ndarray] = []

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self.values.append(self.model.rollout_buffer.values.copy())
        self.advantages.append(self.model.rollout_buffer.advantages.copy())


@pytest.mark.parametrize("recompute", [False, True])
@pytest.mark.parametrize("algo", [PPO, A2C])
def test_advantage_timing(algo: type[BaseAlgorithm], recompute: bool) -> None:
    model = _pendulum(algo)
    before = ValuesAtRolloutEnd()
    after = BufferRecorder()
    # Step-by-step values, so that ``before`` sees SB3's own (deferred values are equivalent:
    # test_deferred_values_equal_step_by_step).
    # SB3's returns: 64 steps per env and rollout complete no 200-step episode.
    cb = GPValueCallback(target="returns", recompute_advantages=recompute, deferred_values=False)
    model.learn(3 * 128, callback=CallbackList([before, cb, after]))
    last = after.rollouts[-1]
    obs = th.as_tensor(last["observations"].reshape(-1, 3))
    now = model.policy.predict_values(obs).numpy().reshape(64, 2)
    if recompute:
        # Values, returns and advantages all come from the GP that absorbed the rollout.
        np.testing.assert_array_equal(last["values"], now)
        np.testing.assert_allclose(last["returns"], last["advantages"] + now, rtol=1e-6)
        assert not np.allclose(last["advantages"], before.advantages[-1])
    else:
        # SB3's timing, as with an MLP critic: the critic from before the update.
        np.testing.assert_array_equal(last["values"], before.values[-1])
        np.testing.assert_array_equal(last["advantages"], before.advantages[-1])
        assert not np.allclose(last["values"], now)


class TruncatingEnv(gym.Env[np.ndarray, int]):
    """Random walk in 2-D truncated after 3 steps, so every rollout has bootstraps."""

    observation_space = spaces.Box(-10.0, 10.0, shape=(2,), dtype=np.float32)
    action_space = spaces.Discrete(2)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.x = self.np_random.normal(size=2).astype(np.float32)
        return self.x, {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self.x = self.x + self.np_random.normal(size=2).astype(np.float32)
        return self.x, float(self.x[0]), False, False, {}


def test_recompute_updates_time_limit_bootstraps() -> None:
    env = DummyVecEnv([lambda: TimeLimit(TruncatingEnv(), 3)])
    model = PPO(
        GPActorCriticPolicy,
        env,
        n_steps=12,
        batch_size=12,
        n_epochs=1,
        seed=0,
        policy_kwargs=dict(gp_kwargs=dict(kernel="rbf", max_basis=16)),
    )
    raw = BufferRecorder()
    cb = GPValueCallback(recompute_advantages=True)
    model.learn(36, callback=CallbackList([raw, cb]))
    # raw saw the rewards after SB3's bootstrap with the old GP; cb then swapped in the new.
    rewards_old = raw.rollouts[-1]["rewards"]
    rewards_new = model.rollout_buffer.rewards
    truncated = rewards_old != rewards_new
    assert truncated.sum() == 4  # steps 2, 5, 8, 11
    np.testing.assert_array_equal(np.flatnonzero(truncated), [2, 5, 8, 11])


@pytest.mark.parametrize("kernel", ["geodesic", "rbf"])
@pytest.mark.parametrize("algo", [PPO, A2C])
def test_deferred_values_equal_step_by_step(algo: type[BaseAlgorithm], kernel: str) -> None:
    """One batched prediction per rollout gives the buffer and actor of step-by-step values.

    Two envs, truncated every 3 steps inside 8-step rollouts, so SB3 bootstraps mid-rollout.
    """

    def run(deferred: bool) -> tuple[list[dict[str, np.ndarray]], list[th.Tensor]]:
        env = DummyVecEnv([lambda: TimeLimit(TruncatingEnv(), 3)] * 2)
        extra = dict(batch_size=8, n_epochs=2) if algo is PPO else {}
        model = algo(
            GPActorCriticPolicy,
            env,
            n_steps=8,
            seed=0,
            policy_kwargs=dict(gp_kwargs=dict(kernel=kernel, max_basis=16, forgetting=0.9)),
            **extra,
        )
        recorder = BufferRecorder()
        model.learn(
            5 * 16, callback=CallbackList([GPValueCallback(deferred_values=deferred), recorder])
        )
        return recorder.rollouts, [p.detach().clone() for p in model.policy.parameters()]

    deferred, stepwise = run(True), run(False)
    assert len(deferred[0]) == len(stepwise[0]) == 5
    for a, b in zip(deferred[0], stepwise[0], strict=True):
        assert (a["rewards"] != 0).any()
        for name in ("observations", "rewards", "values", "returns", "advantages"):
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert all(th.equal(a, b) for a, b in zip(deferred[1], stepwise[1], strict=True))


# ------------------------------------------------------------------------------------------------
# Logging and errors
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kernel", ["geodesic", "rbf"])
def test_logged_metrics(kernel: str) -> None:
    model = PPO(
        GPActorCriticPolicy,
        make_vec_env("Pendulum-v1", n_envs=2, seed=1),
        n_steps=64,
        batch_size=64,
        n_epochs=1,
        seed=1,
        policy_kwargs=dict(gp_kwargs=dict(kernel=kernel, max_basis=32, forgetting=0.95)),
    )
    recorder = BufferRecorder()
    model.learn(4 * 128, callback=CallbackList([GPValueCallback(target="returns"), recorder]))
    logged = recorder.logged[-1]
    keys = {"gp/n_basis", "gp/update_ms", "gp/explained_variance", "gp/mse"}
    keys |= {"gp/forgetting", "gp/n_fed"}
    assert keys <= logged.keys()
    # The variance diagnostic is recomputed once 256 points have been fed since: these
    # 128-point rollouts have it every other time.
    assert ["gp/mean_std" in r for r in recorder.logged] == [True, False, True, False]
    assert recorder.logged[0]["gp/mean_std"] > 0
    assert ("gp/n_components" in logged) == (kernel == "geodesic")
    assert logged["gp/n_basis"] == model.policy.gp.n_basis
    assert logged["gp/forgetting"] == 0.95
    assert logged["gp/n_fed"] == 128
    assert logged["gp/update_ms"] > 0
    # Measured before absorbing: the first rollout meets an empty GP predicting 0 everywhere.
    first = recorder.logged[0]
    returns = recorder.rollouts[0]["returns"]
    assert first["gp/mse"] == pytest.approx(float(np.mean(returns.astype(np.float64) ** 2)))
    assert first["gp/explained_variance"] == pytest.approx(0.0, abs=1e-6)


def test_callback_rejects_other_policies() -> None:
    model = PPO("MlpPolicy", "Pendulum-v1", n_steps=64, batch_size=64)
    with pytest.raises(TypeError, match="GPActorCriticPolicy"):
        model.learn(64, callback=GPValueCallback())


def test_callback_rejects_other_algorithms() -> None:
    """A GP policy put into a model after its construction meets the policy's check in learn."""
    model = SAC("MlpPolicy", "Pendulum-v1")
    model.policy = GPActorCriticPolicy(model.observation_space, model.action_space, lambda _: 1e-3)
    with pytest.raises(TypeError, match=re.escape(SUPPORTED_ALGORITHMS)):
        model.learn(64, callback=GPValueCallback())


def test_bad_target_raises() -> None:
    with pytest.raises(ValueError, match="monte_carlo"):
        GPValueCallback(target="td")  # type: ignore[arg-type]


def test_the_callback_class_passed_for_an_instance_is_named() -> None:
    """SB3 wraps a callable that is no callback and calls it with its locals and globals: the
    class itself would be built with them as its options."""
    model = PPO(GPActorCriticPolicy, "Pendulum-v1", n_steps=64, batch_size=64)
    with pytest.raises(TypeError, match=r"as a class; pass an instance.*GPValueCallback\(\)"):
        model.learn(64, callback=GPValueCallback)  # type: ignore[arg-type]


def test_vec_normalize_warns_about_drifting_statistics() -> None:
    env = VecNormalize(make_vec_env("Pendulum-v1", n_envs=1, seed=0))
    model = PPO(GPActorCriticPolicy, env, n_steps=64, batch_size=64, n_epochs=1)
    # SB3's returns: fed every rollout (Monte Carlo targets would warn that 64 steps of
    # Pendulum's 200-step episodes fed nothing).
    with pytest.warns(UserWarning, match="norm_obs=False.*normalize_actor_obs=True"):
        model.learn(64, callback=GPValueCallback(target="returns"))
    env.training = False  # frozen statistics: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model.learn(64, callback=GPValueCallback(target="returns"), reset_num_timesteps=False)
    # The other fix it names: raw observations for the GP, normalised ones for the actor alone.
    env = VecNormalize(make_vec_env("Pendulum-v1", n_envs=1, seed=0), norm_obs=False)
    kwargs = dict(normalize_actor_obs=True)
    model = PPO(GPActorCriticPolicy, env, n_steps=64, batch_size=64, policy_kwargs=kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model.learn(64, callback=GPValueCallback(target="returns"))


@pytest.mark.parametrize(
    ("wrap", "named", "dims"),
    [
        (lambda env: VecNormalize(env), "VecNormalize normalises", [0, 1, 2]),
        (lambda env: VecFrameStack(env, n_stack=2), "VecFrameStack stacks", list(range(6))),
        (lambda env: VecNormalize(env, norm_obs=False), None, None),
        (lambda env: env, None, None),
    ],
    ids=["normalised", "stacked", "rewards-normalised", "plain"],
)
def test_wrappers_that_change_the_observations_bounds_meaning_are_named(
    wrap: Any, named: str | None, dims: list[int] | None
) -> None:
    """Pendulum-v1's lengthscales all come from its bounds; VecNormalize's normalised
    observations and VecFrameStack's stacked ones no longer match those bounds: named before
    the GP's first data (and not again on a continued learn() call), with the dimensions.
    Lengthscales the user gives are not named."""

    def learn(model: PPO, **kwargs: Any) -> None:
        model.learn(64, callback=GPValueCallback(target="returns"), **kwargs)

    def model(**kernel_kwargs: Any) -> PPO:
        env = wrap(make_vec_env("Pendulum-v1", n_envs=1, seed=0))
        if isinstance(env, VecNormalize):
            env.training = False  # no warning about moving statistics
        gp_kwargs = dict(kernel_kwargs=kernel_kwargs)
        return PPO(GPActorCriticPolicy, env, n_steps=64, batch_size=64, n_epochs=1,
                   policy_kwargs=dict(gp_kwargs=gp_kwargs))  # fmt: skip

    wrapped = model()
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        learn(wrapped)
    texts = [str(r.message) for r in record if issubclass(r.category, GPCriticWarning)]
    if named is None:
        assert not any("came from the observation space's bounds" in t for t in texts)
        return
    (text,) = [t for t in texts if named in t]
    assert f"observation dimensions {dims} came from" in text
    with warnings.catch_warnings():
        warnings.simplefilter("error", GPCriticWarning)
        learn(wrapped, reset_num_timesteps=False)  # fed already: said once
        learn(model(lengthscale=1.0))  # the user's lengthscales


def test_inputs_far_outside_their_bounds_are_named() -> None:
    """``VecFrameStack``'s Pendulum-v1 bounds, element by element ([-1, -1, -1, -1, -8, -8]),
    against its frames ([cos, sin, velocity] twice): the first frame's velocity, in [-8, 8], falls
    in a dimension declared +-1, far outside it; the engine names it after 10,000 inputs."""
    env = VecFrameStack(make_vec_env("Pendulum-v1", n_envs=1, seed=0), n_stack=2)
    space = env.observation_space
    np.testing.assert_array_equal(space.high, [1, 1, 1, 1, 8, 8])  # SB3's order
    coverage = BoundsCoverage(space.low, space.high, [True] * 6)
    rng = np.random.default_rng(0)
    theta, speed = rng.uniform(-np.pi, np.pi, 10_000), rng.uniform(-8, 8, 10_000)
    frame = np.stack([np.cos(theta), np.sin(theta), speed], axis=1)
    coverage.add(th.as_tensor(np.concatenate([frame, frame], axis=1)))
    message = coverage.check(th.as_tensor(bounds_lengthscale(space.low, space.high)))
    assert message is not None
    named = [int(i) for i in re.findall(r"dimension (\d) spans", message)]
    assert named == [2]  # the second frame's sine, in +-8, fills 12.5 % of them
    assert "times the width of its bounds [-1, 1]" in message and "reordered" in message


def test_a2c_without_forgetting_warns() -> None:
    def learn(algo: type[BaseAlgorithm], **gp_kwargs: Any) -> None:
        extra = dict(batch_size=8) if algo is PPO else {}
        model = algo(GPActorCriticPolicy, "Pendulum-v1", n_steps=8, seed=0, **extra,
                     policy_kwargs=dict(gp_kwargs=dict(kernel="rbf", **gp_kwargs)))  # fmt: skip
        # A2C's default target is SB3's returns; PPO's (Monte Carlo) would feed 8 steps nothing.
        model.learn(8, callback=GPValueCallback(target="returns" if algo is PPO else None))

    with pytest.warns(UserWarning, match="forgetting=0.9"):
        learn(A2C, adapt=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        learn(A2C)  # the adaptive default chooses its forgetting
        learn(A2C, adapt=False, forgetting=0.9)
        learn(PPO, adapt=False)  # long rollouts: no warning


def test_callback_passed_twice_raises() -> None:
    model = PPO(GPActorCriticPolicy, "Pendulum-v1", n_steps=64, batch_size=64, n_epochs=1)
    with pytest.raises(RuntimeError, match="more than once"):
        model.learn(64, callback=[GPValueCallback(), GPValueCallback()])


class NaNRewardEnv(TruncatingEnv):
    """The random walk whose third step's reward is NaN."""

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        self.t = 0
        return super().reset(seed=seed, options=options)

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self.t += 1
        obs, reward, *rest = super().step(action)
        return obs, float("nan") if self.t == 3 else reward, *rest


def test_nan_reward_is_named_with_its_step_and_env() -> None:
    env = DummyVecEnv([TruncatingEnv, NaNRewardEnv])
    model = A2C(GPActorCriticPolicy, env, n_steps=5, seed=0)
    gp_before = {
        k: v.clone() for k, v in model.policy.gp.state_dict().items() if isinstance(v, th.Tensor)
    }
    with pytest.raises(ValueError, match="reward at step 2 of this rollout in env 1 is nan"):
        model.learn(10, callback=GPValueCallback())
    for key, value in model.policy.gp.state_dict().items():
        if isinstance(value, th.Tensor):
            assert th.equal(value.nan_to_num(), gp_before[key].nan_to_num()), key


class NaNAtTruncation(TruncatingEnv):
    """The random walk whose second episode's final observation, at its time limit of 3
    steps, holds NaN."""

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        self.episodes = getattr(self, "episodes", 0) + 1
        self.t = 0
        return super().reset(seed=seed, options=options)

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self.t += 1
        obs, *rest = super().step(action)
        if self.episodes == 2 and self.t == 3:
            obs = np.array([np.nan, 0.0], dtype=np.float32)
        return obs, *rest


def test_nan_final_observation_of_a_truncated_episode_is_named_with_its_env() -> None:
    """SB3 asks the critic for V(final observation) of each truncated episode alone, a batch
    of one; the callback checks it first and names the env (2, not row 0)."""
    envs = [lambda: TimeLimit(TruncatingEnv(), 3)] * 2 + [lambda: TimeLimit(NaNAtTruncation(), 3)]
    model = A2C(GPActorCriticPolicy, DummyVecEnv(envs), n_steps=4, seed=0)
    probe = ProbeRecorder(th.zeros(1, 2))
    match = r"final observation of env 2's episode, cut by its time limit, holds NaN"
    with pytest.raises(ValueError, match=match):
        model.learn(40, callback=[GPValueCallback(), probe])
    assert model.num_timesteps == 3 * 6  # the second episode's last step
    assert not model.policy.defer_values
    assert len(probe.values) == 1  # the first rollout was fed, the second refused


class HugeRewardEnv(ScriptedEnv):
    """:class:`ScriptedEnv` (3-step episodes) whose rewards, 3e38, fit float32 and whose
    discounted sums do not."""

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        obs, _, *rest = super().step(action)
        return obs, 3e38, *rest


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # SB3 computes its GAE in overflow
@pytest.mark.parametrize(
    ("algo", "target", "episode"),
    [(PPO, "monte_carlo", 3), (A2C, "returns", 3), (PPO, "monte_carlo", 20)],
    ids=["float64-mc", "sb3", "mc-nothing-fed"],
)
def test_returns_beyond_float32_are_refused_with_the_fix(
    algo: type[BaseAlgorithm], target: Target, episode: int
) -> None:
    """Finite rewards whose returns overflow float32 (SB3's returns turn inf; Monte Carlo
    returns, float64, would become inf values in the float32 value head): refused before the
    GP learns anything, naming the fix; also where no episode ends within the rollout, so no
    Monte Carlo return is fed (the actor would train on SB3's inf returns)."""
    kwargs: dict[str, Any] = dict(batch_size=8, n_epochs=1) if algo is PPO else {}
    env = DummyVecEnv([lambda: HugeRewardEnv(0, episode)])
    model = algo(GPActorCriticPolicy, env, n_steps=8, seed=0, **kwargs)
    before = snapshot(model.policy.gp)
    message = r"returns (reach \d\S*|overflow to inf or NaN), beyond float32.*Scale the rewards"
    with pytest.raises(ValueError, match=message):
        model.learn(8, callback=GPValueCallback(target=target))
    assert_same_state(before, snapshot(model.policy.gp))


def test_a_learn_call_that_feeds_nothing_says_so() -> None:
    """Monte Carlo targets (PPO's default) wait for an episode's end: a learn() call shorter
    than Pendulum's 200-step episodes feeds nothing and warns; SB3's returns feed every rollout,
    and a call in which an episode ends feeds its 200 steps, neither with a warning."""

    def pendulum() -> PPO:
        return PPO(GPActorCriticPolicy, "Pendulum-v1", n_steps=64, batch_size=64, n_epochs=1,
                   seed=0)  # fmt: skip

    short = pendulum()
    with pytest.warns(GPCriticWarning, match="fed the GP critic nothing in this learn"):
        short.learn(128, callback=GPValueCallback())
    assert int(short.policy.gp.n_seen) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error", GPCriticWarning)
        fed_returns = pendulum()
        fed_returns.learn(128, callback=GPValueCallback(target="returns"))
        assert int(fed_returns.policy.gp.n_seen) == 128
        longer = pendulum()
        longer.learn(256, callback=GPValueCallback())
        assert int(longer.policy.gp.n_seen) == 200


class ConstantRewardEnv(ScriptedEnv):
    """:class:`ScriptedEnv` whose every reward is ``reward``, never terminating."""

    def __init__(self, env_id: int, reward: float) -> None:
        super().__init__(env_id, None)
        self.reward = reward

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        obs, _, terminated, truncated, info = super().step(action)
        return obs, self.reward, terminated, truncated, info


def _learn_at_prior(
    reward: float, callback: GPValueCallback
) -> tuple[list[warnings.WarningMessage], np.ndarray, list[str]]:
    """PPO on :class:`ConstantRewardEnv` (time limit 5) with its GP kept at the prior mean 2,
    ``gamma = 0.5``, ``ent_coef = 0``: the all-zero warnings, the advantages and the names of
    the actor's parameters that changed."""
    env = DummyVecEnv(
        [lambda i=i: TimeLimit(ConstantRewardEnv(i, reward), max_episode_steps=5) for i in (0, 1)]
    )
    gp_kwargs = dict(kernel="rbf", max_basis=16, target_mean=2.0)
    model = PPO(GPActorCriticPolicy, env, n_steps=8, batch_size=16, n_epochs=2, gamma=0.5,
                ent_coef=0.0, seed=0, policy_kwargs=dict(gp_kwargs=gp_kwargs))  # fmt: skip
    FeedRecorder(model.policy, keep_empty=True)
    before = {name: p.detach().clone() for name, p in model.policy.named_parameters()}
    recorder = BufferRecorder()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.learn(3 * 16, callback=CallbackList([callback, recorder]))
    said = [w for w in caught if "is exactly 0" in str(w.message)]
    advantages = np.stack([r["advantages"] for r in recorder.rollouts])
    moved = [n for n, p in model.policy.named_parameters() if not th.equal(p, before[n])]
    return said, advantages, moved


@pytest.mark.parametrize(("reward", "still"), [(1.0, True), (1.5, False)])
def test_advantages_all_zero_warn_that_the_actor_stands_still(reward: float, still: bool) -> None:
    """The GP kept at its prior mean ``m = 2`` everywhere, ``gamma = 0.5`` and every reward
    ``r = (1 - gamma) m = 1``: each TD error ``r + gamma m - m`` is 0 (also at the time limit,
    where SB3 folds ``gamma m`` into the reward), so every advantage is 0, PPO's actor gets no
    gradient (``ent_coef=0``) and its parameters stay as they were, bit for bit; the callback
    says so once. With ``r = 1.5`` the advantages vary along the rollout, the actor moves, and
    nothing is said."""
    said, advantages, moved = _learn_at_prior(reward, GPValueCallback(target="returns"))
    assert len(advantages) == 3 and (not advantages.any()) == still
    assert len(said) == int(still) and all(w.category is GPCriticWarning for w in said)
    assert bool(moved) != still, moved


@pytest.mark.parametrize(("horizon", "names_uncut"), [(3, True), (None, False)])
def test_the_all_zero_warning_names_uncut_returns_only_where_returns_are_cut(
    horizon: int | None, names_uncut: bool
) -> None:
    """Uncut Monte Carlo returns are offered as the fix only to a critic fed cut ones."""
    said, _, _ = _learn_at_prior(1.0, GPValueCallback(target="monte_carlo", horizon=horizon))
    assert len(said) == 1
    assert ("target='monte_carlo'" in str(said[0].message)) == names_uncut


def test_warnings_have_their_own_category_and_point_at_the_users_line() -> None:
    import warnings as std_warnings

    fixed = dict(gp_kwargs=dict(adapt=False))
    model = A2C(GPActorCriticPolicy, "Pendulum-v1", n_steps=8, seed=0, policy_kwargs=fixed)
    with pytest.warns(GPCriticWarning, match="forgetting=1.0") as record:
        model.learn(8, callback=GPValueCallback())
    ours = [w for w in record if issubclass(w.category, GPCriticWarning)]
    assert ours and all(w.filename == __file__ for w in ours)
    with std_warnings.catch_warnings():
        std_warnings.simplefilter("error", UserWarning)
        std_warnings.filterwarnings("ignore", category=GPCriticWarning)
        A2C(GPActorCriticPolicy, "Pendulum-v1", n_steps=8, seed=0, policy_kwargs=fixed).learn(
            8, callback=GPValueCallback()
        )


def test_no_forgetting_warning_when_the_gp_adapts_its_forgetting() -> None:
    import warnings as std_warnings

    kwargs = dict(gp_kwargs=dict(adapt=True))
    model = A2C(GPActorCriticPolicy, "Pendulum-v1", n_steps=8, seed=0, policy_kwargs=kwargs)
    with std_warnings.catch_warnings():
        std_warnings.simplefilter("error", GPCriticWarning)
        model.learn(8, callback=GPValueCallback())
