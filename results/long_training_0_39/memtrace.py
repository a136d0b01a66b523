"""Where does A2C CartPole-v1's resident memory grow late in a long run? (session 79)

Trains A2C (SB3's defaults, 4 envs, seed 0) with the default GP critic for ``argv[1]`` steps,
then ``argv[2]`` more under tracemalloc, and prints the resident memory before and after, the
growth of Python's traced allocations by traceback, and the torch tensors alive before and
after (the long run's own per-rollout record is not kept here)::

    python results/long_training_0_39/memtrace.py 250000 100000 \\
        > results/long_training_0_39/memtrace.txt
"""

from __future__ import annotations

import collections
import gc
import sys
import tracemalloc
from pathlib import Path

import torch
from stable_baselines3 import A2C
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback


def resident_mib() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status (Linux only)")


def census() -> tuple[collections.Counter[str], int]:
    """Live objects by type, and how many are torch tensors."""
    gc.collect()
    objects = gc.get_objects()
    tensors = sum(1 for o in objects if isinstance(o, torch.Tensor))
    return collections.Counter(type(o).__name__ for o in objects), tensors


def main() -> None:
    torch.set_num_threads(1)
    env = make_vec_env("CartPole-v1", n_envs=4, seed=0)
    model = A2C(GPActorCriticPolicy, env, seed=0)
    callback = GPValueCallback()
    model.learn(int(sys.argv[1]), callback=callback)
    (types_before, tensors_before), rss_before = census(), resident_mib()
    tracemalloc.start(30)
    before = tracemalloc.take_snapshot()
    model.learn(int(sys.argv[2]), callback=callback, reset_num_timesteps=False)
    gc.collect()
    after = tracemalloc.take_snapshot()
    rss_after, (types_after, tensors_after) = resident_mib(), census()
    traced = tracemalloc.get_traced_memory()[0] / 2**20
    print(
        f"RSS {rss_before:.1f} -> {rss_after:.1f} MiB; traced now {traced:.2f} MiB; "
        f"tensors {tensors_before} -> {tensors_after}"
    )
    grown = [(k, types_after[k] - types_before[k]) for k in types_after]
    print("object count growth:", [(k, d) for k, d in grown if d > 50][:20])
    for stat in after.compare_to(before, "traceback")[:8]:
        print(stat)
        print("\n".join(stat.traceback.format()[-12:]))
        print("----")


if __name__ == "__main__":
    main()
