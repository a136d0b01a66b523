"""Why the default GP critic loses PPO InvertedPendulum-v5 to SB3's MLP critic in the zoo's
``VecNormalize`` (session 81, exploratory; the held-out study's lost cell).

Trains PPO on InvertedPendulum-v5 with the zoo's entry (``results/heldout/ppo.yml``) for
50,000 steps on the held-out study's seeds 1023-1032, in arms that change one thing each:
the critic, which parts of ``VecNormalize`` wrap the environment (observations, rewards), and,
for the GP critic, its kernel, its targets, its forgetting and its trend; two more arms start
both critics' actors with less noise. Before each PPO update it records, from the rollout
buffer:

* the mean return of the last 5 training episodes (the stochastic policy's);
* the actor's log standard deviation (state-independent in SB3's Gaussian policy);
* ``corr(A, z**2)`` and ``corr(A, z)``, with ``A`` the rollout's advantages and
  ``z = (a - mu(s)) / sigma`` each action's deviation from the actor's mean in its standard
  deviations: how much the advantages tell the actor about its own noise.

::

    python results/heldout_noise/run.py            # resumable: skips runs already saved
    python results/heldout_noise/read.py > results/heldout_noise/read.md

``--first-seed``, ``--seeds`` and ``--arms`` select other runs (``PLAN_confirm.md``'s check on
fresh seeds).

Each run writes ``runs/<arm>__s<seed>.npz`` (one row per rollout) and its settings and
provenance to ``runs/<arm>__s<seed>.json``.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import stable_baselines3
import torch as th
from stable_baselines3 import PPO

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import HyperparamsFile, hyperparams
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.specs import RunSpec
from sb3_geogp.policies import default_adaptation
from sb3_geogp.toolbox.provenance import provenance

HERE = Path(__file__).resolve().parent
ENV_ID = "InvertedPendulum-v5"
STEPS = 50_000
SEEDS = tuple(range(1023, 1033))
THRESHOLD = 950.0
OBS_AND_REWARD = {"norm_obs": True, "norm_reward": True}


@dataclass(frozen=True)
class Arm:
    """One arm: the critic, which parts of ``VecNormalize`` wrap the environment (None: no
    wrapper), whether a GP critic's policy normalises its actor's observations, the GP's
    options, ``GPValueCallback``'s arguments, and keys that replace the zoo entry's."""

    critic: str
    vec_normalize: dict[str, bool] | None = None
    actor_normalize: bool = False
    gp_kwargs: dict[str, Any] = field(default_factory=dict)
    callback_kwargs: dict[str, Any] = field(default_factory=dict)
    entry: dict[str, Any] = field(default_factory=dict)


#: The actor's initial noise at the MLP critic's agents' final one (std 0.37).
LOW_NOISE = {"policy_kwargs": "dict(log_std_init=-1.0)"}


def adapt_with(**changes: Any) -> dict[str, Any]:
    """GP options: PPO's default adaptation with ``changes``."""
    return {"adapt": {**default_adaptation(PPO).as_dict(), **changes}}


#: The GP critic's options that keep every point it absorbed at full weight: no starting
#: forgetting, no forgetting by drift, and 1 as the adaptation's only forgetting candidate.
NEVER_FORGETS = {
    **adapt_with(forgetting=[1.0]),
    "forgetting": 1.0,
    "forgetting_points": 4096,
    "drift_forgetting": 0.0,
}

ARMS: dict[str, Arm] = {
    "mlp_vecnormalize": Arm("mlp", OBS_AND_REWARD),
    "mlp_rewards_only": Arm("mlp", {"norm_obs": False, "norm_reward": True}),
    "mlp_observations_only": Arm("mlp", {"norm_obs": True, "norm_reward": False}),
    "mlp_raw": Arm("mlp"),
    "gp_actor_normalized": Arm("laplacian", actor_normalize=True),
    "gp_raw": Arm("laplacian"),
    "gp_rewards_normalized": Arm(
        "laplacian", {"norm_obs": False, "norm_reward": True}, actor_normalize=True
    ),
    "gp_rbf": Arm("rbf", actor_normalize=True),
    "gp_sb3_returns": Arm("laplacian", actor_normalize=True, callback_kwargs={"target": "returns"}),
    "gp_no_drift_forgetting": Arm(
        "laplacian", actor_normalize=True, gp_kwargs={"drift_forgetting": 0.0}
    ),
    "gp_never_forgets": Arm("laplacian", actor_normalize=True, gp_kwargs=NEVER_FORGETS),
    # Added after a 4-seed screen of the GP critic without the PPO default's moving level:
    "gp_no_trend": Arm("laplacian", actor_normalize=True, gp_kwargs={"trend": "none"}),
    # A control on the mechanism (added while the first ten arms ran): the actors start with
    # little noise, both critics.
    "mlp_vecnormalize_low_noise": Arm("mlp", OBS_AND_REWARD, entry=LOW_NOISE),
    "gp_actor_normalized_low_noise": Arm("laplacian", actor_normalize=True, entry=LOW_NOISE),
    # Session 82 (results/heldout_advantage): the lengthscales' start. Without the hyperprior
    # that holds them near the first batch's; and following the spread of the window.
    "gp_no_prior": Arm("laplacian", actor_normalize=True, gp_kwargs=adapt_with(prior_sd=None)),
    "gp_follow_spread": Arm(
        "laplacian", actor_normalize=True, gp_kwargs=adapt_with(follow_spread=True)
    ),
    # Session 83: following only where the window spreads wider (CartPole-v1's narrow).
    "gp_follow_widen": Arm(
        "laplacian", actor_normalize=True, gp_kwargs=adapt_with(follow_spread="widen")
    ),
}


def build(arm: str | Arm, seed: int) -> tuple[PPO, list[GPValueCallback]]:
    """The arm's PPO model on its (wrapped) environment, and its callbacks (``arm``: a name in
    :data:`ARMS`, or an arm of another script's)."""
    a = ARMS[arm] if isinstance(arm, str) else arm
    entry = hyperparams("ppo", ENV_ID, HyperparamsFile.read(HERE.parent / "heldout/ppo.yml"))
    values = dict(entry.values, normalize=a.vec_normalize or False, **a.entry)
    spec = RunSpec(
        "ppo",
        a.critic,
        ENV_ID,
        seed,
        STEPS,
        normalize=a.vec_normalize is not None,
        actor_normalize=a.actor_normalize,
        gp_kwargs=tuple(sorted(a.gp_kwargs.items())),
        hyperparams=values,
        hyperparams_source=entry.source,
        threshold=THRESHOLD,
    )
    model = build_model(spec)
    assert isinstance(model, PPO)
    callbacks = [] if a.critic == "mlp" else [GPValueCallback(**a.callback_kwargs)]
    return model, callbacks


class RolloutRecord:
    """Wraps ``model.train`` to read the rollout buffer before each PPO update."""

    def __init__(self, model: PPO) -> None:
        self.model = model
        self.rows: list[dict[str, float]] = []
        self._train = model.train
        model.train = self._record_then_train  # type: ignore[method-assign]

    def _record_then_train(self) -> None:
        self.rows.append(self.row())
        self._train()

    def row(self) -> dict[str, float]:
        model, buffer = self.model, self.model.rollout_buffer
        advantages = buffer.advantages.ravel()
        with th.no_grad():
            obs = th.as_tensor(buffer.observations.reshape(len(advantages), -1))
            distribution = model.policy.get_distribution(obs).distribution
            mean = distribution.mean.numpy().ravel()
            std = distribution.stddev.numpy().ravel()
        z = (buffer.actions.ravel() - mean) / std
        episodes = [info["r"] for info in list(model.ep_info_buffer)[-5:]]
        return dict(
            steps=float(model.num_timesteps),
            episode_return=float(np.mean(episodes)) if episodes else np.nan,
            log_std=float(model.policy.log_std.detach().mean()),
            corr_z2=float(np.corrcoef(advantages, z**2)[0, 1]),
            corr_z=float(np.corrcoef(advantages, z)[0, 1]),
        )


def run(arm: str, seed: int, out: Path) -> str:
    """Train one arm on one seed and save its record; the line to print."""
    warnings.filterwarnings("ignore", category=UserWarning)
    th.set_num_threads(1)
    model, callbacks = build(arm, seed)
    record = RolloutRecord(model)
    start = time.perf_counter()
    model.learn(STEPS, callback=callbacks)
    seconds = time.perf_counter() - start
    model.get_env().close()  # type: ignore[union-attr]
    stem = out / f"{arm}__s{seed}"
    columns = {k: np.array([r[k] for r in record.rows]) for k in record.rows[0]}
    np.savez(stem.with_suffix(".npz"), **columns)
    settings = dict(arm=arm, seed=seed, steps=STEPS, env_id=ENV_ID, settings=asdict(ARMS[arm]))
    gp = isinstance(model.policy, GPActorCriticPolicy)
    info = dict(settings, seconds=seconds, gp=gp, provenance=provenance(stable_baselines3, gym))
    stem.with_suffix(".json").write_text(json.dumps(info, indent=1, default=str))
    last = record.rows[-1]["episode_return"]
    return f"{arm} seed {seed}: {seconds:.0f} s, last episodes {last:.0f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "runs")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--arms", nargs="+", default=list(ARMS), choices=list(ARMS))
    parser.add_argument("--first-seed", type=int, default=SEEDS[0])
    parser.add_argument("--seeds", type=int, default=len(SEEDS), help="how many seeds")
    args = parser.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    args.out.mkdir(parents=True, exist_ok=True)
    todo = [
        (arm, seed)
        for arm in args.arms
        for seed in seeds
        if not (args.out / f"{arm}__s{seed}.npz").exists()
    ]
    print(f"{len(todo)} runs to make", flush=True)
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(run, arm, seed, args.out) for arm, seed in todo]
        for i, future in enumerate(futures, 1):
            print(f"[{i}/{len(todo)}] {future.result()}", flush=True)


if __name__ == "__main__":
    main()
