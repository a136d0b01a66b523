"""Out-of-sample fit of each critic during PPO training (issue 13's critic-fit goal).

For every rollout the critic is scored on that rollout's targets *before* it learns from them:
SB3's ``explained_variance`` of the values the critic predicted during the rollout against the
GAE returns computed afterwards, ``1 - Var(R - V) / Var(R)``, the same formula for the MLP and
the GP critics. The goal is at least 0.9 averaged over the last 20% of training's rollouts.
Since session 39 each run also records the explained variance of those rollouts pooled, the
same formula over all their points at once (``tail_pooled``): a rollout whose returns hardly
vary (a CartPole policy that rarely fails) weighs in it by its points, not as one rollout's
score that a small ``Var(R)`` can send far below 0. A rollout whose returns do not vary at all
(every step of every episode alike, values and advantages exactly constant) has no score: it is
recorded as ``null``, left out of its run's mean, and a run none of whose scored rollouts has one
is left out of the tables' means (they say how many runs they hold).
The runs are the comparison's (:class:`~sb3_geogp.comparison.specs.SweepConfig`: zoo
hyperparameters and budgets, the same seeds, the GP critics with the comparison's options),
without its evaluations.

    python examples/critic_fit.py --seeds 0 1 2 3 4 --workers 2 --out docs/critic_fit

``--gp-option KEY=VALUE`` (repeatable) sets an option of both GP critics, and ``--target`` /
``--horizon`` what :class:`~sb3_geogp.GPValueCallback` feeds them, as in ``sb3-geogp compare``;
runs with other options belong in another ``--out``. The score is the same for every target:
the rollout's values against SB3's GAE returns, which are computed from those values.

``--ceiling N`` also scores, on every scored rollout of CartPole-v1, Acrobot-v1, Pendulum-v1
(since 0.35.3), the paper's pendulum or a WallMaze variant, the policy's own value function
``V^pi`` (Monte Carlo, ``N`` rollouts from every state;
:mod:`sb3_geogp.studies.value_ceiling`): what the exact critic would score, by the goal's
reading and on targets no critic shapes, and how far the critic's values are from it. The
run itself is unchanged.

    python examples/critic_fit.py --envs CartPole-v1 Acrobot-v1 --critics mlp laplacian \
        --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2 --ceiling 32 --out docs/critic_fit_ceiling

``--lag`` (with ``--ceiling``) also scores, on every scored rollout, the value function of the
policy that collected the rollout before it (a copy kept at that rollout's end), the *lagged
ceiling* (:func:`~sb3_geogp.studies.value_ceiling.lagged_ceiling`): what a critic would score
that knew the previous policy's values exactly, which is what critics trained on earlier
returns learn towards. The run itself is unchanged.

    python examples/critic_fit.py --envs CartPole-v1 Acrobot-v1 --critics mlp laplacian \
        --seeds 0 1 2 3 4 5 6 7 8 9 --workers 2 --ceiling 32 --lag --out docs/critic_fit_lag

``--capacity`` (with ``--ceiling``) also fits value models once to half of each scored rollout's
environments and scores them against ``V^pi`` on the other half
(:func:`~sb3_geogp.studies.value_ceiling.capacity`): a fresh GP with the run's critic's options,
the same with lengthscales from the batch's spread (and with the RBF kernel), SB3's MLP value
network trained to convergence, 10 nearest neighbours; fitted to ``V^pi``, to the rollout's own
returns and to the previous rollout's ``V^pi``. The run itself is unchanged.

    python examples/critic_fit.py --envs Acrobot-v1 --critics laplacian --seeds 0 1 2 3 4 \
        --last 0.5 --workers 2 --ceiling 32 --capacity --out docs/critic_fit_capacity

Each run is written to ``OUT/runs/<run>.json`` when it finishes; an interrupted call resumes
where it stopped. The summary is printed and written to ``OUT/critic_fit.md`` with a figure.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import copy
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.policies import ActorCriticPolicy
from tqdm.auto import tqdm

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.callbacks import time_limit_truncations
from sb3_geogp.comparison.command import (
    UsageError,
    add_target_arguments,
    check_target_arguments,
    parse_gp_option,
)
from sb3_geogp.comparison.hyperparams import ALL_CRITICS, CRITICS
from sb3_geogp.comparison.measurement import RolloutRecorder, rollout_explained_variance
from sb3_geogp.comparison.report import COLORS
from sb3_geogp.comparison.run import build_model, write_json_atomic
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.policies import build_gp_critic
from sb3_geogp.studies.value_ceiling import (
    TASKS,
    Fit,
    Predict,
    Rollout,
    capacity,
    ceiling,
    horizon,
    knn_fit,
    lagged_ceiling,
    mlp_fit,
    model_returns,
)
from sb3_geogp.toolbox.pools import worker_pool
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg
from sb3_geogp.toolbox.stats import mean_ci, moments, pooled_explained_variance
from sb3_geogp.toolbox.tables import estimate_cell

ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")
GOAL = 0.9
#: Standard deviation of ``V^pi`` over a run's scored states (mean over rollouts) below which
#: it counts as constant: a tenth of one step's reward (CartPole's and Acrobot's rewards are 1
#: in size; set after seeing a CartPole run whose ``V^pi`` varied by 0.02).
VARYING = 0.1


class ExplainedVariance(RolloutRecorder):
    """The rollout's explained variance once its returns (and a GP critic's values) are final:
    put it after :class:`~sb3_geogp.GPValueCallback`, which fills the GP's values."""

    def row(self) -> dict[str, Any]:
        buffer = self.model.rollout_buffer
        returns, residuals = buffer.returns.ravel(), buffer.returns.ravel() - buffer.values.ravel()
        return dict(
            timesteps=int(self.num_timesteps),
            explained=rollout_explained_variance(buffer),
            moments=moments(returns, residuals),
        )

    @property
    def timesteps(self) -> list[int]:
        return [r["timesteps"] for r in self.rows]

    @property
    def explained(self) -> list[float]:
        return [r["explained"] for r in self.rows]


class WithCeiling(ExplainedVariance):
    """:class:`ExplainedVariance` plus, from the ``first``-th rollout (counted from 0) on, the
    rollout's ceiling: the score of the policy's ``V^pi``, by Monte Carlo with ``n_rollouts``
    rollouts per state cut where at most ``tail`` of a return is left (in units of the task's
    largest reward)
    (:mod:`sb3_geogp.studies.value_ceiling`), and how far the critic's values are from it.

    The Monte Carlo rollouts draw the policy's actions inside a forked torch random stream
    seeded by the run's seed and the rollout's index: training's random streams are untouched,
    so the run's own scores are those of a run without the ceiling."""

    def __init__(
        self,
        env_id: str,
        first: int,
        n_rollouts: int,
        tail: float,
        seed: int,
        with_capacity: bool = False,
        with_lag: bool = False,
    ) -> None:
        super().__init__()
        if env_id not in TASKS:
            raise ValueError(f"--ceiling supports {sorted(TASKS)}, not {env_id}")
        self.task, self.first, self.n_rollouts, self.tail = TASKS[env_id], first, n_rollouts, tail
        self.seed = seed
        self.with_capacity, self.with_lag = with_capacity, with_lag
        # The previous scored rollout and its V^pi, for capacity's "lag" targets.
        self._previous: tuple[Rollout, np.ndarray] | None = None
        # A copy of the policy that collected the previous rollout, for the lagged ceiling.
        self._earlier_policy: ActorCriticPolicy | None = None
        self.rewards: list[np.ndarray] = []
        self.truncations: list[tuple[int, int, np.ndarray]] = []

    def _on_rollout_start(self) -> None:
        self.rewards, self.truncations = [], []

    def _on_step(self) -> bool:
        # before SB3 adds its bootstrap to the rewards at truncations, after this hook
        self.rewards.append(np.array(self.locals["rewards"], dtype=np.float64))
        self.truncations += time_limit_truncations(self.model, self.locals)
        return True

    def row(self) -> dict[str, Any]:
        row = super().row()
        index = len(self.rows)
        if index >= self.first:
            row["ceiling"] = self.ceiling()
        if self.with_lag and index >= self.first - 1:
            # the policy that collected this rollout, before the algorithm trains on it
            self._earlier_policy = copy.deepcopy(self.model.policy)
        return row

    def rollout(self) -> Rollout:
        """The rollout that just ended, as :func:`~sb3_geogp.studies.value_ceiling.ceiling`
        reads it."""
        model, buffer = self.model, self.model.rollout_buffer
        return Rollout(
            obs=buffer.observations,
            rewards=np.stack(self.rewards),
            episode_starts=buffer.episode_starts,
            last_obs=np.asarray(model._last_obs),
            last_dones=np.asarray(model._last_episode_starts, dtype=np.float64),
            truncations=self.truncations,
        )

    def monte_carlo(self, policy: ActorCriticPolicy | None = None) -> tuple[Rollout, np.ndarray]:
        """The rollout that just ended and the policy's (or ``policy``'s) Monte Carlo returns
        from each of its states (:meth:`Rollout.states`), shape (m, ``n_rollouts``); every
        policy scored on a rollout draws from the same seeded random stream."""
        steps = horizon(float(self.model.gamma), self.tail / self.task.reward_bound)
        rollout = self.rollout()
        seed = self.seed * 1000 + len(self.rows)
        states = rollout.states()
        mc = model_returns(
            self.model, self.task, states, steps, self.n_rollouts, seed, policy=policy
        )
        return rollout, mc

    def ceiling(self) -> dict[str, Any]:
        model, buffer = self.model, self.model.rollout_buffer
        gamma, lam = float(model.gamma), float(model.gae_lambda)
        rollout, mc = self.monte_carlo()
        result = ceiling(
            rollout, mc, gamma, lam, critic=buffer.values.ravel(),
            advantages=buffer.advantages.ravel(),
        )  # fmt: skip
        if self._earlier_policy is not None:
            lagged = self.monte_carlo(self._earlier_policy)[1]
            result["lag"] = lagged_ceiling(rollout, mc, lagged, gamma, lam)
        if self.with_capacity:
            values = mc.mean(axis=1)
            result["capacity"] = capacity(
                self._fits(), rollout, values, gamma, buffer.values.ravel(), self._previous
            )
            self._previous = (rollout, values)
        return result

    def _fits(self) -> dict[str, Fit]:
        """The value models :func:`capacity` fits: a fresh GP with the run's GP critic's
        options (GP critics only), the same with lengthscales from the batch's spread instead
        of the observation bounds, and with the RBF kernel too; SB3's MLP value network
        trained to convergence; 10 nearest neighbours."""
        fits = {"mlp": mlp_fit(), "knn": knn_fit(10)}
        if isinstance(self.model.policy, GPActorCriticPolicy):
            options = self.model.policy._get_constructor_parameters()["gp_kwargs"]
            space = self.model.observation_space
            bounds = (space.low.ravel(), space.high.ravel())
            fits = {
                "gp": _gp_fit(options, bounds, spread=False),
                "gp, spread": _gp_fit(options, bounds, spread=True),
                "gp, rbf, spread": _gp_fit({**options, "kernel": "rbf"}, bounds, spread=True),
                **fits,
            }
        return fits


def _gp_fit(options: dict[str, Any], bounds: tuple[np.ndarray, np.ndarray], spread: bool) -> Fit:
    """:data:`~sb3_geogp.studies.value_ceiling.Fit` of a new GP critic of ``options`` fed the
    batch once (float64, CPU); with ``spread`` its lengthscales start at the batch's standard
    deviation per dimension instead of the observation bounds."""

    def fit(x: np.ndarray, y: np.ndarray, episode_starts: np.ndarray) -> Predict:
        chosen = dict(options)
        if spread:
            chosen["kernel_kwargs"] = {**(chosen.get("kernel_kwargs") or {}),
                                       "lengthscale": x.std(axis=0).tolist()}  # fmt: skip
        gp = build_gp_critic(chosen, x.shape[1], bounds)
        gp.update(x, y, episode_starts)
        return lambda z: gp.predict(z, return_var=False)[0].cpu().numpy()

    return fit


def first_scored(n_rollouts: int, last: float) -> int:
    """Index of the first of ``n_rollouts`` rollouts in the share ``last`` that is scored."""
    return int(np.floor((1 - last) * n_rollouts))


def run_one(
    spec: RunSpec,
    last: float,
    ceiling_rollouts: int = 0,
    tail: float = 0.1,
    with_capacity: bool = False,
    with_lag: bool = False,
) -> dict[str, Any]:
    """Train ``spec``'s model and return its per-rollout explained variance (and with
    ``ceiling_rollouts`` Monte Carlo rollouts per state, the ceilings of the scored ones, with
    ``with_capacity`` their :func:`~sb3_geogp.studies.value_ceiling.capacity` too, with
    ``with_lag`` their :func:`~sb3_geogp.studies.value_ceiling.lagged_ceiling`)."""
    th.set_num_threads(1)
    model = build_model(spec)
    per_rollout = model.n_steps * model.n_envs
    n_rollouts = -(-spec.total_timesteps // per_rollout)
    first = first_scored(n_rollouts, last)
    recorder = (
        WithCeiling(spec.env_id, first, ceiling_rollouts, tail, spec.seed, with_capacity, with_lag)
        if ceiling_rollouts
        else ExplainedVariance()
    )
    callbacks: list[BaseCallback] = [recorder]
    if isinstance(model.policy, GPActorCriticPolicy):
        callbacks.insert(0, GPValueCallback(target=spec.target, horizon=spec.horizon))
    model.learn(spec.total_timesteps, callback=CallbackList(callbacks))
    env = model.get_env()
    assert env is not None
    env.close()
    explained = np.array(recorder.explained)
    if len(explained) != n_rollouts:
        raise RuntimeError(f"expected {n_rollouts} rollouts, SB3 collected {len(explained)}")
    scored = explained[first:]
    result = dict(
        env_id=spec.env_id,
        critic=spec.critic,
        seed=spec.seed,
        total_timesteps=spec.total_timesteps,
        gp_kwargs=dict(spec.gp_kwargs),
        **_feed(spec),
        timesteps=recorder.timesteps,
        explained_variance=[_score(x) for x in recorder.explained],
        tail_rollouts=len(scored),
        tail_mean=_score(np.nanmean(scored) if np.isfinite(scored).any() else np.nan),
        tail_pooled=_score(
            pooled_explained_variance([r["moments"] for r in recorder.rows[first:]])
        ),
        provenance=provenance(),
    )
    if ceiling_rollouts:
        ceilings = [r["ceiling"] for r in recorder.rows[first:]]
        result["ceiling"] = dict(
            n_rollouts=ceiling_rollouts,
            tail=tail,
            **({"with_capacity": True} if with_capacity else {}),
            **({"with_lag": True} if with_lag else {}),
            rollouts=ceilings,
            tail_mean=float(np.nanmean([c["explained"] for c in ceilings])),
            tail_halves=float(np.nanmean([c["halves"] for c in ceilings])),
            tail_pooled=pooled_explained_variance([c["moments"] for c in ceilings]),
            **{
                f"{key}_pooled": pooled_explained_variance([c[f"{key}_moments"] for c in ceilings])
                for key in ("mc_ceiling", "mc_critic")
            },
        )
    return result


def _score(x: float) -> float | None:
    """An explained variance as the run file keeps it: ``None`` (JSON ``null``) where it is
    undefined (returns that do not vary)."""
    return float(x) if np.isfinite(x) else None


def _feed(spec: RunSpec) -> dict[str, Any]:
    """What the GP critic is fed, where it is not the default (runs recorded before the
    option existed carry none): ``target`` and ``horizon``."""
    if spec.critic == "mlp":
        return {}
    return {key: value for key, value in spec.as_dict().items() if key in ("target", "horizon")}


def _run_file(out: Path, spec: RunSpec) -> Path:
    return out / "runs" / f"{spec.critic}__{spec.env_id.replace('/', '-')}__s{spec.seed}.json"


def _run_and_save(
    spec: RunSpec,
    last: float,
    out: Path,
    ceiling_rollouts: int,
    tail: float,
    with_capacity: bool,
    with_lag: bool,
) -> dict[str, Any]:
    result = run_one(spec, last, ceiling_rollouts, tail, with_capacity, with_lag)
    write_json_atomic(_run_file(out, spec), result)
    return result


class OtherSettingsError(ValueError):
    """A finished run in ``--out`` was made with other settings than those asked for now."""


def run_all(
    specs: list[RunSpec],
    last: float,
    out: Path,
    workers: int,
    ceiling_rollouts: int = 0,
    tail: float = 0.1,
    with_capacity: bool = False,
    with_lag: bool = False,
) -> list[dict[str, Any]]:
    """Every run of ``specs`` not already in ``out`` (resumable), with a progress bar."""
    (out / "runs").mkdir(parents=True, exist_ok=True)
    existing = [s for s in specs if _run_file(out, s).exists()]
    done = [json.loads(_run_file(out, s).read_text()) for s in existing]
    for result, spec in zip(done, existing, strict=True):
        if result["total_timesteps"] != spec.total_timesteps:
            raise OtherSettingsError(
                f"{_run_file(out, spec)} ran {result['total_timesteps']} steps, not "
                f"{spec.total_timesteps} (another --scale): pass another --out"
            )
        if spec.critic != "mlp" and result["gp_kwargs"] != dict(spec.gp_kwargs):
            raise OtherSettingsError(
                f"{_run_file(out, spec)} ran with GP options {result['gp_kwargs']}, not "
                f"{dict(spec.gp_kwargs)}: pass another --out"
            )
        n = len(result["explained_variance"])
        tail_rollouts = n - first_scored(n, last)
        if result["tail_rollouts"] != tail_rollouts:
            raise OtherSettingsError(
                f"{_run_file(out, spec)} averaged its last {result['tail_rollouts']} of {n} "
                f"rollouts, not the last {last:.0%} ({tail_rollouts}): pass another --out, or "
                "the --last it ran with"
            )
        recorded_feed = {key: result[key] for key in ("target", "horizon") if key in result}
        if recorded_feed != _feed(spec):
            raise OtherSettingsError(
                f"{_run_file(out, spec)} was fed {recorded_feed or 'the returns'}, not "
                f"{_feed(spec) or 'the returns'}: pass another --out"
            )
        recorded = result.get("ceiling", {})
        settings = (
            recorded.get("n_rollouts", 0),
            recorded.get("tail", tail),
            recorded.get("with_capacity", False),
            recorded.get("with_lag", False),
        )
        if settings != (ceiling_rollouts, tail, with_capacity, with_lag):
            raise OtherSettingsError(
                f"{_run_file(out, spec)} ran with another --ceiling, --ceiling-tail, "
                "--capacity or --lag: pass another --out"
            )
    todo = [s for s in specs if s not in existing]
    bar = tqdm(total=len(specs), initial=len(done), unit="run", desc="runs")

    def finished(result: dict[str, Any]) -> None:
        done.append(result)
        score = result["tail_mean"]
        shown = "undefined" if score is None else f"{score:.2f}"
        bar.set_postfix_str(f"{result['critic']} {result['env_id']} {shown}")
        bar.update()

    options = (ceiling_rollouts, tail, with_capacity, with_lag)
    if workers <= 1:
        for spec in todo:
            finished(_run_and_save(spec, last, out, *options))
    else:
        # Spawned, not forked: a fork after autograd has run on a GPU cannot backpropagate.
        with worker_pool(workers) as pool:
            futures = [pool.submit(_run_and_save, s, last, out, *options) for s in todo]
            for future in cf.as_completed(futures):
                finished(future.result())
    bar.close()
    return done


def summary(results: list[dict[str, Any]], critics: Sequence[str], last: float) -> str:
    """Markdown: per environment and critic, the tail explained variance over seeds (mean of the
    rollouts' scores, then pooled where every run recorded it), each with the paired
    differences from the first critic."""
    reach = f"mean over seeds [min, max], seeds reaching {GOAL}:"
    heading = f"Out-of-sample explained variance averaged over the last {last:.0%} of each run's"
    lines = seed_table(results, critics, "tail_mean", f"{heading} rollouts; {reach}")
    lines += paired_differences(results, critics, "tail_mean")
    if all("tail_pooled" in r for r in results):
        heading = (
            f"The same rollouts pooled (one explained variance over all their points); {reach}"
        )
        lines += ["", *seed_table(results, critics, "tail_pooled", heading)]
        lines += paired_differences(results, critics, "tail_pooled")
    if all("ceiling" in r for r in results):
        lines += ["", *ceiling_table(results, critics)]
    if all("capacity" in c for r in results for c in r.get("ceiling", {}).get("rollouts", [{}])):
        lines += ["", *capacity_table(results, critics)]
    if all(r.get("ceiling", {}).get("with_lag") for r in results):
        lines += ["", *lag_table(results, critics)]
    return "\n".join(lines) + "\n"


def capacity_table(results: list[dict[str, Any]], critics: Sequence[str]) -> list[str]:
    """Markdown lines: per environment, critic and value model, what the model fitted once to
    half a scored rollout's environments explains of ``V^pi`` on the other half (by target),
    median over the scored rollouts whose ``V^pi`` varies [min, max] (a rollout early in a
    swing-up, where ``V^pi`` barely varies, can send one score far below 0)."""
    targets = ("exact", "G", "lag")
    lines = [
        "What value models fitted once to half of each scored rollout's environments explain "
        "of V^pi on the other half (1 - MSE / Var(V^pi)), fitted to V^pi itself (exact), to "
        "the rollout's own returns (G) and to the previous scored rollout's V^pi (lag); the "
        "run's own critic on the same half; median over the scored rollouts whose V^pi varies "
        "[min, max] (rollouts):",
        "",
        "| env | run's critic | model | " + " | ".join(targets) + " |",
        "|---|---|---|" + "---:|" * len(targets),
    ]
    for env_id in dict.fromkeys(r["env_id"] for r in results):
        for critic in critics:
            rows = [
                c["capacity"]
                for r in results
                if (r["env_id"], r["critic"]) == (env_id, critic)
                for c in r["ceiling"]["rollouts"]
                if c["truth_sd"] > VARYING
            ]
            if not rows:
                continue
            models = dict.fromkeys(k.split("|")[0] for k in rows[0] if "|" in k)
            lines.append(
                f"| `{env_id}` | {critic} | the run's critic | {_spread(rows, 'critic')} | | |"
            )
            for model in models:
                cells = [_spread(rows, f"{model}|{t}") for t in targets]
                lines.append(f"| `{env_id}` | {critic} | {model} | " + " | ".join(cells) + " |")
    return lines


def _spread(rows: list[dict[str, float]], key: str) -> str:
    values = [row[key] for row in rows if key in row]
    if not values:
        return "–"
    return f"{np.median(values):.2f} [{min(values):.2f}, {max(values):.2f}] ({len(values)})"


def ceiling_table(results: list[dict[str, Any]], critics: Sequence[str]) -> list[str]:
    """Markdown lines: per environment and critic, the critic's score and its policies' ceiling
    (``V^pi``'s score) on the same rollouts, by both readings, and the critic's distance from
    ``V^pi`` at the rollouts' states; each a mean over seeds."""
    n_mc = results[0]["ceiling"]["n_rollouts"]
    lines = [
        f"The ceiling: the score of the policies' own value function V^pi on the same rollouts "
        f"(Monte Carlo, {n_mc} rollouts per state; halves: {n_mc // 2} each, lower by the "
        "Monte Carlo noise); mean over seeds [min, max], seeds with a ceiling of at least "
        f"{GOAL} (goal's reading); both pooled; both on G, the rollouts' own returns "
        "bootstrapped with V^pi (lambda = 1, the same targets for both), pooled, over the runs "
        "whose V^pi varies; the critic's values against V^pi at the scored states; the "
        "correlation of the advantages the actor learned from with the GAE advantages with V^pi "
        "(– where the runs predate it):",
        "",
        "| env | critic | critic's score | ceiling | ceiling, halves | pooled: critic | pooled: "
        "ceiling | on G, pooled: critic | on G, pooled: V^pi | value RMSE to V^pi | "
        "mean value − V^pi | V^pi's sd | advantages: correlation |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for env_id in dict.fromkeys(r["env_id"] for r in results):
        for critic in critics:
            runs = [r for r in results if (r["env_id"], r["critic"]) == (env_id, critic)]
            if runs:
                lines.append(
                    f"| `{env_id}` | {critic} | " + " | ".join(_ceiling_cells(runs)) + " |"
                )
    return lines


def seed_table(
    results: list[dict[str, Any]], critics: Sequence[str], key: str, heading: str
) -> list[str]:
    """Markdown lines: mean over seeds of ``key``, its range and how many seeds reach the goal."""
    lines = [heading, "", "| env | " + " | ".join(critics) + " |", "|---|" + "---:|" * len(critics)]
    for env_id in dict.fromkeys(r["env_id"] for r in results):
        cells = []
        for critic in critics:
            runs = [r[key] for r in results if (r["env_id"], r["critic"]) == (env_id, critic)]
            tails = [t for t in runs if t is not None]
            if not tails:
                cells.append("–")
                continue
            reached = sum(t >= GOAL for t in tails)
            undefined = f" ({len(runs) - len(tails)} undefined)" if len(tails) < len(runs) else ""
            cells.append(
                f"{np.mean(tails):.3f} [{min(tails):.2f}, {max(tails):.2f}], "
                f"{reached}/{len(runs)}{undefined}"
            )
        lines.append(f"| `{env_id}` | " + " | ".join(cells) + " |")
    return lines


def paired_differences(
    results: list[dict[str, Any]], critics: Sequence[str], key: str = "tail_mean"
) -> list[str]:
    """Markdown lines: each critic's ``key`` minus the first critic's, paired by seed over the
    seeds both have, with a 95 % t interval (none with one critic)."""
    if len(critics) < 2:
        return []
    first = critics[0]
    lines = [
        "",
        f"Paired by seed, minus `{first}`: mean difference [95 % t interval] (seeds):",
        "",
        "| env | " + " | ".join(f"{c} − {first}" for c in critics[1:]) + " |",
        "|---|" + "---:|" * (len(critics) - 1),
    ]
    tails = {(r["env_id"], r["critic"], r["seed"]): r[key] for r in results if r[key] is not None}
    for env_id in dict.fromkeys(r["env_id"] for r in results):
        cells = []
        for critic in critics[1:]:
            pairs = [
                (t, tails[env_id, first, seed])
                for (e, c, seed), t in tails.items()
                if (e, c) == (env_id, critic) and (env_id, first, seed) in tails
            ]
            cells.append(_paired(*zip(*pairs, strict=True)) if pairs else "–")
        lines.append(f"| `{env_id}` | " + " | ".join(cells) + " |")
    return lines


def _on_g(runs: list[dict[str, Any]], key: str | Callable[[dict[str, Any]], float]) -> str:
    """Mean over ``runs`` of a pooled score on G (``key``'s in the run's ceiling record, or
    ``key(run)``), over the runs whose ``V^pi`` varies (where it is constant so is G, and a
    score of it is noise over nothing), how many if not all; "–" for runs recorded before that
    reading."""
    if isinstance(key, str):
        name = f"{key}_pooled"
        if not all(name in r["ceiling"] for r in runs):
            return "–"
        key = lambda r: r["ceiling"][name]  # noqa: E731
    varying = [
        key(r) for r in runs if np.mean([c["truth_sd"] for c in r["ceiling"]["rollouts"]]) > VARYING
    ]
    count = "" if len(varying) == len(runs) else f" ({len(varying)} runs)"
    return f"{np.mean(varying):.3f}{count}" if varying else "–"


def _mean(values: Sequence[float | None], fmt: str = ".3f") -> str:
    """The mean of the defined ``values`` (a critic's score may be undefined), "–" if none."""
    defined = [v for v in values if v is not None]
    return f"{np.mean(defined):{fmt}}" if defined else "–"


def _per_run(
    runs: list[dict[str, Any]], get: Callable[[dict[str, Any]], float | None]
) -> list[float | None]:
    """Each run's mean over its scored rollouts of ``get(rollout's ceiling record)`` (``None``
    and NaN left out); ``None`` where a run has no defined value."""
    means = []
    for r in runs:
        values = [get(c) for c in r["ceiling"]["rollouts"]]
        defined = [v for v in values if v is not None and not np.isnan(v)]
        means.append(float(np.mean(defined)) if defined else None)
    return means


def _ceiling_cells(runs: list[dict[str, Any]]) -> list[str]:
    """The cells of :func:`ceiling_table`'s row of ``runs`` (one env and critic)."""
    ceilings = [r["ceiling"]["tail_mean"] for r in runs]

    def per_rollout(key: str) -> list[float | None]:
        return _per_run(runs, lambda c: c.get(key))

    reached = sum(c >= GOAL for c in ceilings)
    return [
        _mean([r["tail_mean"] for r in runs]),
        f"{_mean(ceilings)} [{min(ceilings):.2f}, {max(ceilings):.2f}], {reached}/{len(runs)}",
        _mean([r["ceiling"]["tail_halves"] for r in runs]),
        _mean([r["tail_pooled"] for r in runs]),
        _mean([r["ceiling"]["tail_pooled"] for r in runs]),
        *(_on_g(runs, key) for key in ("mc_critic", "mc_ceiling")),
        _mean(per_rollout("value_rmse"), ".2f"),
        _mean(per_rollout("value_bias"), "+.2f"),
        _mean(per_rollout("truth_sd"), ".2f"),
        _mean(per_rollout("advantage_correlation")),
    ]


def lag_table(results: list[dict[str, Any]], critics: Sequence[str]) -> list[str]:
    """Markdown lines: per environment and critic, the critic's score beside the lagged ceiling
    (the previous rollout's policy's ``V^pi'`` scored on each rollout,
    :func:`~sb3_geogp.studies.value_ceiling.lagged_ceiling`) and the ceiling; each a mean over
    seeds. The lag's columns average the scored rollouts that have a previous policy (all of
    them unless the scored share starts at the first rollout), the others every scored one."""
    lines = [
        "The lagged ceiling: the score of the previous rollout's policy's value function V^pi' "
        "on each scored rollout (Monte Carlo, the same seeded random stream as V^pi), what a "
        "critic that knew the previous policy's values exactly would score; beside it the critic's "
        "score and the ceiling (V^pi) on the same rollouts. Per run the mean over its scored "
        "rollouts, then mean over seeds [min, max], seeds of at least "
        f"{GOAL}; pooled over each run's rollouts; on G (the rollouts' own returns "
        "bootstrapped with V^pi), pooled, over the runs whose V^pi varies; how far V^pi' is "
        "from V^pi at the scored states (RMSE) and V^pi's standard deviation there; the "
        "ceiling and the critic's score minus the lagged ceiling, paired by seed [95 % t] "
        "(seeds):",
        "",
        "| env | critic | critic's score | lagged ceiling V^pi' | ceiling V^pi | pooled: critic | "
        "pooled: V^pi' | pooled: V^pi | on G: critic | on G: V^pi' | on G: V^pi | "
        "V^pi' − V^pi RMSE | V^pi's sd | V^pi − V^pi' | critic − V^pi' |",
        "|---|---|" + "---:|" * 13,
    ]
    for env_id in dict.fromkeys(r["env_id"] for r in results):
        for critic in critics:
            runs = [r for r in results if (r["env_id"], r["critic"]) == (env_id, critic)]
            if runs:
                lines.append(f"| `{env_id}` | {critic} | " + " | ".join(_lag_cells(runs)) + " |")
    return lines


def _lag_cells(runs: list[dict[str, Any]]) -> list[str]:
    """The cells of :func:`lag_table`'s row of ``runs`` (one env and critic)."""

    def lagged(key: str) -> Callable[[dict[str, Any]], Any]:
        return lambda c: c["lag"][key] if "lag" in c else None

    per_run = _per_run(runs, lagged("explained"))
    lags = [v for v in per_run if v is not None]
    reached = sum(v >= GOAL for v in lags)
    spread = f" [{min(lags):.2f}, {max(lags):.2f}], {reached}/{len(lags)}" if lags else ""

    def pooled(key: str) -> Callable[[dict[str, Any]], float]:
        """A run's rollouts pooled, from the lag's moments ``key``."""
        return lambda r: pooled_explained_variance(
            [c["lag"][key] for c in r["ceiling"]["rollouts"] if "lag" in c]
        )

    return [
        _mean([r["tail_mean"] for r in runs]),
        _mean(lags) + spread,
        _mean([r["ceiling"]["tail_mean"] for r in runs]),
        _mean([r["tail_pooled"] for r in runs]),
        _mean([pooled("moments")(r) for r in runs]),
        _mean([r["ceiling"]["tail_pooled"] for r in runs]),
        _on_g(runs, "mc_critic"),
        _on_g(runs, pooled("mc_critic_moments")),
        _on_g(runs, "mc_ceiling"),
        _mean(_per_run(runs, lagged("value_rmse")), ".2f"),
        _mean(_per_run(runs, lagged("truth_sd")), ".2f"),
        _paired([r["ceiling"]["tail_mean"] for r in runs], per_run),
        _paired([r["tail_mean"] for r in runs], per_run),
    ]


def _paired(first: Sequence[float | None], second: Sequence[float | None]) -> str:
    """``first - second`` paired by run over the runs where both are defined: mean and 95 % t
    interval (the mean alone from too few runs), and how many runs."""
    pairs = zip(first, second, strict=True)
    diff = np.array([a - b for a, b in pairs if a is not None and b is not None])
    if not len(diff):
        return "–"
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    interval = f"[{mean - half:+.3f}, {mean + half:+.3f}]"
    return f"{estimate_cell(f'{mean:+.3f}', interval, len(diff))} ({len(diff)})"


def plot(results: list[dict[str, Any]], path: Path) -> None:
    """Explained variance per rollout, one panel per environment, one line per run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    envs = list(dict.fromkeys(r["env_id"] for r in results))
    fig, axes = plt.subplots(1, len(envs), figsize=(5 * len(envs), 3.6), squeeze=False)
    for ax, env_id in zip(axes[0], envs, strict=True):
        for r in sorted(results, key=lambda r: (r["critic"], r["seed"])):
            if r["env_id"] != env_id:
                continue
            first = r["seed"] == min(q["seed"] for q in results if q["critic"] == r["critic"])
            ax.plot(
                r["timesteps"],
                np.clip(np.array(r["explained_variance"], dtype=float), -1, 1),
                color=COLORS.get(r["critic"]),
                alpha=0.6,
                lw=1,
                label=r["critic"] if first else None,
            )
            if "ceiling" in r:
                ax.plot(
                    r["timesteps"][-r["tail_rollouts"] :],
                    np.clip([c["explained"] for c in r["ceiling"]["rollouts"]], -1, 1),
                    color=COLORS.get(r["critic"]),
                    ls="none",
                    marker="^",
                    ms=4,
                    label=f"{r['critic']}'s ceiling (V^pi)" if first else None,
                )
        ax.axhline(GOAL, color="k", ls=":", lw=1)
        ax.set(title=env_id, xlabel="timesteps", ylim=(-1.02, 1.02))
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("explained variance (out of sample, clipped at -1)")
    axes[0][0].legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_ceiling(results: list[dict[str, Any]], path: Path) -> None:
    """Each scored rollout's score against its ceiling, one panel per environment (top: the
    goal's reading; then, where recorded, on G, the same targets for both): points below the
    diagonal are what a better critic could still gain. Where the lagged ceiling is recorded,
    a last row puts it against the ceiling: points on the diagonal are rollouts where knowing
    the previous policy's values would have been as good as knowing the current one's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def critic_scores(runs: list[dict[str, Any]]) -> list[float]:
        return [s for r in runs for s in r["explained_variance"][-r["tail_rollouts"] :]]

    def recorded(key: str) -> Callable[[list[dict[str, Any]]], list[float]]:
        return lambda runs: [c[key] for r in runs for c in r["ceiling"]["rollouts"]]

    def lagged(runs: list[dict[str, Any]]) -> list[float]:
        rollouts = [c for r in runs for c in r["ceiling"]["rollouts"]]
        return [c["lag"]["explained"] if "lag" in c else np.nan for c in rollouts]

    envs = list(dict.fromkeys(r["env_id"] for r in results))
    rollouts = [c for r in results for c in r["ceiling"]["rollouts"]]
    score = "the critic's score (clipped at -1)"
    readings = [("explained", critic_scores, "the goal's reading", score)]
    if all("mc_critic" in c for c in rollouts):
        on_g = "on G (lambda = 1, V^pi bootstraps)"
        readings.append(("mc_ceiling", recorded("mc_critic"), on_g, score))
    if any("lag" in c for c in rollouts):
        lag_label = "V^pi''s score, one policy behind"
        readings.append(("explained", lagged, "the lagged ceiling (goal's reading)", lag_label))
    fig, axes = plt.subplots(
        len(readings), len(envs), figsize=(4.6 * len(envs), 4.2 * len(readings)), squeeze=False
    )
    for row, (x_key, y_of, reading, label) in zip(axes, readings, strict=True):
        for ax, env_id in zip(row, envs, strict=True):
            for critic in dict.fromkeys(r["critic"] for r in results):
                runs = [r for r in results if (r["env_id"], r["critic"]) == (env_id, critic)]
                ax.scatter(
                    np.clip(recorded(x_key)(runs), -1, 1),
                    np.clip(np.array(y_of(runs), dtype=float), -1, 1),
                    s=12,
                    alpha=0.6,
                    color=COLORS.get(critic),
                    label=critic,
                )
            ax.plot([-1, 1], [-1, 1], color="k", lw=0.8)
            ax.axhline(GOAL, color="k", ls=":", lw=1)
            ax.set(title=f"{env_id}:\n{reading}", xlim=(-1.05, 1.05), ylim=(-1.05, 1.05))
            ax.set(xlabel="V^pi's score (Monte Carlo)")
            ax.grid(alpha=0.3)
        row[0].set_ylabel(label)
    axes[0][0].legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--envs", nargs="+", default=list(ENVS))
    parser.add_argument("--critics", nargs="+", choices=ALL_CRITICS, default=list(CRITICS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--scale", type=float, default=1.0, help="multiplies the budgets")
    parser.add_argument("--last", type=float, default=0.2, help="share of rollouts averaged")
    parser.add_argument("--workers", type=count_arg, default=1)
    parser.add_argument("--out", type=Path, default=Path("critic_fit"))
    parser.add_argument(
        "--ceiling",
        type=int,
        default=0,
        metavar="N",
        help="also score V^pi on the scored rollouts, by Monte Carlo with N rollouts per state "
        f"(0: off; {', '.join(TASKS)} only)",
    )
    parser.add_argument(
        "--ceiling-tail",
        type=float,
        default=0.1,
        help="the Monte Carlo rollouts stop where at most this much of a return is left, in "
        "units of the task's largest reward",
    )
    parser.add_argument(
        "--gp-option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        type=parse_gp_option,
        help="option of both GP critics, as in sb3-geogp compare (repeatable)",
    )
    parser.add_argument(
        "--lag",
        action="store_true",
        help="with --ceiling: also score the previous rollout's policy's V^pi on each scored "
        "rollout (the lagged ceiling: what a critic one policy behind could score)",
    )
    parser.add_argument(
        "--capacity",
        action="store_true",
        help="with --ceiling: also fit value models once to half of each scored rollout and "
        "score them against V^pi on the other half (what the critic's function class and one "
        "rollout's returns allow)",
    )
    add_target_arguments(parser)
    args = parser.parse_args(argv)
    try:
        check_target_arguments(args)
    except UsageError as err:
        parser.error(str(err))
    config = SweepConfig(
        algos=("ppo",),
        critics=tuple(args.critics),
        envs=tuple(args.envs),
        seeds=tuple(args.seeds),
        timesteps_scale=args.scale,
        gp_options=tuple(args.gp_option),
        target=args.target,
        horizon=args.horizon,
    )
    if args.ceiling == 1 or args.ceiling < 0:
        parser.error("--ceiling needs at least 2 Monte Carlo rollouts per state (0: off)")
    if args.ceiling and set(args.envs) - set(TASKS):
        parser.error(f"--ceiling supports {', '.join(TASKS)}, not {set(args.envs) - set(TASKS)}")
    if args.capacity and not args.ceiling:
        parser.error("--capacity scores against V^pi: it needs --ceiling N")
    if args.lag and not args.ceiling:
        parser.error("--lag scores by Monte Carlo: it needs --ceiling N")
    try:
        results = run_all(
            config.specs(),
            args.last,
            args.out,
            args.workers,
            args.ceiling,
            args.ceiling_tail,
            args.capacity,
            args.lag,
        )
    except OtherSettingsError as err:
        parser.error(str(err))
    except KeyboardInterrupt:
        print("interrupted; the same command resumes from the finished runs", file=sys.stderr)
        return 130
    text = summary(results, args.critics, args.last)
    (args.out / "critic_fit.md").write_text(text)
    plot(results, args.out / "critic_fit.png")
    if all("ceiling" in r for r in results):
        plot_ceiling(results, args.out / "ceiling.png")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
