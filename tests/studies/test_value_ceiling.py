"""The value ceiling: batch dynamics and Monte Carlo returns against gymnasium's own envs, GAE
returns against SB3's buffer, and the ceiling of a policy whose returns are certain."""

from __future__ import annotations

import copy
import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp.envs import PAPER_PENDULUM_ID
from sb3_geogp.envs.pendulum import PaperPendulum
from sb3_geogp.studies.advantage_error import gae
from sb3_geogp.studies.value_ceiling import (
    TASKS,
    Rollout,
    acrobot_step,
    capacity,
    ceiling,
    horizon,
    knn_fit,
    lagged_ceiling,
    mlp_fit,
    model_returns,
    own_value_weight,
    policy_returns,
    reference_advantages,
    value_r2,
)


def _random_acrobot_states(n: int, rng: np.random.Generator) -> np.ndarray:
    return np.column_stack(
        [
            rng.uniform(-math.pi, math.pi, (n, 2)),
            rng.uniform(-4 * math.pi, 4 * math.pi, n),
            rng.uniform(-9 * math.pi, 9 * math.pi, n),
        ]
    )


def test_acrobot_step_is_gymnasiums() -> None:
    """Reference: gymnasium's ``AcrobotEnv.step`` from the same state, one state at a time;
    the states include fast ones that wrap and reach the goal."""
    rng = np.random.default_rng(0)
    states, actions = _random_acrobot_states(400, rng), rng.integers(0, 3, 400)
    nxt, terminated = acrobot_step(states, actions)
    env = gym.make("Acrobot-v1").unwrapped
    env.reset(seed=0)
    for s, a, want, done in zip(states, actions, nxt, terminated, strict=True):
        env.state = s.copy()
        obs, reward, gym_done, _, _ = env.step(int(a))
        np.testing.assert_allclose(env.state, want, rtol=0, atol=1e-12)
        assert gym_done == done
        assert reward == TASKS["Acrobot-v1"].reward(s[None], a[None, None], np.array([done]))[0]
        np.testing.assert_allclose(TASKS["Acrobot-v1"].observe(want[None])[0], obs, atol=1e-6)
    assert 0 < terminated.sum() < len(terminated)


def test_pendulum_v1_step_and_reward_are_gymnasiums() -> None:
    """Reference: gymnasium's ``PendulumEnv.step`` from the same state, one at a time; the
    states include fast ones the speed limit clips, the torques ones the torque limit clips,
    and angles many turns away from upright (the reward wraps them, the state does not)."""
    rng = np.random.default_rng(2)
    states = np.stack([rng.uniform(-5 * math.pi, 5 * math.pi, 300), rng.uniform(-9, 9, 300)], 1)
    actions = rng.uniform(-3, 3, (300, 1))
    task = TASKS["Pendulum-v1"]
    nxt, terminated = task.step(states, actions)
    rewards = task.reward(states, actions, terminated)
    env = gym.make("Pendulum-v1").unwrapped
    env.reset(seed=0)
    for s, a, want, r in zip(states, actions, nxt, rewards, strict=True):
        env.state = s.copy()
        obs, reward, gym_terminated, _, _ = env.step(a)
        np.testing.assert_allclose(env.state, want, rtol=0, atol=1e-12)
        assert not gym_terminated
        assert reward == pytest.approx(r, rel=1e-12) and abs(r) <= task.reward_bound
        np.testing.assert_allclose(task.observe(want[None])[0], obs, atol=1e-6)
    assert not terminated.any()
    speeds = np.abs(nxt[:, 1])
    assert (speeds == 8.0).any() and (speeds < 8.0).any()
    back = task.state(task.observe(states))
    np.testing.assert_allclose(np.cos(back[:, 0]), np.cos(states[:, 0]), atol=1e-12)
    np.testing.assert_allclose(np.sin(back[:, 0]), np.sin(states[:, 0]), atol=1e-12)
    np.testing.assert_allclose(back[:, 1], states[:, 1], atol=0)


def test_acrobot_state_is_recovered_from_its_observation() -> None:
    rng = np.random.default_rng(1)
    states = _random_acrobot_states(100, rng)
    task = TASKS["Acrobot-v1"]
    np.testing.assert_allclose(task.state(task.observe(states)), states, atol=1e-12)


def test_horizon_leaves_at_most_the_tail() -> None:
    for gamma, tail in ((0.99, 0.1), (0.98, 0.1), (0.9, 1e-3)):
        steps = horizon(gamma, tail)
        assert gamma**steps / (1 - gamma) <= tail < gamma ** (steps - 1) / (1 - gamma)
    with pytest.raises(ValueError, match="gamma"):
        horizon(1.0, 0.1)


def _restart(env_id: str, obs: np.ndarray) -> gym.Env:  # type: ignore[type-arg]
    """gymnasium's env (no time limit) restarted from the observation's state."""
    env = gym.make(env_id).unwrapped
    state = TASKS[env_id].state(obs[None])[0]
    if env_id == PAPER_PENDULUM_ID:
        env.reset(seed=0, options={"state": state})
    elif env_id.startswith("sb3_geogp/"):
        env.reset(seed=0, options={"start": state})
    else:
        env.reset(seed=0)
        env.state = state
    return env


def _gym_return(
    env_id: str, obs: np.ndarray, action: np.ndarray, gamma: float, steps: int
) -> float:
    """Brute force: gymnasium's env restarted from the observation's state, one action always,
    no time limit."""
    env = _restart(env_id, obs)
    total = 0.0
    for t in range(steps):
        _, reward, terminated, _, _ = env.step(action)
        total += gamma**t * reward
        if terminated:
            break
    return total


def _two_actions(env_id: str) -> tuple[np.ndarray, np.ndarray]:
    space = gym.make(env_id).action_space
    if isinstance(space, gym.spaces.Discrete):
        return np.array(0), np.array(1)
    # out of the box and inside it: the maze clips, then bounds the speed; the pendulum clips
    n = space.shape[0]
    return tuple(np.array(a[:n], np.float32) * space.high for a in ([-1.4, 0.6], [0.2, 0.9]))


@pytest.mark.parametrize("env_id", sorted(TASKS))
def test_policy_returns_match_gymnasium_for_a_fixed_action(env_id: str) -> None:
    """A policy that always takes one action has one return per state: every Monte Carlo
    rollout equals gymnasium's own episode from that state, cut at the same step."""
    gamma, steps = 0.99, 300
    env = gym.make(env_id)
    obs = np.array([env.reset(seed=s)[0] for s in range(6)], dtype=np.float64)
    for action in _two_actions(env_id):
        returns = policy_returns(
            lambda o, t, a=action: np.repeat(a[None], len(o), axis=0),
            TASKS[env_id],
            obs,
            gamma,
            steps,
            3,
        )
        assert returns.shape == (6, 3) and np.all(returns == returns[:, :1])
        want = [_gym_return(env_id, o, action, gamma, steps) for o in obs]
        np.testing.assert_allclose(returns[:, 0], want, rtol=1e-10)


@pytest.mark.parametrize(
    ("obs", "gamma", "steps", "n_rollouts", "named"),
    [
        (np.zeros((1, 4)), 0.9, 5, 1, "n_rollouts"),
        (np.zeros(4), 0.9, 5, 2, "shape"),
        (np.full((2, 4), np.nan), 0.9, 5, 2, "NaN"),
        (np.zeros((2, 4)), 0.9, 0, 2, "steps"),
        (np.zeros((2, 4)), 1.5, 5, 2, "gamma"),
    ],
)
def test_policy_returns_refuse_bad_arguments_before_acting(
    obs: np.ndarray, gamma: float, steps: int, n_rollouts: int, named: str
) -> None:
    calls: list[int] = []

    def act(o: np.ndarray, step: int) -> np.ndarray:
        calls.append(step)
        return np.zeros(len(o), dtype=np.int64)

    with pytest.raises(ValueError, match=named):
        policy_returns(act, TASKS["CartPole-v1"], obs, gamma, steps, n_rollouts)
    assert calls == []


def test_model_returns_refuse_observations_not_shaped_as_the_models() -> None:
    """A CartPole model asked about 3-wide states: a ValueError naming both shapes, and no
    random stream drawn from."""
    from stable_baselines3 import PPO

    model = PPO("MlpPolicy", "CartPole-v1", n_steps=32, batch_size=32, seed=0, device="cpu")
    before = th.get_rng_state()
    with pytest.raises(ValueError, match=r"\(n, 4\).*\(2, 3\)"):
        model_returns(model, TASKS["CartPole-v1"], np.zeros((2, 3)), 5, 2, seed=0)
    assert th.equal(th.get_rng_state(), before)


def test_pendulum_returns_at_rest_hanging_are_the_geometric_sum() -> None:
    """Closed form: without torque the hanging pendulum at rest stays there (a stable
    equilibrium), earning ``cos(pi) = -1`` each step: ``-(1 - gamma^H) / (1 - gamma)``."""
    gamma, steps = 0.9, 50
    still = lambda o, t: np.zeros((len(o), 1))  # noqa: E731
    task = TASKS[PAPER_PENDULUM_ID]
    returns = policy_returns(still, task, np.array([[-math.pi, 0.0]]), gamma, steps, 3)
    np.testing.assert_allclose(returns, -(1 - gamma**steps) / (1 - gamma), rtol=1e-10)


def test_policy_returns_pass_the_step_to_the_policy() -> None:
    """Brute force: a deterministic feedback policy that depends on the step index, stepped
    through ``PaperPendulum`` itself from each start state; every rollout of a deterministic
    policy is the same."""
    gamma, steps = 0.9, 40
    states = np.array([[0.3, -1.0], [-2.5, 4.0], [3.0, 0.5]])

    def act(obs: np.ndarray, step: int) -> np.ndarray:
        return (-2.0 * obs[:, 1] + 0.1 * step)[:, None]

    returns = policy_returns(act, TASKS[PAPER_PENDULUM_ID], states, gamma, steps, 2)
    env = PaperPendulum()
    for state, got in zip(states, returns, strict=True):
        env.reset(options={"state": state})
        total = 0.0
        for step in range(steps):
            _, r, *_ = env.step(act(env.state[None], step)[0])
            total += gamma**step * r
        np.testing.assert_allclose(got, total, rtol=1e-12)


def test_model_returns_leave_gsde_training_as_it_was() -> None:
    """PPO with gSDE on the paper's pendulum, its noise resampled every 4 steps: Monte Carlo
    returns of its policy taken in the middle of those 4 steps (gSDE resampled in them as in
    training) leave its parameters bit for bit as without them; the same seed gives the same
    returns, another seed others."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback

    taken: list[np.ndarray] = []

    class Take(BaseCallback):
        def _on_step(self) -> bool:
            if self.n_calls % 16 == 2:  # the next step draws with the exploration matrices
                obs = np.asarray(self.locals["new_obs"], dtype=np.float64)
                taken.extend(
                    model_returns(self.model, TASKS[PAPER_PENDULUM_ID], obs, 12, 2, seed)
                    for seed in (7, 7, 8)
                )
            return True

    def train(callbacks: list[BaseCallback]) -> PPO:
        env = make_vec_env(PAPER_PENDULUM_ID, n_envs=2, seed=3)
        model = PPO("MlpPolicy", env, n_steps=32, batch_size=32, use_sde=True, sde_sample_freq=4,
                    seed=3)  # fmt: skip
        return model.learn(3 * 64, callback=callbacks)

    with_returns, plain = train([Take()]), train([])
    for a, b in zip(with_returns.policy.parameters(), plain.policy.parameters(), strict=True):
        assert th.equal(a, b)
    assert len(taken) == 18 and all(r.shape == (2, 2) for r in taken)
    for same, again, other in zip(taken[::3], taken[1::3], taken[2::3], strict=True):
        assert np.array_equal(same, again) and not np.array_equal(same, other)


def _ppo_rollout_with_truncations():  # type: ignore[no-untyped-def]
    """A real PPO rollout on CartPole with a 12-step time limit (so that SB3 bootstraps at
    truncations), the critic fit script's recorder reading it."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback

    from tests.test_examples_training import load_script

    critic_fit = load_script("critic_fit")
    seen: list[tuple[Rollout, np.ndarray, np.ndarray]] = []

    class Read(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_rollout_end(self) -> None:
            rollout = recorder.rollout()
            with th.no_grad():
                states = th.as_tensor(rollout.states(), dtype=th.float32, device=self.model.device)
                values = self.model.policy.predict_values(states).cpu()
            seen.append((rollout, values.numpy()[:, 0], self.model.rollout_buffer.returns.copy()))

    env = make_vec_env("CartPole-v1", n_envs=3, seed=0, env_kwargs=dict(max_episode_steps=12))
    model = PPO("MlpPolicy", env, n_steps=40, batch_size=60, gamma=0.97, gae_lambda=0.9, seed=0)
    recorder = critic_fit.WithCeiling("CartPole-v1", first=0, n_rollouts=2, tail=0.1, seed=0)
    model.learn(120, callback=[recorder, Read()])
    return model, seen


def test_rollout_returns_are_sb3s_with_its_bootstrap_at_truncations() -> None:
    """Reference: SB3's own ``RolloutBuffer.returns``, recomputed from the recorded rewards,
    starts and truncations with the MLP critic's values at the rollout's states."""
    model, seen = _ppo_rollout_with_truncations()
    assert len(seen) == 1
    rollout, values, sb3_returns = seen[0]
    assert len(rollout.truncations) > 0  # the time limit cut episodes inside the rollout
    got = rollout.returns(values, model.gamma, model.gae_lambda)
    np.testing.assert_allclose(got, sb3_returns, rtol=1e-5, atol=1e-5)


def _always_right_rollout(steps: int, n_envs: int) -> Rollout:
    """A rollout of the policy that always pushes right, stepped by gymnasium's CartPole in
    SB3's vector env with a 9-step time limit: about as many episodes fall as are truncated."""
    env = make_vec_env("CartPole-v1", n_envs=n_envs, seed=0, env_kwargs=dict(max_episode_steps=9))
    obs, starts = env.reset(), np.ones(n_envs, dtype=bool)
    rows: dict[str, list[np.ndarray]] = {"obs": [], "rewards": [], "starts": []}
    truncations = []
    for t in range(steps):
        rows["obs"].append(obs)
        rows["starts"].append(starts.astype(np.float64))
        obs, rewards, starts, infos = env.step(np.ones(n_envs, dtype=np.int64))
        rows["rewards"].append(rewards.astype(np.float64))
        for e, info in enumerate(infos):
            if starts[e] and info.get("TimeLimit.truncated", False):
                truncations.append((t, e, info["terminal_observation"]))
    return Rollout(
        obs=np.array(rows["obs"]),
        rewards=np.array(rows["rewards"]),
        episode_starts=np.array(rows["starts"]),
        last_obs=obs,
        last_dones=starts.astype(np.float64),
        truncations=truncations,
    )


def test_the_ceiling_of_certain_returns_is_one_and_of_a_guess_below() -> None:
    """With a deterministic policy the return from a state is certain, so ``V^pi`` explains
    all of its own GAE returns (ceiling 1, Monte Carlo error 0); a value function that is off
    scores less."""
    rollout = _always_right_rollout(60, 4)
    task, gamma, lam = TASKS["CartPole-v1"], 0.97, 0.9
    ends, truncations = rollout.episode_starts[1:].sum(), len(rollout.truncations)
    assert ends > truncations > 0  # episodes fall and are cut
    right = lambda o, t: np.ones(len(o), dtype=np.int64)  # noqa: E731
    mc = policy_returns(right, task, rollout.states(), gamma, horizon(gamma, 1e-12), 2)
    scores = ceiling(rollout, mc, gamma, lam)
    assert scores["explained"] == pytest.approx(1.0, abs=1e-9)
    assert scores["halves"] == pytest.approx(1.0, abs=1e-9) and scores["mc_se"] == 0.0
    assert scores["check_mean"] == pytest.approx(0.0, abs=1e-9)
    assert scores["mc_ceiling"] == pytest.approx(1.0, abs=1e-9)
    # a critic one above V^pi: the same explained variance of G, its offset measured apart
    n = rollout.rewards.size
    shifted = ceiling(rollout, mc, gamma, lam, critic=mc.mean(axis=1)[:n] + 1)
    assert shifted["mc_critic"] == pytest.approx(shifted["mc_ceiling"], abs=1e-9)
    assert shifted["value_bias"] == pytest.approx(1.0) and shifted["value_rmse"] == pytest.approx(
        1.0
    )
    noisy = mc + np.random.default_rng(0).normal(0, 1, (len(mc), 1))
    assert ceiling(rollout, noisy, gamma, lam)["explained"] < 0.99
    # values one too high: the rollout's own returns fall short of them
    assert ceiling(rollout, mc + 1, gamma, lam)["check_mean"] < -0.1


def test_the_lagged_ceiling_scores_the_earlier_policys_values() -> None:
    """Deterministic policies, so every value is certain. The rollout pushes right; the
    earlier policy pushed left. On G (the rollout's returns bootstrapped with ``V^pi``, which
    are ``V^pi`` itself here) the earlier values explain ``1 - Var(V^pi - V') / Var(V^pi)``,
    computed here from the two value arrays alone; by the goal's reading they are scored on
    their own GAE returns, as the ceiling scores ``V^pi`` (so the same policy twice gives the
    ceiling)."""
    rollout = _always_right_rollout(60, 4)
    task, gamma, lam = TASKS["CartPole-v1"], 0.97, 0.9
    steps, states, n = horizon(gamma, 1e-12), rollout.states(), rollout.rewards.size
    right = lambda o, t: np.ones(len(o), dtype=np.int64)  # noqa: E731
    left = lambda o, t: np.zeros(len(o), dtype=np.int64)  # noqa: E731
    now = policy_returns(right, task, states, gamma, steps, 2)
    before = policy_returns(left, task, states, gamma, steps, 2)
    truth, earlier = now.mean(axis=1)[:n], before.mean(axis=1)[:n]
    assert not np.allclose(truth, earlier)
    lag = lagged_ceiling(rollout, now, before, gamma, lam)
    expected = 1 - np.var(truth - earlier) / np.var(truth)
    assert lag["mc_critic"] == pytest.approx(expected, rel=1e-9)
    assert lag["value_rmse"] == pytest.approx(np.sqrt(np.mean((earlier - truth) ** 2)))
    assert lag["value_bias"] == pytest.approx(np.mean(earlier - truth))
    assert lag["truth_sd"] == pytest.approx(np.std(truth))
    assert lag["explained"] == ceiling(rollout, before, gamma, lam)["explained"]
    same = lagged_ceiling(rollout, now, now, gamma, lam)
    scores = ceiling(rollout, now, gamma, lam)
    assert same["explained"] == scores["explained"] == pytest.approx(1.0, abs=1e-9)
    assert same["mc_critic"] == scores["mc_ceiling"] and same["value_rmse"] == 0.0
    with pytest.raises(ValueError, match="start from"):
        lagged_ceiling(rollout, now, before[:-1], gamma, lam)


def test_the_lagged_ceiling_rolls_out_the_policy_of_the_previous_rollout() -> None:
    """The recorder's lagged ceiling of each scored rollout equals, bit for bit, the one
    computed from a copy of the policy taken at the previous rollout's end (a reference
    callback, before PPO trains on that rollout) with the same seed. With a learning rate of
    0 the policy never changes and the same seed draws the same actions: the lagged ceiling is
    the ceiling."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback

    from tests.test_examples_training import load_script

    critic_fit = load_script("critic_fit")
    task = TASKS["CartPole-v1"]

    def train(learning_rate: float) -> tuple[Any, Any, list[Any]]:
        kept: list[Any] = []

        class Keep(BaseCallback):
            def _on_step(self) -> bool:
                return True

            def _on_rollout_end(self) -> None:
                # PPO's training flattens the buffer in place: read the rollout now
                kept.append((copy.deepcopy(self.model.policy), recorder.rollout()))

        env = make_vec_env("CartPole-v1", n_envs=2, seed=4)
        model = PPO("MlpPolicy", env, n_steps=32, batch_size=64, learning_rate=learning_rate,
                    seed=4)  # fmt: skip
        recorder = critic_fit.WithCeiling(
            "CartPole-v1", first=1, n_rollouts=4, tail=0.1, seed=4, with_lag=True
        )
        model.learn(3 * 64, callback=[recorder, Keep()])
        return model, recorder, kept

    model, recorder, kept = train(3e-3)
    rows = [r["ceiling"] for r in recorder.rows[1:]]
    assert "ceiling" not in recorder.rows[0] and len(rows) == 2
    assert all("lag" in row for row in rows)
    gamma, lam = float(model.gamma), float(model.gae_lambda)
    # the last rollout (index 2), rolled out with its policy and the one before it
    last, steps, seed = kept[2][1], horizon(gamma, 0.1), 4 * 1000 + 2
    reference = [
        model_returns(model, task, last.states(), steps, 4, seed, policy=kept[i][0]) for i in (2, 1)
    ]
    expected = lagged_ceiling(last, *reference, gamma, lam)
    assert rows[-1]["explained"] == ceiling(last, reference[0], gamma, lam)["explained"]
    assert rows[-1]["lag"]["explained"] == expected["explained"]
    assert rows[-1]["lag"]["mc_critic"] == expected["mc_critic"]
    assert rows[-1]["explained"] != rows[-1]["lag"]["explained"]
    _, frozen, _ = train(0.0)
    for row in (r["ceiling"] for r in frozen.rows[1:]):
        assert row["lag"]["explained"] == row["explained"]
        assert row["lag"]["value_rmse"] == 0.0


def test_reference_advantages_vanish_where_returns_are_certain() -> None:
    """Bellman: with a deterministic policy and ``V^pi`` exact, every TD error is 0, so the
    reference advantages are 0, at falls and time-limit cuts too. With ``V^pi`` off by noise
    they are not, and a critic's advantages are scored by their correlation with them."""
    rollout = _always_right_rollout(60, 4)
    task, gamma, lam = TASKS["CartPole-v1"], 0.97, 0.9
    right = lambda o, t: np.ones(len(o), dtype=np.int64)  # noqa: E731
    mc = policy_returns(right, task, rollout.states(), gamma, horizon(gamma, 1e-12), 2)
    np.testing.assert_allclose(reference_advantages(rollout, mc, gamma, lam), 0.0, atol=1e-9)
    rng = np.random.default_rng(1)
    same_noise = mc + rng.normal(0, 1, (len(mc), 1))  # both halves alike
    reference = reference_advantages(rollout, same_noise, gamma, lam)
    assert reference.std() > 0.1
    scores = ceiling(rollout, same_noise, gamma, lam, advantages=3 * reference - 2)
    assert scores["advantage_correlation"] == pytest.approx(1.0)
    assert scores["advantage_reliability"] == pytest.approx(1.0)
    noise = mc + rng.normal(0, 1, mc.shape)  # the halves disagree
    scores = ceiling(rollout, noise, gamma, lam, advantages=-reference)
    assert scores["advantage_reliability"] < 0.9
    flat = ceiling(rollout, noise, gamma, lam, advantages=np.ones_like(reference))
    assert np.isnan(flat["advantage_correlation"])


@pytest.mark.parametrize(("gamma", "lam"), [(0.98, 0.8), (0.99, 0.94), (0.9, 0.95)])
def test_own_value_weight_is_what_sb3s_gae_puts_of_the_values_in_its_targets(
    gamma: float, lam: float
) -> None:
    """Brute force through SB3's recursion: zero rewards, values 1 along a long episode; the
    first step's target is the critic's own values, weighted by the closed form."""
    T = 3000
    values = np.ones((T, 1))
    advantages = gae(
        np.zeros((T, 1)), values, np.zeros((T, 1)), np.ones(1), np.zeros(1), gamma, lam
    )
    assert advantages[0, 0] + values[0, 0] == pytest.approx(own_value_weight(gamma, lam), rel=1e-9)


def _random_rollout(rng: np.random.Generator, steps: int = 6, n_envs: int = 4) -> Rollout:
    return Rollout(
        obs=rng.normal(size=(steps, n_envs, 3)),
        rewards=rng.normal(size=(steps, n_envs)),
        episode_starts=rng.random((steps, n_envs)) < 0.2,
        last_obs=rng.normal(size=(n_envs, 3)),
        last_dones=np.zeros(n_envs),
        truncations=[],
    )


def test_capacity_fits_the_first_envs_and_scores_the_others() -> None:
    """Brute force: a model that predicts the mean of its training targets scores ``1 - mean((m
    - V)^2) / Var(V)`` on envs 2-3, with ``m`` the mean over envs 0-1 of ``V^pi`` (exact), of the
    rollout's own returns (G), and over all envs of the previous rollout's ``V^pi`` (lag); each
    env's block starts a trajectory; the critic is scored on envs 2-3."""
    rng = np.random.default_rng(3)
    rollout, old = _random_rollout(rng), _random_rollout(rng)
    values, old_values = rng.normal(size=6 * 4 + 4), rng.normal(size=6 * 4 + 4)
    critic = rng.normal(size=6 * 4)
    fed: list[tuple[np.ndarray, np.ndarray]] = []

    def mean_fit(x: np.ndarray, y: np.ndarray, starts: np.ndarray):  # type: ignore[no-untyped-def]
        fed.append((x, starts))
        return lambda z: np.full(len(z), y.mean())

    out = capacity({"mean": mean_fit}, rollout, values, 0.9, critic, (old, old_values))
    truth = values[:24].reshape(6, 4)
    test = truth[:, 2:]

    def r2(pred: np.ndarray) -> float:
        return float(1 - np.mean((pred - test) ** 2) / test.var())

    g = rollout.returns(values, 0.9, 1.0)
    assert out["mean|exact"] == pytest.approx(r2(np.full_like(test, truth[:, :2].mean())))
    assert out["mean|G"] == pytest.approx(r2(np.full_like(test, g[:, :2].mean())))
    assert out["mean|lag"] == pytest.approx(r2(np.full_like(test, old_values[:24].mean())))
    assert out["critic"] == pytest.approx(r2(critic.reshape(6, 4)[:, 2:]))
    x_exact, starts = fed[0]
    np.testing.assert_array_equal(x_exact[:6], rollout.obs[:, 0])  # env 0, in time order
    assert starts[0] and starts[6] and len(starts) == 12
    with pytest.raises(ValueError, match="at least 2 environments"):
        capacity({}, _random_rollout(rng, n_envs=1), values[:7], 0.9, critic[:6])


def test_knn_and_mlp_fits_recover_a_smooth_function() -> None:
    """One nearest neighbour returns the training targets at the training points; the MLP fit
    explains most of a smooth function's variance on points it was not fitted to."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (600, 2))
    y = np.sin(2 * x[:, 0]) + x[:, 1] ** 2
    starts = np.zeros(600, dtype=bool)
    np.testing.assert_array_equal(knn_fit(1)(x, y, starts)(x), y)
    predict = mlp_fit(steps=800)(x[:400], y[:400], starts[:400])
    assert value_r2(predict(x[400:]), y[400:]) > 0.95
    assert math.isnan(value_r2(np.zeros(3), np.ones(3)))


def test_the_maze_ceiling_leaves_ppo_as_it_was_and_its_returns_agree() -> None:
    """On WallMaze-v0 (continuous 2-D actions, time-limit cuts) the recorder's Monte Carlo runs
    in a forked random stream: PPO's parameters end bit for bit as without it. The restarted
    rollouts are the task's and the policy's: the rollout's own returns, bootstrapped with
    ``V^pi``, average ``V^pi`` within their sampling error and the Monte Carlo horizon's cut
    (at most ``tail``, as every reward is -1). The four rollouts are pooled: each one's standard
    error rests on 4 environments only, too few for a 4-sigma bound per rollout."""
    from stable_baselines3 import PPO

    from tests.test_examples_training import load_script

    critic_fit = load_script("critic_fit")
    env_id = "sb3_geogp/WallMaze-v0"

    def train(callbacks: list[Any]) -> PPO:
        env = make_vec_env(env_id, n_envs=4, seed=1, env_kwargs=dict(max_episode_steps=25))
        model = PPO("MlpPolicy", env, n_steps=48, batch_size=64, gamma=0.9, seed=1)
        return model.learn(4 * 192, callback=callbacks)

    tail = 0.001
    recorder = critic_fit.WithCeiling(env_id, first=0, n_rollouts=16, tail=tail, seed=1)
    with_ceiling, plain = train([recorder]), train([])
    for a, b in zip(with_ceiling.policy.parameters(), plain.policy.parameters(), strict=True):
        assert th.equal(a, b)
    rows = [r["ceiling"] for r in recorder.rows]
    assert len(rows) == 4
    for row in rows:
        assert -1.0 <= row["advantage_correlation"] <= 1.0
        assert row["truth_sd"] > 0 and row["mc_se"] > 0
    check_mean = np.mean([row["check_mean"] for row in rows])
    check_se = math.sqrt(sum(row["check_se"] ** 2 for row in rows)) / len(rows)
    assert abs(check_mean) <= 4 * check_se + tail
