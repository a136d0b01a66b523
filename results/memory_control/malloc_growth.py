"""Is the GP critic's late memory growth in A2C CartPole-v1 memory that malloc holds or memory
in use? (session 80)

Trains session 79's long A2C run (default GP critic, 4 envs, seed 0, one torch thread) for
``argv[1]`` steps, reading every 20 rollouts the resident memory and glibc's ``mallinfo2``:
the bytes malloc has handed out and not had back (``uordblks``, in use) and the bytes it
holds free (``fordblks``). At the end ``malloc_trim(0)`` gives free pages back to the system
and the resident memory is read again. Prints the growth of each after 300,000 steps (a
least-squares slope)::

    python results/memory_control/malloc_growth.py 1000000 \\
        > results/memory_control/malloc_growth.txt
"""

from __future__ import annotations

import ctypes
import sys
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import A2C
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import GPActorCriticPolicy, GPValueCallback

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "examples"))
from long_training_run import resident_mib  # noqa: E402
from mlp_memory import FROM, Memory  # noqa: E402

LIBC = ctypes.CDLL("libc.so.6")


class MallInfo2(ctypes.Structure):
    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
            "fordblks", "keepcost",
        )
    ]  # fmt: skip


LIBC.mallinfo2.restype = MallInfo2


def reading(steps: int) -> tuple[int, float, float, float, float]:
    """Steps, resident MiB, malloc's in-use MiB, free MiB it holds, mmapped MiB."""
    info = LIBC.mallinfo2()
    mib = 2.0**-20
    return steps, resident_mib(), info.uordblks * mib, info.fordblks * mib, info.hblkhd * mib


def main() -> None:
    torch.set_num_threads(1)
    steps = int(sys.argv[1])
    env = make_vec_env("CartPole-v1", n_envs=4, seed=0)
    model = A2C(GPActorCriticPolicy, env, seed=0)
    memory = Memory(reading)
    model.learn(steps, callback=[GPValueCallback(), memory])
    rows = np.array(memory.rows)
    late = rows[:, 0] >= FROM
    names = ("resident", "malloc in use", "malloc free (held)", "mmapped")
    print(f"A2C CartPole-v1, default GP critic, 4 envs, seed 0, {steps:,} steps; MiB; slope "
          f"after {FROM:,} steps per 100,000\n")  # fmt: skip
    print("| memory | start | at 300,000 | end | slope |")
    print("|---|---:|---:|---:|---:|")
    at = int(np.argmax(late))
    for j, name in enumerate(names, start=1):
        slope = np.polyfit(rows[late, 0], rows[late, j], 1)[0] * 100_000
        print(f"| {name} | {rows[0, j]:.1f} | {rows[at, j]:.1f} | {rows[-1, j]:.1f} | "
              f"{slope:+.2f} |")  # fmt: skip
    before = resident_mib()
    LIBC.malloc_trim(0)
    print(f"\nresident memory at the end {before:.1f} MiB, after malloc_trim(0) "
          f"{resident_mib():.1f} MiB")  # fmt: skip


if __name__ == "__main__":
    main()
