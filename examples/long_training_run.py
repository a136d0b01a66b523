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


#: What the record holds per rollout: its step count, the ``gp/`` figures, its wall clock
#: and, every ``--memory-every`` rollouts, the memory (NaN between readings).
COLUMNS = ("timesteps", *KEYS, "rollout_s", "resident_mib", "device_mib")

Record = dict[str, np.ndarray]


class Recorder(BaseCallback):
    """Per rollout, what ``GPValueCallback`` (listed before it) logged, and the wall clock.

    The record is one preallocated float array for the ``rollouts`` the run collects, so that
    the memory it reads is the training's: a list of per-rollout dicts (0.39's) grew by about
    430 bytes a rollout, 2 MiB per 100,000 A2C steps, which the memory readings counted.
    """

    def __init__(self, memory_every: int, rollouts: int) -> None:
        super().__init__()
        self.memory_every = memory_every
        self._table = np.full((rollouts, len(COLUMNS)), np.nan)
        self._n = 0
        self._started = 0.0

    @property
    def record(self) -> Record:
        """The rollouts so far, one array per column (``device_mib`` only on a CUDA device)."""
        cuda = self.model.policy.device.type == "cuda"
        return {
            key: self._table[: self._n, j]
            for j, key in enumerate(COLUMNS)
            if key != "device_mib" or cuda
        }

    def _on_rollout_start(self) -> None:
        self._started = time.perf_counter()

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        logged = self.logger.name_to_value
        policy = self.model.policy
        assert isinstance(policy, GPActorCriticPolicy)
        gp = policy.gp
        if self._n == len(self._table):  # more rollouts than planned: room for as many again
            self._table = np.concatenate([self._table, np.full_like(self._table, np.nan)])
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
        if self._n % self.memory_every == 0:
            row["resident_mib"] = resident_mib()
            if policy.device.type == "cuda":
                row["device_mib"] = torch.cuda.memory_allocated(policy.device) / 2**20
        for key, value in row.items():
            self._table[self._n, COLUMNS.index(key)] = value
        self._n += 1


def columns(record: Record) -> dict[str, list[float | None]]:
    """The record as lists, 6 significant digits, ``None`` where a rollout has none (memory
    between readings) or it is NaN (JSON has no NaN)."""
    return {
        key: [float(f"{v:.6g}") if math.isfinite(v) else None for v in values.tolist()]
        for key, values in record.items()
    }


def tenth(record: Record, key: str, last: bool) -> float:
    """Median of ``key`` over the first (or last) tenth of the rollouts that have it."""
    values = record[key][np.isfinite(record[key])]
    k = max(1, len(values) // 10)
    part = values[-k:] if last else values[:k]
    return float(np.median(part)) if len(part) else math.nan


def checks(model: Any, record: Record) -> dict[str, Any]:
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
        key: int(np.count_nonzero(~np.isfinite(record[key])))
        for key in KEYS
        if key != "explained_variance"
    }
    ev = record["explained_variance"]
    inf_ev, nan_ev = int(np.count_nonzero(np.isinf(ev))), int(np.count_nonzero(np.isnan(ev)))
    passed = not bad_state and not any(nonfinite.values()) and not inf_ev
    return {
        "passed": passed,
        "nonfinite_state": bad_state,
        "nonfinite_logged": nonfinite,
        "explained_variance_inf": inf_ev,
        "explained_variance_nan": nan_ev,
    }


def plot(record: Record, title: str, path: Path) -> None:
    t = record["timesteps"]
    panels = [
        ("rollout_s", "rollout wall clock (s)"),
        ("update_ms", "GP update (ms)"),
        ("resident_mib", "resident memory (MiB)"),
        ("n_basis", "basis vectors"),
        ("explained_variance", "explained variance\n(out of sample; NaN not drawn)"),
        ("noise_var", "noise variance (standardised)"),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(14, 6.5), sharex=True)
    # thousands of A2C rollouts as a cloud, tens of PPO ones joined
    style = (
        {"ls": "-", "marker": ".", "ms": 4}
        if len(t) < FEW_ROLLOUTS
        else {"ls": "", "marker": ".", "ms": 2, "alpha": 0.5}
    )
    for ax, (key, label) in zip(axes.flat, panels, strict=True):
        y = record[key]
        have = np.isfinite(y)
        if key == "explained_variance":
            y = np.clip(y, -1, 1)
        ax.plot(t[have], y[have], **style)
        if key == "resident_mib" and "device_mib" in record:
            on_device = np.isfinite(record["device_mib"])
            device_mib = record["device_mib"][on_device]
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
    recorder = Recorder(args.memory_every or (1 if rollouts < FEW_ROLLOUTS else 20), rollouts)
    start = time.perf_counter()
    model.learn(
        steps,
        callback=[GPValueCallback(), recorder],
        progress_bar=not args.no_progress,
    )
    seconds = time.perf_counter() - start
    eval_env = make_vec_env(args.env, n_envs=1, seed=args.seed + 10_000)
    mean, std = evaluate_policy(model, eval_env, n_eval_episodes=10, return_episode_rewards=False)
    record = recorder.record
    verdict = checks(model, record)
    result: dict[str, Any] = {
        "settings": vars(args) | {"out": str(args.out)},
        "provenance": provenance(),
        "seconds": seconds,
        "rollouts": len(record["timesteps"]),
        "eval_return": [float(mean), float(std)],  # type: ignore[arg-type]
        "checks": verdict,
        "per_rollout": columns(record),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    # one line: 10,000 A2C rollouts would otherwise be some 90,000 lines
    (args.out / "long_training_run.json").write_text(json.dumps(result) + "\n")
    title = f"{args.algo.upper()} {args.env}, {model.num_timesteps:,} steps, seed {args.seed}"
    plot(record, title, args.out / "long_training_run.png")
    print(f"{title}: {result['rollouts']} rollouts in {seconds:.0f} s")
    print("                      first tenth   last tenth   (medians)")
    for key in (
        "rollout_s",
        "update_ms",
        "resident_mib",
        "device_mib",
        "n_basis",
        "explained_variance",
    ):
        if key not in record:
            continue
        first, last = tenth(record, key, last=False), tenth(record, key, last=True)
        print(f"{key:20s}  {first:11.4g}  {last:11.4g}")
    print(f"evaluation return (10 episodes): {mean:.1f} +/- {std:.1f}")
    print(f"checks: {json.dumps(verdict)}")
    print(f"wrote {args.out / 'long_training_run.json'} and long_training_run.png")
    return 0 if verdict["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
