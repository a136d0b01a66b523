"""Where an A2C update of the default GP critic spends its time (session 79, descriptive)::

    python results/a2c_update_profile/update_profile.py \
        > results/a2c_update_profile/update_profile.txt

1. The training benchmark's A2C CartPole-v1 workload (``examples/benchmark_training.py``'s
   ``run``, one torch thread) with the default critic capped at 16, 64 and 256 basis vectors,
   and SB3's MLP critic, seeds 0 and 1, interleaved: how much of the GP's update time grows
   with the basis and how much is per-update overhead.
2. The last 60 updates of a 12,000-step run (256 basis vectors by then), each replayed on a
   copy of the GP as it was before it: wall clock per update, and torch's profiler's operator
   table over the 60 (``torch.profiler``; the Python between operators is the difference
   between the wall clock and the operators' self time).
"""

from __future__ import annotations

import copy
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import torch
from stable_baselines3 import A2C
from stable_baselines3.common.env_util import make_vec_env
from torch.profiler import ProfilerActivity, profile

from sb3_geogp import GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import algo_kwargs, hyperparams

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "examples"))
import benchmark_training as bench  # noqa: E402

WORKLOAD = "A2C CartPole-v1"


def basis_sweep() -> None:
    print("## 1. The workload at three basis sizes (seconds per run)\n")
    print("| seed | critic | wall | GP update | GP predict | adaptation |")
    print("|---|---|---:|---:|---:|---:|")
    for seed in (0, 1):
        for basis in (16, 64, 256, None):
            critic = "mlp" if basis is None else "rbf+adapt"
            r = bench.run(WORKLOAD, critic, seed, basis or 256, 1.0)
            name = "SB3's MLP" if basis is None else f"default GP, max_basis={basis}"
            print(
                f"| {seed} | {name} | {r['wall']:.2f} | {r['update']:.2f} | {r['predict']:.2f} "
                f"| {r['adaptation']:.2f} |"
            )


def recorded_updates(steps: int, keep: int) -> list[tuple[Any, tuple[Any, ...], dict[str, Any]]]:
    """The last ``keep`` updates of a run: the GP before each, and its arguments."""
    n_envs, kwargs, policy_kwargs = algo_kwargs("a2c", hyperparams("a2c", "CartPole-v1").values)
    env = make_vec_env("CartPole-v1", n_envs=n_envs, seed=0)
    gp_kwargs = bench.critic_gp_kwargs(WORKLOAD, "rbf+adapt", 256)
    policy_kwargs = {**policy_kwargs, "gp_kwargs": gp_kwargs}
    model = A2C(GPActorCriticPolicy, env, seed=0, policy_kwargs=policy_kwargs, **kwargs)
    gp = model.policy.gp
    calls: list[tuple[Any, tuple[Any, ...], dict[str, Any]]] = []
    update = type(gp).update

    def recording(self: Any, *args: Any, **kw: Any) -> Any:
        calls.append((copy.deepcopy(self), copy.deepcopy(args), dict(kw)))
        del calls[:-keep]
        return update(self, *args, **kw)

    type(gp).update = recording  # type: ignore[method-assign]
    try:
        model.learn(steps, callback=GPValueCallback())
    finally:
        type(gp).update = update  # type: ignore[method-assign]
    return calls


def update_profile() -> None:
    calls = recorded_updates(12_000, 60)
    print(f"\n## 2. {len(calls)} recorded updates, {calls[-1][0].n_basis} basis vectors\n")
    seconds = []
    for _ in range(3):
        for gp, args, kw in calls:
            fresh = copy.deepcopy(gp)
            start = time.perf_counter()
            fresh.update(*args, **kw)
            seconds.append(time.perf_counter() - start)
    print(f"wall clock per update: median {1e3 * statistics.median(seconds):.2f} ms (3 passes)\n")
    copies = [copy.deepcopy(gp) for gp, _, _ in calls]
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for fresh, (_, args, kw) in zip(copies, calls, strict=True):
            fresh.update(*args, **kw)
    print("```")
    print(prof.key_averages().table(sort_by="self_cpu_time_total", row_limit=20))
    print("```")


def main() -> None:
    torch.set_num_threads(1)
    basis_sweep()
    update_profile()


if __name__ == "__main__":
    main()
