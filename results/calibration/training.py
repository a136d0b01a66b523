"""The GP critic's predictive intervals inside training (``PLAN.md``, addendum 2)::

    python results/calibration/training.py                # resumes: finished runs are kept
    python results/calibration/training.py --read > results/calibration/training.md

Each run trains as ``examples/critic_fit.py`` does (the comparison's zoo hyperparameters and
budget) with three callbacks: :class:`Posterior` takes the GP's mean and latent variance at the
rollout's states before the GP learns from the rollout, :class:`~sb3_geogp.GPValueCallback`
feeds it, and :class:`Scored` (critic_fit's ``WithCeiling``) estimates ``V^pi`` there by Monte
Carlo and scores the intervals, on every ``EVERY[algo]``-th rollout of the last 20 %.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from tqdm import tqdm

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.run import build_model, write_json_atomic
from sb3_geogp.comparison.specs import RunSpec, SweepConfig
from sb3_geogp.toolbox.pools import worker_pool
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
RUNS = HERE / "training"
CRITIC_FIT = load_script(HERE.parents[1] / "examples" / "critic_fit.py", "critic_fit")
CALIBRATION = load_script(HERE / "calibration.py", "calibration")
ENVS = ("CartPole-v1", "Acrobot-v1", "sb3_geogp/PaperPendulum-v0")
#: Algorithm -> (its default critic, fresh seeds).
ARMS = {"ppo": ("laplacian", (638, 639, 640, 641, 642)), "a2c": ("rbf", (149, 150, 151, 152, 153))}
#: Score every n-th rollout of the last 20 % (A2C's 5-step rollouts are many).
EVERY = {"ppo": 1, "a2c": 8}
LAST = 0.2
MC_ROLLOUTS = 16
TAIL = 0.01
#: The nominal coverages read (``calibration.py`` records more).
LEVELS = (0.5, 0.9, 0.95)


class Posterior(BaseCallback):
    """The GP's mean and latent variance at the rollout's states (SB3's buffer order), taken
    when the rollout ends and before :class:`~sb3_geogp.GPValueCallback` feeds it."""

    def __init__(self) -> None:
        super().__init__()
        self.mean = self.var = np.empty(0)

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        model = self.model
        assert isinstance(model, OnPolicyAlgorithm)
        policy, buffer = model.policy, model.rollout_buffer
        assert isinstance(policy, GPActorCriticPolicy)
        obs = buffer.observations.reshape(-1, *buffer.obs_shape)
        mean, var = policy.gp.predict(policy.critic_features(obs))
        assert var is not None
        self.mean, self.var = mean.cpu().numpy(), var.cpu().numpy()


class Scored(CRITIC_FIT.WithCeiling):  # type: ignore[name-defined]
    """``WithCeiling`` whose ceiling is the intervals' score against ``V^pi``."""

    def __init__(self, posterior: Posterior, every: int, *args: Any) -> None:
        super().__init__(*args)
        self.posterior, self.every = posterior, every

    def row(self) -> dict[str, Any]:
        row: dict[str, Any] = CRITIC_FIT.ExplainedVariance.row(self)
        since = len(self.rows) - self.first
        if since >= 0 and since % self.every == 0:
            row["ceiling"] = self.ceiling()
        return row

    def ceiling(self) -> dict[str, Any]:
        rollout, mc = self.monte_carlo()
        n = rollout.rewards.size
        mu, var = self.posterior.mean, self.posterior.var
        # The posterior read is the one that gave the rollout's values (float32 there).
        values = self.model.rollout_buffer.values.ravel()
        np.testing.assert_allclose(mu, values, rtol=1e-4, atol=1e-3)
        stderr = mc[:n].std(axis=1, ddof=1) / math.sqrt(mc.shape[1])
        return {
            **CALIBRATION.scores(mu, var, mc[:n].mean(axis=1), stderr),
            "truth_sd": float(mc[:n].mean(axis=1).std()),
        }


def specs() -> list[RunSpec]:
    out = []
    for algo, (critic, seeds) in ARMS.items():
        config = SweepConfig(algos=(algo,), critics=(critic,), envs=ENVS, seeds=seeds)
        out += config.specs()
    return out


def run_file(spec: RunSpec) -> Path:
    return RUNS / f"{spec.algo}__{spec.env_id.replace('/', '-')}__s{spec.seed}.json"


def run_one(spec: RunSpec) -> dict[str, Any]:
    th.set_num_threads(1)
    model = build_model(spec)
    n_rollouts = -(-spec.total_timesteps // (model.n_steps * model.n_envs))
    first = int(np.floor((1 - LAST) * n_rollouts))
    posterior = Posterior()
    scored = Scored(posterior, EVERY[spec.algo], spec.env_id, first, MC_ROLLOUTS, TAIL, spec.seed)
    feed = GPValueCallback(target=spec.target, horizon=spec.horizon)
    model.learn(spec.total_timesteps, callback=CallbackList([posterior, feed, scored]))
    rollouts = [r["ceiling"] for r in scored.rows if "ceiling" in r]
    result = {
        "algo": spec.algo,
        "critic": spec.critic,
        "env_id": spec.env_id,
        "seed": spec.seed,
        "total_timesteps": spec.total_timesteps,
        "scored_rollouts": len(rollouts),
        "rollouts": rollouts,
    }
    write_json_atomic(run_file(spec), result)
    return result


def run(workers: int) -> None:
    todo = [s for s in specs() if not run_file(s).is_file()]
    if not todo:
        print(f"all runs in {RUNS}")
        return
    with worker_pool(workers) as pool:
        futures = [pool.submit(run_one, s) for s in todo]
        for future in tqdm(cf.as_completed(futures), total=len(futures), unit="run"):
            future.result()


def pooled(result: dict[str, Any]) -> dict[str, float]:
    """A run's scores over all its scored states: each rollout's weighted by its states."""
    rollouts = result["rollouts"]
    w = np.array([r["cells"] for r in rollouts], dtype=np.float64)
    w /= w.sum()

    def mean(values: list[float]) -> float:
        return float(w @ np.array(values))

    out = {f"coverage {p}": mean([r["coverage"][str(p)] for r in rollouts]) for p in LEVELS}
    for key, name in (("z_rms", "z_rms"), ("rmse", "RMSE"), ("rms_sd", "rms sd")):
        out[name] = math.sqrt(mean([r[key] ** 2 for r in rollouts]))
    out["sd of V^pi"] = float(np.mean([r["truth_sd"] for r in rollouts]))
    return out


def read() -> str:
    results = [json.loads(p.read_text()) for p in sorted(RUNS.glob("*.json"))]
    metrics = [*(f"coverage {p}" for p in LEVELS), "z_rms", "RMSE", "rms sd", "sd of V^pi"]
    lines = [
        "## The GP critic's intervals against V^pi inside training",
        "",
        "Pooled over each run's scored states; mean over seeds [95 % Student-t interval].",
        "",
        "| algo | critic | env | runs | states per run | " + " | ".join(metrics) + " |",
        "|---|---|---|---:|---:|" + "---:|" * len(metrics),
    ]
    for algo, (critic, _) in ARMS.items():
        for env_id in ENVS:
            runs = [r for r in results if r["algo"] == algo and r["env_id"] == env_id]
            if not runs:
                continue
            scores = [pooled(r) for r in runs]
            states = np.mean([sum(x["cells"] for x in r["rollouts"]) for r in runs])
            cells = []
            for key in metrics:
                mean, half = mean_ci(np.array([s[key] for s in scores]), nan_policy="omit")
                cells.append(f"{mean:.3f} [{mean - half:.3f}, {mean + half:.3f}]")
            lines.append(
                f"| {algo} | {critic} | {env_id} | {len(runs)} | {states:.0f} | "
                + " | ".join(cells)
                + " |"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--read", action="store_true", help="print the table of the runs")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    if args.read:
        print(read())
    else:
        run(args.workers)


if __name__ == "__main__":
    main()
