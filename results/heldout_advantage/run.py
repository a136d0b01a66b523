"""Are the default GP critic's advantages worse than an MLP critic's on PPO
InvertedPendulum-v5? (session 82, exploratory; session 81's open question,
``results/heldout_noise``)

Trains PPO on InvertedPendulum-v5 as ``results/heldout_noise/run.py`` does (the zoo's entry,
50,000 steps; its arms). Every ``--every``-th rollout that holds no time-limit truncation is
scored before any critic learns from it:

1. ``V^pi`` of the current policy at each of the rollout's states and at the state after its
   last step, by Monte Carlo: ``--rollouts`` rollouts of the current stochastic policy from
   each state, restarted exactly in MuJoCo (:class:`InvertedPendulumTask`; the observation is
   the state ``(qpos, qvel)``, float32-rounded), without a time limit and cut after
   ``--horizon`` steps (``gamma ** 1000 = 0.37`` of a return is left beyond the default's cut:
   the reference is ``V^pi`` of that horizon, exact for the states whose rollouts all fall
   before it);
2. the reference advantages: GAE (the entry's ``gamma`` and ``gae_lambda``) of the rollout's
   rewards with ``V^pi``;
3. each critic's GAE advantages, scored against the reference by
   :func:`sb3_geogp.studies.advantage_error.advantage_scores` (their correlation is what PPO's
   per-minibatch standardisation leaves of them): the run's own critic (the advantages PPO
   trains on), a shadow MLP critic that learns beside it from every rollout as the zoo's MLP
   critic learns in ``VecNormalize`` (:class:`MLPShadow`; also scored in return units,
   ``mlp_shadow_return_units``), and the GP critics of ``--shadows``, fed as
   ``GPValueCallback`` would feed them, all on the same rollouts.

The split-half agreement of the reference (Spearman-Brown to all rollouts) bounds every
critic's correlation alike (``sqrt`` of it). The scorer and the shadow draw from their own
random streams: the run trains as it would without them.

The runs of docs/results.md (session 82), each about 45 minutes on 2 cores::

    python results/heldout_advantage/run.py --shadows gp_rbf gp_sb3_returns gp_no_trend
    python results/heldout_advantage/run.py --out results/heldout_advantage/runs_start \
        --shadows gp_ls_late gp_follow_spread gp_no_prior
    python results/heldout_advantage/read.py > results/heldout_advantage/read.md

Each run writes ``runs/<arm>__s<seed>.json``: its settings, provenance and one row per scored
rollout.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
import stable_baselines3
import torch as th
from mujoco import rollout
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.running_mean_std import RunningMeanStd
from stable_baselines3.common.vec_env import VecNormalize
from torch import nn

from sb3_geogp.comparison.shadow import (
    ActorDrift,
    NumpyValue,
    own_feed,
    own_value,
    posterior_mean,
)
from sb3_geogp.studies.advantage_error import advantage_scores, gae
from sb3_geogp.studies.value_ceiling import RestartableTask, model_returns
from sb3_geogp.toolbox.provenance import provenance

HERE = Path(__file__).resolve().parent


def _load_noise() -> Any:
    """``results/heldout_noise/run.py``: the arms and how a run is built."""
    spec = importlib.util.spec_from_file_location(
        "heldout_noise_run", HERE.parent / "heldout_noise/run.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


noise = _load_noise()

#: Shadows of the default GP critic (``gp_actor_normalized``) whose kernel starts from the
#: given lengthscales instead of its first batch's standard deviations: these are the
#: standard deviations of the GP critic's agent's states between 10,000 and 30,000 steps
#: (seed 1023), where the first batch's are about ten times smaller in the cart's position.
STARTS = {"gp_ls_late": (0.33, 0.05, 0.55, 0.95)}
#: ``VecNormalize``'s defaults, which the zoo's ``normalize: true`` keeps.
CLIP, EPSILON = 10.0, 1e-8


def return_scale(ret_rms: RunningMeanStd) -> float:
    """Raw return units per normalised unit of rewards normalised by ``ret_rms``, now."""
    return float(np.sqrt(ret_rms.var + EPSILON))


#: The shadows ``--shadows`` takes, and the arm each is built as.
SHADOW_ARMS = {
    **{
        n: n
        for n, a in noise.ARMS.items()
        if a.critic != "mlp" and a.vec_normalize is None and not a.entry
    },
    **{n: "gp_actor_normalized" for n in STARTS},
}


class InvertedPendulumTask:
    """InvertedPendulum-v5 restarted from its observations ``(qpos, qvel)``, batched through
    ``mujoco.rollout`` (the environment's model, ``frame_skip`` physics steps per action)."""

    def __init__(self) -> None:
        env = gym.make(noise.ENV_ID).unwrapped
        self.model, self.frame_skip = env.model, env.frame_skip  # type: ignore[attr-defined]
        self.data = mujoco.MjData(self.model)
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.size = mujoco.mj_stateSize(self.model, self.spec)
        self.high = float(env.action_space.high[0])  # type: ignore[index]
        env.close()

    def step(self, states: np.ndarray, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Next states, shape (n, 4), and whether each step ends its episode (the pole past
        0.2 rad or the state not finite, as the environment's ``step``)."""
        initial = np.zeros((len(states), self.size))
        initial[:, 1:5] = states  # [time, qpos (2), qvel (2)]
        control = np.clip(actions, -self.high, self.high).reshape(len(states), 1, -1)
        out, _ = rollout.rollout(
            self.model, self.data, initial, np.repeat(control, self.frame_skip, axis=1)
        )
        after = out[:, -1, 1:5]
        return after, ~np.isfinite(after).all(axis=1) | (np.abs(after[:, 1]) > 0.2)

    def restartable(self, observe: Any) -> RestartableTask:
        """The task for :func:`model_returns`; ``observe`` maps states to what the policy
        sees. The reward is 1 for every step but the one that ends the episode (v5's)."""
        return RestartableTask(
            lambda obs: np.asarray(obs, dtype=np.float64),
            observe,
            self.step,
            lambda _s, _a, done: 1.0 - done,
        )


class MLPShadow:
    """SB3's MLP critic as the zoo trains it in ``VecNormalize``, learning beside a run.

    Its observations and rewards are normalised as ``VecNormalize`` normalises them, step by
    step with running statistics of its own; its network is ``MlpPolicy``'s value network
    ((64, 64) tanh, orthogonal initialisation); after each rollout it takes the PPO entry's
    epochs of Adam steps on ``vf_coef`` times the squared error to its own GAE returns, one
    minibatch of ``batch_size`` at most, its gradient clipped to ``max_grad_norm`` (PPO clips
    the actor's and critic's together).
    """

    def __init__(self, dim: int, entry: dict[str, Any], seed: int) -> None:
        self.gamma, self.lam = float(entry["gamma"]), float(entry["gae_lambda"])
        self.epochs, self.batch = int(entry["n_epochs"]), int(entry["batch_size"])
        self.vf_coef, self.max_norm = float(entry["vf_coef"]), float(entry["max_grad_norm"])
        with th.random.fork_rng():
            th.manual_seed(seed)
            self.net = nn.Sequential(
                nn.Linear(dim, 64), nn.Tanh(), nn.Linear(64, 64), nn.Tanh(), nn.Linear(64, 1)
            )
            for layer, gain in zip(self.net[::2], (np.sqrt(2), np.sqrt(2), 1.0), strict=True):
                nn.init.orthogonal_(layer.weight, gain=gain)
                nn.init.zeros_(layer.bias)
        self.optimizer = th.optim.Adam(
            self.net.parameters(), lr=float(entry["learning_rate"]), eps=1e-5
        )
        self.obs_rms, self.ret_rms = RunningMeanStd(shape=(dim,)), RunningMeanStd(shape=())
        self.ret = 0.0
        self.obs: list[np.ndarray] = []
        self.rewards: list[float] = []

    def normalize(self, raw: np.ndarray) -> np.ndarray:
        scaled = (raw - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + EPSILON)
        return np.clip(scaled, -CLIP, CLIP)

    def reset(self, first: np.ndarray) -> None:
        """The first observation of the run."""
        self.obs_rms.update(first[None])
        self.last = self.normalize(first)

    def step(self, new_raw: np.ndarray, reward: float, done: bool) -> None:
        """One environment step, as ``VecNormalize.step_wait`` sees it."""
        self.obs_rms.update(new_raw[None])
        self.ret = self.ret * self.gamma + reward
        self.ret_rms.update(np.array([self.ret]))
        self.obs.append(self.last)
        self.rewards.append(float(np.clip(reward / return_scale(self.ret_rms), -CLIP, CLIP)))
        self.last = self.normalize(new_raw)
        if done:
            self.ret = 0.0

    def values(self, normalized: np.ndarray) -> np.ndarray:
        with th.no_grad():
            return self.net(th.as_tensor(normalized, dtype=th.float32)).numpy().ravel()

    def values_now(self) -> np.ndarray:
        """Its values at this rollout's states and the state after it, shape (T + 1,)."""
        return self.values(np.concatenate([np.array(self.obs), self.last[None]]))

    def advantages(self, starts: np.ndarray, last_done: bool) -> tuple[np.ndarray, np.ndarray]:
        """This rollout's values and GAE advantages (normalised units), shape (T,) each."""
        v = self.values(np.array(self.obs))
        last_v = self.values(self.last[None])
        a = gae(
            np.array(self.rewards)[:, None],
            v[:, None],
            starts[:, None],
            last_v,
            np.array([last_done], float),
            self.gamma,
            self.lam,
        )
        return v, a.ravel()

    def learn(self, starts: np.ndarray, last_done: bool) -> None:
        """Train on this rollout's GAE returns, then start the next rollout."""
        v, a = self.advantages(starts, last_done)
        x = th.as_tensor(np.array(self.obs), dtype=th.float32)
        returns = th.as_tensor(v + a, dtype=th.float32)
        for _ in range(self.epochs):
            for lo in range(0, len(x), self.batch):
                loss = (
                    self.vf_coef
                    * (
                        (self.net(x[lo : lo + self.batch]).ravel() - returns[lo : lo + self.batch])
                        ** 2
                    ).mean()
                )
                self.optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(self.net.parameters(), self.max_norm)
                self.optimizer.step()
        self.obs, self.rewards = [], []

    def scale(self) -> float:
        """Raw return units per normalised unit, now."""
        return return_scale(self.ret_rms)


class AdvantageScorer(BaseCallback):
    """Feeds the shadow every step and scores every ``every``-th rollout free of truncations.
    Pass it before the callbacks that let the run's critic learn from the rollout."""

    def __init__(
        self,
        task: InvertedPendulumTask,
        shadow: MLPShadow,
        gp_shadows: dict[str, NumpyValue],
        args: argparse.Namespace,
        seed: int,
    ) -> None:
        super().__init__()
        self.task, self.shadow, self.args, self.seed = task, shadow, args, seed
        self.gp_shadows = gp_shadows
        self.rows: list[dict[str, Any]] = []
        self.n_rollouts = 0

    def raw_obs(self) -> np.ndarray:
        env = self.model.get_env()
        if isinstance(env, VecNormalize):
            return np.asarray(env.get_original_obs(), dtype=np.float64)[0]
        return np.asarray(self.model._last_obs, dtype=np.float64)[0]  # type: ignore[index]

    def _on_training_start(self) -> None:
        self.shadow.reset(self.raw_obs())

    def _on_rollout_start(self) -> None:
        self.states = [self.raw_obs()]
        self.truncated = False

    def _on_step(self) -> bool:
        env = self.model.get_env()
        new = self.locals["new_obs"]
        seen = env.get_original_obs() if isinstance(env, VecNormalize) else new  # type: ignore[union-attr]
        # after an episode's end this is the next episode's first state, as VecNormalize's
        # statistics see it
        raw = np.asarray(seen, dtype=np.float64)[0]
        done = bool(self.locals["dones"][0])
        truncated = bool(self.locals["infos"][0].get("TimeLimit.truncated", False))
        self.truncated |= truncated
        self.states.append(raw)
        self.shadow.step(raw, 0.0 if done and not truncated else 1.0, done)
        return True

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer
        starts = buffer.episode_starts[:, 0].astype(float)
        last_done = bool(self.model._last_episode_starts[0])  # type: ignore[index]
        self.n_rollouts += 1
        if self.n_rollouts % self.args.every == 0 and not self.truncated:
            self.rows.append(self.score(starts, last_done))
        self.shadow.learn(starts, last_done)

    def observe(self) -> Any:
        env = self.model.get_env()
        if isinstance(env, VecNormalize):
            return lambda s: env.normalize_obs(s.astype(np.float32))
        return lambda s: s

    def score(self, starts: np.ndarray, last_done: bool) -> dict[str, Any]:
        states = np.array(self.states)  # (T + 1, 4): each step's start, then the last state
        T = len(states) - 1
        ends = np.append(starts[1:], float(last_done))
        rewards = 1.0 - ends  # every step's reward but a fall's; no truncation here
        task = self.task.restartable(self.observe())
        seed = self.seed * 100_000 + self.n_rollouts
        g = model_returns(self.model, task, states, self.args.horizon, self.args.rollouts, seed)
        gamma, lam = float(self.model.gamma), float(self.model.gae_lambda)

        def advantages(v: np.ndarray, r: np.ndarray = rewards) -> np.ndarray:
            return gae(
                r[:, None],
                v[:T, None],
                starts[:, None],
                v[T:],
                np.array([last_done], float),
                gamma,
                lam,
            ).ravel()

        true_v = g.mean(axis=1)
        reference = advantages(true_v)
        halves = [advantages(g[:, k::2].mean(axis=1)) for k in (0, 1)]
        half = float(np.corrcoef(*halves)[0, 1])
        # The run's critic on what it sees (VecNormalize's observations and rewards for the
        # MLP critic): with deferred values a GP critic's buffer values are placeholders
        # until GPValueCallback fills them from the GP as it is now, before it learns.
        buffer = self.model.rollout_buffer
        seen = np.concatenate([buffer.observations[:, 0], self.model._last_obs])  # type: ignore[list-item]
        seen = seen.astype(np.float64)
        own_v = own_value(self.model)(seen)
        own_a = advantages(own_v, buffer.rewards[:, 0].astype(np.float64))
        env = self.model.get_env()
        normalized = isinstance(env, VecNormalize) and env.norm_reward
        own_scale = return_scale(env.ret_rms) if normalized else 1.0  # type: ignore[union-attr]
        shadow_v, shadow_a = self.shadow.advantages(starts, last_done)
        # GP shadows run beside a GP critic only (main() refuses VecNormalize): they see what
        # it sees, the raw observations.
        gp_shadows = {
            name: advantage_scores(reference, advantages(v := value(seen)), true_v[:T], v[:T])
            for name, value in self.gp_shadows.items()
        }
        row: dict[str, Any] = dict(
            step=int(self.num_timesteps),
            falls=int(ends.sum()),
            reliability=2 * half / (1 + half),
            v_pi_mean=float(true_v[:T].mean()),
            own=advantage_scores(reference, own_a, true_v[:T], own_v[:T] * own_scale),
            mlp_shadow=advantage_scores(
                reference, shadow_a, true_v[:T], shadow_v * self.shadow.scale()
            ),
            # The shadow's values in return units with the rollout's own rewards: advantages
            # in the reference's units, for the parts (slope, error gain) that need them.
            mlp_shadow_return_units=advantage_scores(
                reference,
                advantages(scaled := self.shadow.values_now() * self.shadow.scale()),
                true_v[:T],
                scaled[:T],
            ),
            **gp_shadows,
        )
        return row


def run(arm: str, seed: int, args: argparse.Namespace) -> str:
    warnings.filterwarnings("ignore", category=UserWarning)
    th.set_num_threads(1)
    # The shadows first: building a model seeds every random stream, so the run's own build,
    # last, leaves them as a run without shadows has them.
    shadow_models = {n: noise.build(SHADOW_ARMS[n], seed)[0] for n in args.shadows}
    for name, shadow_model in shadow_models.items():
        shadow_model.get_env().close()  # type: ignore[union-attr]
        if name in STARTS:
            shadow_model.policy.gp.kernel.lengthscale.copy_(th.tensor(STARTS[name]))
    model, callbacks = noise.build(arm, seed)
    drift = ActorDrift()
    gp_values = {n: posterior_mean(m.policy.gp) for n, m in shadow_models.items()}
    feeds = [
        own_feed(
            drift.learner(m.policy.gp),
            gp_values[n],
            noise.ARMS[SHADOW_ARMS[n]].callback_kwargs,
            model,
        )
        for n, m in shadow_models.items()
    ]
    entry = dict(
        gamma=model.gamma,
        gae_lambda=model.gae_lambda,
        n_epochs=model.n_epochs,
        batch_size=model.batch_size,
        vf_coef=model.vf_coef,
        max_grad_norm=model.max_grad_norm,
        learning_rate=model.learning_rate,
    )
    shadow = MLPShadow(4, entry, seed + 7_000_000)
    scorer = AdvantageScorer(InvertedPendulumTask(), shadow, gp_values, args, seed)
    start = time.perf_counter()
    model.learn(args.steps, callback=[scorer, drift, *feeds, *callbacks])
    seconds = time.perf_counter() - start
    model.get_env().close()  # type: ignore[union-attr]
    episodes = [float(i["r"]) for i in list(model.ep_info_buffer)[-5:]]
    info = dict(
        arm=arm,
        seed=seed,
        steps=args.steps,
        seconds=seconds,
        every=args.every,
        rollouts=args.rollouts,
        horizon=args.horizon,
        shadows=args.shadows,
        last_episodes=episodes,
        provenance=provenance(stable_baselines3, gym),
        rows=scorer.rows,
    )
    (args.out / f"{arm}__s{seed}.json").write_text(json.dumps(info, indent=1, default=str))
    scored, last = len(scorer.rows), np.mean(episodes)
    return f"{arm} seed {seed}: {seconds:.0f} s, {scored} scored, last episodes {last:.0f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "runs")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--arms",
        nargs="+",
        default=["gp_actor_normalized"],
        choices=list(noise.ARMS),
    )
    parser.add_argument(
        "--shadows",
        nargs="+",
        default=[],
        choices=list(SHADOW_ARMS),
        help="GP critics (heldout_noise arms) that learn beside a GP critic's run, fed as "
        "GPValueCallback would feed them",
    )
    parser.add_argument("--first-seed", type=int, default=noise.SEEDS[0])
    parser.add_argument("--seeds", type=int, default=10, help="how many seeds")
    parser.add_argument("--steps", type=int, default=noise.STEPS, help="training steps per run")
    parser.add_argument("--every", type=int, default=16, help="score every n-th rollout")
    parser.add_argument("--rollouts", type=int, default=16, help="Monte Carlo rollouts per state")
    parser.add_argument("--horizon", type=int, default=1000, help="steps per Monte Carlo rollout")
    args = parser.parse_args()
    if args.shadows and any(noise.ARMS[a].vec_normalize is not None for a in args.arms):
        parser.error("--shadows learn from raw observations: give GP arms without VecNormalize")
    args.out.mkdir(parents=True, exist_ok=True)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    todo = [(a, s) for a in args.arms for s in seeds if not (args.out / f"{a}__s{s}.json").exists()]
    print(f"{len(todo)} runs to make", flush=True)
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(run, a, s, args) for a, s in todo]
        for i, future in enumerate(futures, 1):
            print(f"[{i}/{len(todo)}] {future.result()}", flush=True)


if __name__ == "__main__":
    main()
