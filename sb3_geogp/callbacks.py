"""``GPValueCallback``: feeds the GP critic each rollout of PPO, A2C, TRPO or MaskablePPO.

SB3 computes a rollout's returns and advantages in ``collect_rollouts`` with the critic that
collected it, then calls ``on_rollout_end``, then ``train``. Feeding the GP at
``on_rollout_end`` therefore mirrors the MLP critic (advantages of a rollout use the critic
from before that rollout's update); ``recompute_advantages=True`` recomputes them with the
freshly updated GP instead.

This module only adapts: it reorders SB3's time-major ``(n_steps, n_envs)`` buffer into
per-environment trajectories, takes targets from :mod:`sb3_geogp.targets` and logs.
"""

from __future__ import annotations

import math
from typing import Any, Literal, NamedTuple, cast

import numpy as np
import torch as th
from stable_baselines3 import A2C
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecFrameStack, VecNormalize, unwrap_vec_wrapper

from sb3_geogp.drift import drift_keyword
from sb3_geogp.options import positive_int
from sb3_geogp.policies import GPCriticMixin, _contrib_algorithms, _for_algorithm, check_algorithm
from sb3_geogp.targets import Segment, completed_returns, empty_segment, env_major, per_env
from sb3_geogp.user_warnings import warn_user

Target = Literal["returns", "monte_carlo"]

#: What :class:`GPValueCallback` feeds the GP critic where ``target`` is unset, unless the
#: algorithm is in :data:`DEFAULT_TARGETS`: since 0.24 Monte Carlo returns, for the PPO family
#: (PPO, TRPO, MaskablePPO). In its pre-registered adoption test on issue 13's 40 PPO seeds
#: (docs/results.md, "Monte Carlo targets under PPO") no PPO cell was worse than SB3's returns
#: at 95 % nor than SB3's MLP critic family-wise; against the returns Acrobot-v1 gained +115.5
#: [+51.5, +177.9] and CartPole-v1 +41.6 [+9.6, +77.7] (final return; found on those seeds, a
#: screen). 0.23's default: ``GPValueCallback(target="returns")``.
DEFAULT_TARGET: Target = "monte_carlo"
#: Algorithms whose GP critic is fed another target by default: A2C keeps SB3's returns, where
#: Monte Carlo targets lost Acrobot-v1 (sessions 32-34, docs/results.md, "Monte Carlo targets
#: cut after 100 steps").
DEFAULT_TARGETS: dict[type[BaseAlgorithm], Target] = {A2C: "returns"}


def default_target(algorithm: type[BaseAlgorithm] | None) -> Target:
    """What :class:`GPValueCallback` feeds the GP critic of a policy trained by ``algorithm``
    where ``target`` is unset: :data:`DEFAULT_TARGETS`, else :data:`DEFAULT_TARGET`."""
    return _for_algorithm(DEFAULT_TARGETS, DEFAULT_TARGET, algorithm)


#: Where ``target`` is unset and the algorithm's default is Monte Carlo returns, they are cut
#: after this many steps (since 0.25), so a step waits at most 200 steps for its target instead
#: of until its episode ends, where the discount leaves the return beyond the cut at least
#: :data:`CUT_WEIGHT` (since 0.26). In its pre-registered test on fresh PPO seeds 320-339
#: (docs/results.md, "Monte Carlo returns cut after 200 steps: PPO's default since 0.25")
#: MountainCarContinuous-v0 (999-step episodes) gained +41.8 [+28.1, +54.2] against the uncut
#: returns; where no episode lasts longer than 200 steps nothing changes.
DEFAULT_HORIZON = 200
#: The least weight ``gamma ** DEFAULT_HORIZON`` at which the default cut applies (since 0.26):
#: where the discount has already shrunk the return beyond the cut, the cut buys little
#: variance and, on a task whose reward never varies until its goal, makes the early targets
#: nearly equal, so the critic learns the constant value of a never-rewarded policy and PPO's
#: advantages vanish. In its registered test (PPO Acrobot-v1, ``gamma`` 0.99, weight 0.13,
#: 100,000 steps, fresh seeds 340-429; docs/results.md, "The 200-step cut at 100,000 steps on
#: Acrobot") 6 of 90 cut runs never swung up against 0 of 90 uncut (p = 0.014) and the uncut
#: returns ended +28.6 [+9.3, +51.9] higher. MountainCarContinuous-v0's ``gamma`` 0.9999 weighs
#: 0.98 and keeps the cut. At ``gamma`` 0.999 (0.82, cut) a registered test on the same task
#: (40 fresh seeds per arm) found no difference: uncut − cut +13.3 [-0.4, +37.3].
CUT_WEIGHT = 0.5


def default_feed(algorithm: type[BaseAlgorithm] | None, gamma: float) -> tuple[Target, int | None]:
    """The target and horizon :class:`GPValueCallback` feeds the GP critic of a policy trained
    by ``algorithm`` with discount ``gamma`` where ``target`` is unset: :func:`default_target`,
    cut after :data:`DEFAULT_HORIZON` steps where that is ``"monte_carlo"`` and
    ``gamma ** DEFAULT_HORIZON >= CUT_WEIGHT``."""
    target = default_target(algorithm)
    cut = target == "monte_carlo" and gamma**DEFAULT_HORIZON >= CUT_WEIGHT
    return target, DEFAULT_HORIZON if cut else None


class _Unfinished(NamedTuple):
    """What a ``learn()`` call leaves for the next: the model's last observation array then
    (a reset replaces it), its step count, the feed rule (target, horizon) and each env's
    steps not yet fed (observations, rewards, episode starts)."""

    last_obs: Any
    num_timesteps: int
    feed_rule: tuple[Target | None, int | None]
    pending: list[Segment]


class GPValueCallback(BaseCallback):
    """Feed a GP critic policy's GP at the end of every rollout.

    The policy is a :class:`~sb3_geogp.GPActorCriticPolicy` (PPO, A2C, sb3-contrib's TRPO) or
    a :class:`~sb3_geogp.MaskableGPActorCriticPolicy` (MaskablePPO).

    Parameters
    ----------
    target : {"returns", "monte_carlo"}, optional
        ``"returns"``: the rollout buffer's returns (TD(lambda) with GAE), the targets SB3's
        MLP critic is trained on. ``"monte_carlo"``: discounted returns of completed episodes
        only, episodes spanning rollouts stitched per environment; a time-limit truncation is
        bootstrapped with the critic's value of the terminal observation (SB3 adds
        ``gamma * V(terminal_observation)`` to that step's reward), a termination is not.
        Steps of unfinished episodes wait for a later rollout; a ``learn`` call that feeds
        nothing (no episode ended) warns, as its critic learnt nothing. ``None`` (default): the
        algorithm's default, :func:`default_feed`, chosen when training starts: for PPO, TRPO
        and MaskablePPO Monte Carlo returns (since 0.24) cut after
        :data:`DEFAULT_HORIZON` = 200 steps (since 0.25) only where ``gamma ** 200 >=
        CUT_WEIGHT`` = 0.5 (since 0.26: e.g. ``gamma=0.9999``, not SB3's default 0.99), for A2C
        ``"returns"``.
    horizon : int, optional
        With ``target="monte_carlo"`` (passed explicitly, as the default target depends on
        the algorithm): cut each return after ``horizon`` steps with the critic's value of the
        state reached then (predicted when the step is fed), so that a step waits at most
        ``horizon`` steps instead of until its episode ends. Under A2C
        with ``gae_lambda=1`` SB3's returns cut at the rollout's end instead. ``None``
        (default): no cut, so ``GPValueCallback(target="monte_carlo")`` feeds 0.24's default,
        the uncut returns. Measured under A2C with ``horizon=100`` (docs/results.md, "Monte
        Carlo targets cut after 100 steps"): better than ``"returns"`` on CartPole-v1, worse on
        Acrobot-v1, whose exploration the critic's early bias above the returns had kept.
    feed_every : int
        Feed the GP every ``feed_every``-th rollout, with the targets of that rollout and the
        ``feed_every - 1`` before it (each env's steps stitched in time order), instead of
        after every rollout. The critic's values stay those of the last feed in between, so
        the rollouts held back are valued by a critic that has not seen them yet. It divides
        the GP's per-update costs (scoring, adaptation) by ``feed_every`` where rollouts are
        short, as A2C's are (40 steps per rollout in the zoo's CartPole-v1 setting). What is
        held is fed at the end of every ``learn`` call, so nothing is dropped. ``1`` (default):
        every rollout. Under A2C, whose targets bootstrap on the critic, ``4`` lost CartPole-v1's
        return in its registered test (docs/results.md, "Feeding the GP every fourth rollout
        under A2C") while cutting the training benchmark's wall clock from 2.3x the MLP
        critic's to 1.4x.
    recompute_advantages : bool
        Recompute the rollout's values, returns and advantages with the updated GP before
        ``train`` (including the time-limit bootstraps). ``False`` (default) keeps SB3's
        timing: the advantages use the critic from before the update, as with an MLP critic.
    deferred_values : bool
        ``True`` (default): no GP prediction at every environment step; the rollout's values
        come from one batched prediction at its end, and SB3's returns and advantages are
        recomputed from them (identical to step-by-step values, tested). Time-limit
        bootstraps and the last values are always predicted when SB3 asks. ``False``: the
        policy predicts the values step by step, as SB3 does with an MLP critic.
    verbose : int
        SB3 verbosity.

    Attributes
    ----------
    target : {"returns", "monte_carlo"} or None
        The target fed: as passed, and once training starts the algorithm's default where
        ``None`` was passed.
    horizon : int or None
        Where Monte Carlo returns are cut: as passed, and once training starts the
        algorithm's default where ``target=None`` was passed.
    update_seconds : float
        Wall-clock seconds spent in GP updates so far.

    Notes
    -----
    Run it before other callbacks that read the rollout buffer at rollout end: until it has
    run, the deferred values are placeholders.

    Logged at every feed (every rollout unless ``feed_every > 1``; SB3 logger, so
    stdout/CSV/TensorBoard):

    * ``gp/explained_variance``, ``gp/mse``: the GP's prediction of the targets it is about
      to be fed, before it absorbs them (out of sample; with ``target="returns"`` these are
      the rollout's own values, so they cost no extra prediction);
    * ``gp/mean_std``: mean predictive standard deviation on those points (before the update,
      at most 1024 evenly spaced ones; recomputed once 256 points have been fed since);
    * ``gp/n_basis``, ``gp/update_ms``, ``gp/n_fed``, ``gp/forgetting``, and
      ``gp/n_components`` (graph components, geodesic kernel);
    * with ``gp_kwargs=dict(adapt=...)``: ``gp/nlpd``, ``gp/lengthscale`` (and per dimension),
      ``gp/signal_var``, ``gp/noise_var``, ``gp/target_mean``, ``gp/target_scale``,
      ``gp/target_drift`` and ``gp/block_fit`` (docs/usage.md, "Logged metrics"), and with
      ``optimism_cap`` ``gp/bonus_scale``;
    * with ``gp_kwargs=dict(drift_forgetting=...)``: ``gp/policy_kl``, how far the actor moved
      since the last feed (:meth:`~sb3_geogp.GPActorCriticPolicy.measure_drift`, summed over
      the rollouts fed), and ``gp/drift_factor``, the weight that left what the GP had
      absorbed before.
    """

    def __init__(
        self,
        target: Target | None = None,
        horizon: int | None = None,
        feed_every: int = 1,
        recompute_advantages: bool = False,
        deferred_values: bool = True,
        verbose: int = 0,
    ) -> None:
        super().__init__(verbose)
        if isinstance(target, dict):
            # SB3 calls a callable that is not a callback with its locals and globals.
            raise TypeError(
                "GPValueCallback was passed to learn() as a class; pass an instance: "
                "model.learn(total_timesteps, callback=GPValueCallback())"
            )
        if target not in (None, "returns", "monte_carlo"):
            raise ValueError(f"target must be None, 'returns' or 'monte_carlo', got {target!r}")
        self._requested_target = target
        self.target: Target | None = target
        if horizon is not None and (
            target != "monte_carlo" or int(horizon) != horizon or horizon < 1
        ):
            raise ValueError(
                "horizon must be None or a positive integer, with target='monte_carlo' passed "
                f"explicitly; got horizon={horizon!r} with target={target!r}"
            )
        self.horizon = None if horizon is None else int(horizon)
        self.feed_every = positive_int("feed_every", feed_every)
        self.recompute_advantages = bool(recompute_advantages)
        self.deferred_values = bool(deferred_values)
        #: Wall-clock seconds spent in GP updates so far (all rollouts of this callback).
        self.update_seconds = 0.0
        # Monte-Carlo: steps of each env's unfinished episode (obs, rewards, episode_starts).
        self._pending: list[Segment] = []
        # Truncations of the current rollout: (step, env, terminal observation).
        self._truncations: list[tuple[int, int, np.ndarray]] = []
        # Rollouts not fed yet (feed_every > 1), as _rollout_targets gives them, and how far
        # the policy moved over them.
        self._held: list[tuple[np.ndarray, ...]] = []
        self._held_drift = 0.0

    # ------------------------------------------------------------------------------------------
    # SB3 hooks
    # ------------------------------------------------------------------------------------------
    def _init_callback(self) -> None:
        policy = self.model.policy
        if not isinstance(policy, GPCriticMixin):
            raise TypeError(
                "GPValueCallback needs a GP critic policy (GPActorCriticPolicy, or "
                f"MaskableGPActorCriticPolicy for MaskablePPO), got {type(policy).__name__}"
            )
        check_algorithm(self.model, type(policy))
        self._check_discount()
        if self._requested_target is None:
            self.target, self.horizon = default_feed(type(self.model), self._discount)
        if isinstance(self.model, _contrib_algorithms("TRPO")):
            # TRPO follows its actor step with gradient steps on the critic's squared error;
            # the GP has no parameters (its values carry no gradient) and learns here instead.
            self.model.n_critic_updates = 0  # type: ignore[attr-defined]
        vec_normalize = self.model.get_vec_normalize_env()
        if vec_normalize is not None and vec_normalize.norm_obs and vec_normalize.training:
            warn_user(
                "VecNormalize keeps updating its observation statistics while the GP's basis "
                "vectors stay in the units they were fed in, so old basis vectors drift away "
                "from new observations. Use norm_obs=False and give the actor alone the "
                "normalisation with policy_kwargs=dict(normalize_actor_obs=True): on issue "
                "13's tasks whose zoo entry normalises, that made the GP critic no worse than "
                "SB3's MLP critic in VecNormalize, where no setting of VecNormalize did "
                "(docs/results.md, 'The GP critic's actor with the zoo's observation "
                "normalisation'). Or freeze the statistics after a warm-up "
                "(vec_env.training = False)."
            )
        self._check_bounds_wrappers(vec_normalize)
        gp = policy.gp
        # An adapting GP chooses its forgetting from the data.
        fixed_full_memory = gp.adaptation is None and gp.forgetting == 1.0
        if isinstance(self.model, A2C) and self.target == "returns" and fixed_full_memory:
            # Measured in docs/results.md: without forgetting the GP averages A2C's short,
            # self-bootstrapped returns over all past rollouts and lags far behind the values
            # (Acrobot: -500 in 20 of 20 runs; with forgetting 0.9 the best A2C critic).
            warn_user(
                "A2C with GP adapt=False and forgetting=1.0: the GP weighs all past "
                "bootstrapped returns equally and its values lag behind. Leave adapt on (the "
                "default; the GP then chooses its forgetting) or pass "
                "policy_kwargs=dict(gp_kwargs=dict(adapt=False, forgetting=0.9, ...)) "
                "(see docs/results.md, 'Control: A2C with GP forgetting 0.9')."
            )
        self._pending = self._continued_episodes()
        # Rollouts and points fed in this learn() call, for _on_training_end's warning.
        self._fed = [0, 0]
        self._warned_still = False
        self._held = []
        self._held_drift = 0.0

    def _on_rollout_start(self) -> None:
        self._truncations = []
        policy = self._policy
        policy.defer_values = self.deferred_values
        if policy.actor_normalizer is not None:
            # Not at the rollout's end: the actor trains on it under the statistics it acted by.
            policy.actor_normalizer.publish()

    def _on_step(self) -> bool:
        truncations = time_limit_truncations(self._algo, self.locals)
        for _, env, terminal in truncations:
            # SB3 asks the critic for V(terminal) right after this hook, one env at a time.
            self._policy.check_observations(
                terminal, f"the final observation of env {env}'s episode, cut by its time limit,"
            )
        if self.recompute_advantages:
            self._truncations += truncations
        return True

    def _on_rollout_end(self) -> None:
        policy = self._policy
        if not policy.awaiting_feed:
            raise RuntimeError(
                "GPValueCallback: this rollout was already fed to the GP critic: the callback "
                "is passed more than once (directly, in a list, or as a zoo callback too); "
                "pass one GPValueCallback"
            )
        policy.defer_values = False
        buffer = self._algo.rollout_buffer
        dones = np.asarray(self.locals["dones"], dtype=bool)
        _check_rewards(buffer)
        if self.deferred_values:
            # SB3 has just computed returns and advantages from placeholder values; with the
            # values of one batched prediction they are what step-by-step values would give.
            self._fill_values(policy, buffer, self.locals["new_obs"], dones)
        # SB3's returns, which the actor's advantages come from, whatever the critic is fed.
        _check_targets(buffer.returns)
        targets = self._rollout_targets(buffer, dones)
        _check_targets(targets[1])
        self._held.append(targets)
        self._held_drift += policy.measure_drift(*rollout_states(buffer))
        self._fed[0] += 1
        if len(self._held) < self.feed_every:
            # Only marks the rollout handled: the GP, and so the advantages, stay as they are.
            policy.update_critic(*empty_segment(buffer.obs_shape))
        else:
            if self.recompute_advantages:
                old_bootstrap = self._bootstrap_values(policy)
            stats = self._feed_held(policy)
            if self.recompute_advantages:
                self._recompute(policy, buffer, dones, old_bootstrap)
            for key, value in stats.items():
                self.logger.record(f"gp/{key}", value)
        if not self._warned_still and not buffer.advantages.any():
            self._warn_still()
        if policy.actor_normalizer is not None:
            policy.actor_normalizer.observe(
                buffer.observations.reshape(buffer.buffer_size * buffer.n_envs, -1)
            )

    def _rollout_targets(self, buffer: RolloutBuffer, dones: np.ndarray) -> tuple[np.ndarray, ...]:
        """What this rollout feeds: SB3's returns as the buffer's time-major ``(observations,
        returns, episode_starts, values)``, copied (the buffer is refilled); Monte Carlo
        targets as ``(observations, targets, starts)`` env by env."""
        if self.target == "returns":
            arrays = (buffer.observations, buffer.returns, buffer.episode_starts, buffer.values)
            return tuple(a.copy() for a in arrays)
        return self._completed_episodes(buffer, dones)

    def _feed_held(self, policy: GPCriticMixin) -> dict[str, float]:
        """Feed the held rollouts in one update; returns ``update_critic``'s statistics."""
        held, self._held = self._held, []
        drift, self._held_drift = self._held_drift, 0.0
        joined = [np.concatenate(arrays) for arrays in zip(*held, strict=True)]
        moved = drift_keyword(drift)
        if self.target == "returns":
            # Stacked in time, each env's steps of consecutive rollouts form one trajectory.
            obs, returns, starts, values = joined
            obs, returns, starts = per_env(obs, returns, starts)
            stats = policy.update_critic(obs, returns, starts, env_major(values), **moved)
        else:
            obs, returns, starts = joined
            stats = policy.update_critic(obs, returns, starts, **moved)
        self._fed[1] += len(returns)
        self.update_seconds += 1e-3 * stats["update_ms"]
        self.on_fed(obs, returns, starts)
        return stats

    def on_fed(self, obs: np.ndarray, targets: np.ndarray, starts: np.ndarray) -> None:
        """Called with every batch right after the GP has learnt it; does nothing here.

        Override it to give other learners the critic's data (the comparison's shadow
        critics do).

        Parameters
        ----------
        obs : ndarray, shape (n, *obs_shape)
            Observations, environment by environment, each in time order.
        targets : ndarray, shape (n,)
            Their targets (empty where a rollout completed no episode).
        starts : ndarray of bool, shape (n,)
            Where a trajectory starts.
        """

    def _warn_still(self) -> None:
        # Measured in docs/results.md ("The 200-step cut at 100,000 steps on Acrobot"): runs
        # that never reach Acrobot's goal end here, at -500, and stay.
        self._warned_still = True
        entropy = (
            "give the actor an entropy bonus (ent_coef > 0; 0.01 got one of three such runs to "
            "the goal)"
        )
        fix = (
            "feed uncut Monte Carlo returns, GPValueCallback(target='monte_carlo'), whose targets "
            f"vary with the time limit for longer (all three runs then reached it), or {entropy}"
            if self.target == "monte_carlo" and self.horizon is not None
            else entropy
        )
        warn_user(
            f"GPValueCallback: every advantage of the rollout ending at step "
            f"{self.num_timesteps} is exactly 0 (the GP critic's values satisfy V(s) = r + "
            "gamma V(s') at every step), so the actor's loss has no gradient but the entropy "
            "bonus's and the policy does not change while this lasts. It happens when every "
            "reward has been the same and the critic has learnt the constant value that follows, "
            "and lasts until a reward differs: harmless where the policy already does what it "
            "should (a pole balanced at every step), fatal where it has not reached its goal yet "
            f"(Acrobot at -500). There, {fix} (docs/results.md, 'The 200-step cut at 100,000 "
            "steps on Acrobot')."
        )

    def _on_training_end(self) -> None:
        policy = self._policy
        policy.defer_values = False
        if self._held:
            self._feed_held(policy)
        # A callback that stops learn() inside a rollout (SB3's StopTrainingOn... callbacks)
        # skips its rollout end: SB3 drops the rollout, and the episodes then running lack its
        # steps, so they cannot be continued (the next call starts new trajectories).
        cut = policy.awaiting_feed
        policy.unfinished_episodes = (
            None
            if cut
            else _Unfinished(
                self.model._last_obs, self.model.num_timesteps, self._feed_rule, self._pending
            )
        )
        # SB3 ends learn() in training mode, in which the policy stands in zeros for the GP's
        # values (evaluate_actions) and reads a user's forward() as an unfed rollout.
        policy.set_training_mode(False)
        rollouts, points = self._fed
        if rollouts and not points:
            # Monte Carlo targets wait for an episode's end or their horizon, and a learn() call
            # that resets the env drops the unfinished ones: short calls could leave the critic
            # unfed.
            wait = "" if self.horizon is None else f" or {self.horizon} steps have followed it"
            warn_user(
                f"GPValueCallback fed the GP critic nothing in this learn() call ({rollouts} "
                f"rollout{'s' * (rollouts > 1)}): with target='monte_carlo' (the PPO family's "
                f"default since 0.24) a step is fed only once its episode ends{wait}, and in this "
                "call none did, so the critic learnt nothing. Its steps wait for the next "
                "learn() call only if that call continues the environment "
                "(reset_num_timesteps=False); a call that resets it drops them. Train for more "
                "steps per environment in one learn() call, continue with "
                "reset_num_timesteps=False, or pass GPValueCallback(target='returns') (SB3's "
                "returns, fed every rollout)."
            )

    # ------------------------------------------------------------------------------------------
    # Helpers
    # ------------------------------------------------------------------------------------------
    @property
    def _feed_rule(self) -> tuple[Target | None, int | None]:
        return self.target, self.horizon

    def _continued_episodes(self) -> list[Segment]:
        """The episodes an earlier ``learn()`` call left running, where they go on: SB3 keeps
        the environment's last observation (the very array) unless it resets it, which a
        ``learn()`` call does unless ``reset_num_timesteps=False``; else none."""
        last = self._policy.unfinished_episodes
        self._policy.unfinished_episodes = None
        continues = (
            isinstance(last, _Unfinished)
            and last.last_obs is self.model._last_obs
            and last.num_timesteps == self.model.num_timesteps
            and last.feed_rule == self._feed_rule
            and len(last.pending) == self.model.n_envs
        )
        if continues:
            return list(last.pending)
        return [empty_segment(self._algo.rollout_buffer.obs_shape)] * self.model.n_envs

    def _check_bounds_wrappers(self, normalize: VecNormalize | None) -> None:
        """Before the GP's first data: warn where a VecEnv wrapper (``normalize``, the model's
        VecNormalize if any, or a VecFrameStack) makes the observation space's bounds, from
        which the GP's unset lengthscales came, wrong for the observations."""
        gp = self._policy.gp
        dims = np.flatnonzero(gp.lengthscale_from_bounds)
        if int(gp.n_seen) or not len(dims):
            return
        reasons = []
        if normalize is not None and normalize.norm_obs:
            reasons.append(
                "VecNormalize normalises the observations but keeps the space's raw bounds "
                "(normalised observations have unit variance: lengthscale=1.0 is their scale)"
            )
        if unwrap_vec_wrapper(self.training_env, VecFrameStack) is not None:
            reasons.append(
                "VecFrameStack stacks vector observations frame by frame but orders their "
                "bounds element by element, so each dimension gets another's lengthscale"
            )
        if reasons:
            warn_user(
                "the GP critic's starting lengthscales of observation dimensions "
                f"{dims.tolist()} came from the observation space's bounds, which do not "
                f"describe these observations: {'; '.join(reasons)}. Give the lengthscales "
                "yourself: policy_kwargs=dict(gp_kwargs=dict(kernel_kwargs=dict("
                "lengthscale=...)))."
            )

    @property
    def _discount(self) -> float:
        """The discount of SB3's returns and advantages: the rollout buffer's."""
        return float(self._algo.rollout_buffer.gamma)

    def _check_discount(self) -> None:
        gamma = float(self._algo.gamma)
        if gamma != self._discount:
            # SB3 gives the buffer its gamma when it builds the model; an assignment after that
            # changes only SB3's time-limit bootstraps.
            warn_user(
                f"model.gamma is {gamma:g} but its rollout buffer's is {self._discount:g}: SB3 "
                "computes returns and advantages with the buffer's, so the GP critic's targets "
                f"use {self._discount:g} too. To change the discount, pass gamma when building "
                "the model, or to load(..., custom_objects={'gamma': ...})."
            )

    @property
    def _algo(self) -> OnPolicyAlgorithm:
        """The model, as the on-policy algorithm checked in ``_init_callback``."""
        return cast(OnPolicyAlgorithm, self.model)

    @property
    def _policy(self) -> GPCriticMixin:
        """The model's policy, as checked in ``_init_callback``."""
        return cast(GPCriticMixin, self.model.policy)

    def _completed_episodes(
        self, buffer: RolloutBuffer, dones: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Monte-Carlo targets of the episodes completed by this rollout, env by env (with a
        ``horizon``: also of the steps whose ``horizon`` successors have arrived)."""
        return completed_returns(
            self._pending,
            buffer.observations,
            buffer.rewards,
            buffer.episode_starts,
            dones,
            self._discount,
            self.horizon,
            lambda states: _predict(self._policy, states),
        )

    def _bootstrap_values(self, policy: GPCriticMixin) -> np.ndarray:
        """Critic values of this rollout's truncated terminal observations, shape (k,)."""
        if not self._truncations:
            return np.empty(0, dtype=np.float32)
        return _predict(policy, np.stack([t[2] for t in self._truncations]))

    def _recompute(
        self,
        policy: GPCriticMixin,
        buffer: RolloutBuffer,
        dones: np.ndarray,
        old_bootstrap: np.ndarray,
    ) -> None:
        """Values, time-limit bootstraps, returns and advantages with the updated GP."""
        gamma = float(self._algo.gamma)  # the one SB3 folded the bootstraps in with
        new_bootstrap = self._bootstrap_values(policy)
        for (step, env, _), old, new in zip(
            self._truncations, old_bootstrap, new_bootstrap, strict=True
        ):
            buffer.rewards[step, env] += gamma * (new - old)
        self._fill_values(policy, buffer, self.locals["new_obs"], dones)

    @staticmethod
    def _fill_values(
        policy: GPCriticMixin,
        buffer: RolloutBuffer,
        last_obs: np.ndarray,
        dones: np.ndarray,
    ) -> None:
        """The rollout's values in one GP prediction, then SB3's returns and advantages,
        bootstrapped with the values of ``last_obs`` (the observations after the rollout).

        The last values are predicted here rather than read from the algorithm's ``values``:
        sb3-contrib's MaskablePPO does not pass its bootstrap value to ``on_rollout_end``,
        where ``values`` is still the last step's (deferred, so zero)."""
        n_steps, n_envs = buffer.values.shape
        flat_obs = buffer.observations.reshape(n_steps * n_envs, *buffer.obs_shape)
        buffer.values[:] = _predict(policy, flat_obs).reshape(n_steps, n_envs)
        last_values = th.as_tensor(_predict(policy, last_obs))
        buffer.compute_returns_and_advantage(last_values=last_values, dones=dones)


def rollout_states(buffer: RolloutBuffer) -> tuple[np.ndarray, np.ndarray | None]:
    """The rollout's observations, ``(n_steps * n_envs, *obs_shape)``, and MaskablePPO's
    action masks of them, ``(n_steps * n_envs, mask_dims)`` (``None`` for other buffers)."""
    n = buffer.buffer_size * buffer.n_envs
    masks = getattr(buffer, "action_masks", None)
    obs = buffer.observations.reshape(n, *buffer.obs_shape)
    return obs, None if masks is None else masks.reshape(n, -1)


def time_limit_truncations(
    model: OnPolicyAlgorithm, step_locals: dict[str, Any]
) -> list[tuple[int, int, np.ndarray]]:
    """The time-limit truncations of the step a callback's ``_on_step`` sees, as
    ``(buffer index, env, terminal observation)``: the steps SB3 bootstraps right after the
    hook, with ``gamma * V(terminal observation)`` added to the reward at the rollout
    buffer's index ``pos``."""
    step = model.rollout_buffer.pos
    found = []
    for env, (done, info) in enumerate(
        zip(step_locals["dones"], step_locals["infos"], strict=True)
    ):
        terminal = info.get("terminal_observation")
        if done and terminal is not None and info.get("TimeLimit.truncated", False):
            found.append((step, env, np.asarray(terminal)))
    return found


def _predict(policy: GPCriticMixin, states: np.ndarray) -> np.ndarray:
    """The critic's values of ``states`` (shape (k, *obs_shape)) as an array, shape (k,)."""
    if not len(states):
        return np.empty(0, dtype=np.float32)
    with th.no_grad():
        values = policy.predict_values(th.as_tensor(states, device=policy.device))
    return values.cpu().numpy()[:, 0]


def _check_rewards(buffer: RolloutBuffer) -> None:
    """Name the first non-finite reward of the rollout (the GP would refuse its targets)."""
    bad = np.argwhere(~np.isfinite(buffer.rewards))
    if bad.size:
        step, env = (int(i) for i in bad[0])
        raise ValueError(
            f"GPValueCallback: the reward at step {step} of this rollout in env {env} is "
            f"{buffer.rewards[step, env]} ({len(bad)} non-finite rewards in the rollout); the "
            "GP critic cannot learn from it. Check the environment or its reward wrappers"
        )


#: Largest magnitude of a value SB3 can hold: its buffers and the value head are float32.
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def _check_targets(targets: np.ndarray) -> None:
    """Refuse returns (the critic's targets, or SB3's returns of the rollout) that are not
    finite or that float32, SB3's precision, cannot hold: finite rewards whose returns overflow
    (SB3's float32 returns, or the float64 Monte Carlo returns that the critic's float32 values
    would turn into inf)."""
    largest = float(np.abs(targets).max()) if len(targets) else 0.0
    if not largest <= _FLOAT32_MAX:
        # inf - inf in SB3's float32 sums leaves NaN, which has no size to quote.
        reach = f"reach {largest:.3g}" if math.isfinite(largest) else "overflow to inf or NaN"
        raise ValueError(
            f"GPValueCallback: this rollout's returns {reach}, beyond float32's "
            f"{_FLOAT32_MAX:.3g}, in which SB3 keeps returns and values (the rewards are "
            "finite, their discounted sums are not). Scale the rewards down, e.g. "
            "VecNormalize(env, norm_obs=False, norm_reward=True) or a reward wrapper"
        )
