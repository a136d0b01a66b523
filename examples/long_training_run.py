"""A long training run with the drop-in GP critic: does it survive, and does it slow down?

Trains ``--algo`` with ``GPActorCriticPolicy`` and ``GPValueCallback`` (default options) on
``--env`` for ``--timesteps`` steps and records, per rollout: its wall clock, the GP's update
time (``gp/update_ms``), basis vectors, explained variance, noise variance and lengthscale
(geometric mean), and every ``--memory-every`` rollouts the process's resident memory (and, on
a CUDA ``--device``, the memory torch has allocated on it). At the
end it checks that the GP's state holds no NaN or inf and that no logged ``gp/`` figure was
ever inf, or NaN (``gp/explained_variance`` may be NaN where the targets did not vary: counted,
not a failure), evaluates the policy (10 episodes), prints the first and last tenth of the run
side by side, and writes ``long_training_run.json`` (the figures per rollout as one list each)
and ``long_training_run.png`` to ``--out``.
Exit status 1 if a check failed. (``examples/long_run_numerics.py`` soaks the engine alone
with 10^6 points and checks its matrices after every batch.)

Usage::

    python examples/long_training_run.py --algo ppo --env Pendulum-v1 --timesteps 300000 \\
        --out docs/benchmarks/long_training/ppo_pendulum
    python examples/long_training_run.py --algo a2c --env CartPole-v1 --timesteps 200000 \\
        --out docs/benchmarks/long_training/a2c_cartpole
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import sys
import time
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import torch
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.evaluation import evaluate_policy

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg

ALGOS = {"ppo": PPO, "a2c": A2C}
#: Runs with fewer rollouts read the memory at every one and draw their figures as lines.
FEW_ROLLOUTS = 200
#: ``gp/`` keys recorded per rollout.
KEYS = ("update_ms", "n_basis", "explained_variance", "noise_var", "lengthscale")


def resident_mib() -> float:
    """The process's resident memory now (Linux), else its peak so far, in MiB."""
    status = Path("/proc/self/status")
    if status.is_file():
        for line in status.read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024 * 1024 if sys.platform == "darwin" else 1024)


class Recorder(BaseCallback):
    """Per rollout, what ``GPValueCallback`` (listed before it) logged, and the wall clock."""

    def __init__(self, memory_every: int) -> None:
        super().__init__()
        self.memory_every = memory_every
        self.rows: list[dict[str, float]] = []
        self._started = 0.0

    def _on_rollout_start(self) -> None:
        self._started = time.perf_counter()

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        logged = self.logger.name_to_value
        policy = self.model.policy
        assert isinstance(policy, GPActorCriticPolicy)
        gp = policy.gp
        row = {
            "timesteps": float(self.num_timesteps),
            "update_ms": float(logged.get("gp/update_ms", math.nan)),
            "explained_variance": float(logged.get("gp/explained_variance", math.nan)),
            # the GP's own state: the logger has these only after a refit
            "n_basis": float(gp.n_basis),
            "noise_var": float(gp.noise_var),
            "lengthscale": float(gp.kernel.lengthscale.log().mean().exp()),
        }
        # the rollout's collection and the GP's update; the algorithm's train step follows
        row["rollout_s"] = time.perf_counter() - self._started
        if len(self.rows) % self.memory_every == 0:
            row["resident_mib"] = resident_mib()
            if policy.device.type == "cuda":
                row["device_mib"] = torch.cuda.memory_allocated(policy.device) / 2**20
        self.rows.append(row)


def columns(rows: list[dict[str, float]]) -> dict[str, list[float | None]]:
    """The rows as one list per figure, 6 significant digits, ``None`` where a rollout has
    none (memory between readings) or it is NaN (JSON has no NaN)."""
    keys = dict.fromkeys(k for r in rows for k in r)
    return {
        key: [float(f"{r[key]:.6g}") if key in r and math.isfinite(r[key]) else None for r in rows]
        for key in keys
    }


def tenth(rows: list[dict[str, float]], key: str, last: bool) -> float:
    """Median of ``key`` over the first (or last) tenth of the rollouts that have it."""
    values = [r[key] for r in rows if key in r and math.isfinite(r[key])]
    k = max(1, len(values) // 10)
    part = values[-k:] if last else values[:k]
    return float(np.median(part)) if part else math.nan


def checks(model: Any, rows: list[dict[str, float]]) -> dict[str, Any]:
    """What must hold after a long run, and what was seen."""
    state = model.policy.gp.state_dict()
    bad_state = [
        name
        for name, value in state.items()
        if isinstance(value, torch.Tensor)
        and value.is_floating_point()
        and name != "kernel.lengthscale"  # NaN only before the first batch
        and not bool(torch.isfinite(value).all())
    ]
    nonfinite = {
        key: sum(1 for r in rows if not math.isfinite(r[key]))
        for key in KEYS
        if key != "explained_variance"
    }
    inf_ev = sum(1 for r in rows if math.isinf(r["explained_variance"]))
    nan_ev = sum(1 for r in rows if math.isnan(r["explained_variance"]))
    passed = not bad_state and not any(nonfinite.values()) and not inf_ev
    return {
        "passed": passed,
        "nonfinite_state": bad_state,
        "nonfinite_logged": nonfinite,
        "explained_variance_inf": inf_ev,
        "explained_variance_nan": nan_ev,
    }


def plot(rows: list[dict[str, float]], title: str, path: Path) -> None:
    t = np.array([r["timesteps"] for r in rows])
    panels = [
        ("rollout_s", "rollout wall clock (s)"),
        ("update_ms", "GP update (ms)"),
        ("resident_mib", "resident memory (MiB)"),
        ("n_basis", "basis vectors"),
        ("explained_variance", "explained variance\n(out of sample; NaN not drawn)"),
        ("noise_var", "noise variance (standardised)"),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(14, 6.5), sharex=True)
    for ax, (key, label) in zip(axes.flat, panels, strict=True):
        have = np.array([key in r for r in rows])
        y = np.array([r.get(key, math.nan) for r in rows], dtype=np.float64)
        if key == "explained_variance":
            y = np.clip(y, -1, 1)
        # thousands of A2C rollouts as a cloud, tens of PPO ones joined
        style = (
            {"ls": "-", "marker": ".", "ms": 4}
            if len(rows) < FEW_ROLLOUTS
            else {"ls": "", "marker": ".", "ms": 2, "alpha": 0.5}
        )
        ax.plot(t[have], y[have], **style)
        if key == "resident_mib" and any("device_mib" in r for r in rows):
            on_device = np.array(["device_mib" in r for r in rows])
            device_mib = [r["device_mib"] for r in rows if "device_mib" in r]
            ax.plot(t[on_device], device_mib, **style, label="allocated on the device")
            ax.legend(fontsize=8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("timesteps")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--algo", choices=sorted(ALGOS), default="ppo")
    parser.add_argument("--env", default="Pendulum-v1")
    parser.add_argument("--timesteps", type=count_arg, default=300_000)
    parser.add_argument("--n-envs", type=int, default=4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", default="auto", help="torch device of the policy and its GP")
    parser.add_argument(
        "--memory-every",
        type=int,
        default=None,
        help=f"rollouts between readings (default: 1 under {FEW_ROLLOUTS} rollouts, else 20)",
    )
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--out", type=Path, default=Path("runs/long_training_run"))
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    env = make_vec_env(args.env, n_envs=args.n_envs, seed=args.seed)
    model = ALGOS[args.algo](GPActorCriticPolicy, env, seed=args.seed, device=args.device)
    # SB3 collects whole rollouts: asking for them makes the bar's total and the title the
    # steps trained.
    rollouts = -(-args.timesteps // (model.n_steps * model.n_envs))
    steps = rollouts * model.n_steps * model.n_envs
    recorder = Recorder(args.memory_every or (1 if rollouts < FEW_ROLLOUTS else 20))
    start = time.perf_counter()
    model.learn(
        steps,
        callback=[GPValueCallback(), recorder],
        progress_bar=not args.no_progress,
    )
    seconds = time.perf_counter() - start
    eval_env = make_vec_env(args.env, n_envs=1, seed=args.seed + 10_000)
    mean, std = evaluate_policy(model, eval_env, n_eval_episodes=10, return_episode_rewards=False)
    rows = recorder.rows
    verdict = checks(model, rows)
    result: dict[str, Any] = {
        "settings": vars(args) | {"out": str(args.out)},
        "provenance": provenance(),
        "seconds": seconds,
        "rollouts": len(rows),
        "eval_return": [float(mean), float(std)],  # type: ignore[arg-type]
        "checks": verdict,
        "per_rollout": columns(rows),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    # one line: 10,000 A2C rollouts would otherwise be some 90,000 lines
    (args.out / "long_training_run.json").write_text(json.dumps(result) + "\n")
    title = f"{args.algo.upper()} {args.env}, {model.num_timesteps:,} steps, seed {args.seed}"
    plot(rows, title, args.out / "long_training_run.png")
    print(f"{title}: {len(rows)} rollouts in {seconds:.0f} s")
    print("                      first tenth   last tenth   (medians)")
    for key in (
        "rollout_s",
        "update_ms",
        "resident_mib",
        "device_mib",
        "n_basis",
        "explained_variance",
    ):
        if not any(key in r for r in rows):
            continue
        first, last = tenth(rows, key, last=False), tenth(rows, key, last=True)
        print(f"{key:20s}  {first:11.4g}  {last:11.4g}")
    print(f"evaluation return (10 episodes): {mean:.1f} +/- {std:.1f}")
    print(f"checks: {json.dumps(verdict)}")
    print(f"wrote {args.out / 'long_training_run.json'} and long_training_run.png")
    return 0 if verdict["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
