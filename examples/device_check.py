"""Check the GP critic on another device (a GPU) against the CPU.

Run: ``python examples/device_check.py --device cuda [--timesteps 4096] [--out device.json]``.

Four checks, each printed as it runs:

1. **Engine.** The same data stream (a random walk cut into episodes, targets from a smooth
   function with a step) is fed to a :class:`~sb3_geogp.SparseOnlineGP` on the CPU and one on
   ``--device``, with adaptation on, for each kernel and each of :data:`ADAPTATIONS`: the
   summary of the data a refit leaves behind (``fold``, A2C's default; ``snapshot``, PPO's)
   and the lagged forgetting score (``lagged``, an option). Both run in float64, so their
   posteriors should agree to round-off: the largest gap in predictive mean and variance is
   printed.
2. **Training.** PPO (Pendulum-v1, PPO's default Laplacian critic) and A2C (CartPole-v1,
   A2C's default RBF critic) with ``GPActorCriticPolicy``, on the CPU and on ``--device``, wall
   clock side by side; every value the critic predicts on the collected observations must be
   finite.
3. **Save/load across devices.** Each trained model is saved, loaded on the CPU, and its critic's
   values on the last rollout's observations are compared with the original's.
4. **Determinism.** Each training run is repeated with the same seed on the same device: its
   last rollout and its critic's values must be identical.

The script exits with status 1 if a check fails (gap above ``--tol``, a non-finite value, a
seed that does not reproduce its run).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import Adaptation, GPActorCriticPolicy, GPValueCallback, SparseOnlineGP
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg

KERNELS = ("rbf", "laplacian", "matern", "geodesic")
#: Adaptations the engine check runs, by name.
ADAPTATIONS = {
    "fold": Adaptation(),
    "snapshot": Adaptation(summary="snapshot"),
    "lagged": Adaptation(summary="snapshot", forgetting_score="lagged"),
}


def stream(seed: int, batches: int, points: int) -> list[tuple[np.ndarray, ...]]:
    """Batches ``(x, y, starts)`` of a 2-d random walk, with a value step at ``x[0] = 0``."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(batches):
        starts = rng.random(points) < 0.02
        starts[0] = True
        steps = rng.normal(scale=0.1, size=(points, 2))
        x = np.zeros((points, 2))
        for i in range(points):
            x[i] = rng.uniform(-1, 1, 2) if starts[i] else x[i - 1] + steps[i]
        y = np.sin(2 * x[:, 1]) + 2.0 * (x[:, 0] > 0) + rng.normal(scale=0.1, size=points)
        out.append((x, y, starts))
    return out


def engine_gap(
    kernel: str, adapt: Adaptation, device: str, batches: int, points: int
) -> dict[str, float]:
    """Largest |mean| and |var| gap between the CPU engine and the one on ``device``."""
    data = stream(0, batches, points)
    query = np.concatenate([x for x, _, _ in data])[:: max(1, batches * points // 500)]
    runs = []
    for where in ("cpu", device):
        gp = SparseOnlineGP(2, kernel=kernel, max_basis=64, adapt=adapt, device=where)
        for x, y, starts in data:
            gp.update(x, y, starts)
        mean, var = gp.predict(query)
        assert var is not None
        runs.append((mean.cpu().numpy(), var.cpu().numpy(), gp.n_basis))
    (m0, v0, n0), (m1, v1, n1) = runs
    return {
        "mean_gap": float(np.max(np.abs(m0 - m1))),
        "var_gap": float(np.max(np.abs(v0 - v1))),
        "basis_cpu": n0,
        "basis_device": n1,
    }


def train(algo: str, device: str, timesteps: int) -> tuple[BaseAlgorithm, np.ndarray, float]:
    """A short run with the default GP critic on ``device``; returns the model and last obs."""
    env_id, cls, kw = {
        "ppo": ("Pendulum-v1", PPO, {"n_steps": 512, "gamma": 0.9}),
        "a2c": ("CartPole-v1", A2C, {"n_steps": 8}),
    }[algo]
    env = make_vec_env(env_id, n_envs=4, seed=0)
    model = cls(GPActorCriticPolicy, env, seed=0, device=device, **kw)
    start = time.perf_counter()
    model.learn(timesteps, callback=GPValueCallback())
    seconds = time.perf_counter() - start
    obs = model.rollout_buffer.observations.reshape(-1, env.observation_space.shape[0])
    return model, obs, seconds


def values(model: BaseAlgorithm, obs: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        v = model.policy.predict_values(torch.as_tensor(obs, device=model.device))
    return v.cpu().numpy().ravel()


def training_check(algo: str, device: str, timesteps: int) -> dict[str, Any]:
    model, obs, seconds = train(algo, device, timesteps)
    before = values(model, obs)
    twin, twin_obs, _ = train(algo, device, timesteps)
    with tempfile.TemporaryDirectory() as tmp:
        model.save(Path(tmp) / "model.zip")
        loaded = type(model).load(Path(tmp) / "model.zip", device="cpu")
    after = values(loaded, obs)
    return {
        "device": str(model.device),
        "gp_device": str(model.policy.gp.alpha.device),
        "seconds": seconds,
        "basis": model.policy.gp.n_basis,
        "finite": bool(np.isfinite(before).all()),
        "load_gap": float(np.max(np.abs(before - after))),
        "same_rollout": bool(np.array_equal(obs, twin_obs)),
        "repeat_gap": float(np.max(np.abs(before - values(twin, obs)))),
        "value_range": [float(before.min()), float(before.max())],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--device", default="cuda", help="device to check against the CPU")
    parser.add_argument(
        "--timesteps", type=count_arg, default=4096, help="steps per training check"
    )
    parser.add_argument("--batches", type=count_arg, default=6, help="engine check: batches fed")
    parser.add_argument(
        "--points", type=count_arg, default=256, help="engine check: points a batch"
    )
    parser.add_argument("--tol", type=float, default=1e-6, help="largest gap accepted")
    parser.add_argument("--out", type=Path, default=None, help="write the figures as JSON")
    args = parser.parse_args(argv)
    if args.device.startswith("cuda") and not torch.cuda.is_available():
        parser.error(f"--device {args.device}: this torch has no CUDA device (try --device cpu)")
    torch.set_num_threads(1)
    report: dict[str, Any] = {"torch": torch.__version__, "device": args.device}
    if args.device.startswith("cuda"):
        report["gpu"] = torch.cuda.get_device_name(args.device)
    failed = []
    for kernel, name in itertools.product(KERNELS, ADAPTATIONS):
        gap = engine_gap(kernel, ADAPTATIONS[name], args.device, args.batches, args.points)
        report[f"engine_{kernel}_{name}"] = gap
        print(f"engine {kernel:9s} {name:8s} " + " ".join(f"{k}={v:.3g}" for k, v in gap.items()))
        if not gap["mean_gap"] <= args.tol or not gap["var_gap"] <= args.tol:
            failed.append(f"engine {kernel} {name}: CPU and {args.device} posteriors differ")
    for algo, where in itertools.product(("ppo", "a2c"), dict.fromkeys(("cpu", args.device))):
        res = training_check(algo, where, args.timesteps)
        report[f"train_{algo}_{where}"] = res
        print(f"train  {algo} {where:5s} " + " ".join(f"{k}={v}" for k, v in res.items()))
        if not res["finite"]:
            failed.append(f"train {algo} on {where}: non-finite critic values")
        # Values leave the critic as float32: allow a few float32 ulps of the largest value.
        scale = max(1.0, *map(abs, res["value_range"]))
        if not (math.isfinite(res["load_gap"]) and res["load_gap"] <= 1e-5 * scale):
            failed.append(f"train {algo} on {where}: values change when loaded on the CPU")
        if not (res["same_rollout"] and res["repeat_gap"] == 0.0):
            failed.append(f"train {algo} on {where}: the same seed trained another model")
    report["failed"] = failed
    if args.out is not None:
        args.out.write_text(json.dumps(report, indent=2))
    print("FAILED: " + "; ".join(failed) if failed else "all device checks passed")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
