"""``GPValueCallback(feed_every=4)`` as A2C's default: the registered reading (session 48).

``PREREGISTRATION.md`` fixes the runs (``run.sh``: ``every4_s<F>``, issue 13's seven A2C cells
with the GP fed every fourth rollout) and the rule read here, on seeds 0-19: every4 − the
default's stored runs not worse at 95 % in any cell, every4 − SB3's MLP critic not worse
family-wise (the table's 42). The secondary readings take every seed finished, whole blocks of
ten only. A partial primary sweep decides nothing.

    python results/a2c_feed_every/read.py > results/a2c_feed_every/read.md
    python results/a2c_feed_every/read.py --metric mean_return > results/a2c_feed_every/auc.md

``--screens`` reads the exploratory CartPole-v1 screens made after the registered reading
(seeds 0-19, the test's own): fed every 2nd rollout (``screen_every2``) and every 4th with a
refit every 4 blocks instead of 16 (``screen_every4_gap4``, the default's refit cadence in
rollouts):

    python results/a2c_feed_every/read.py --screens > results/a2c_feed_every/screens.md

The reading serves any A2C arm registered against the default and the MLP critic on these
seeds (:class:`Arm`, :func:`reading`): ``results/a2c_basis128/read.py`` reads its arm with it.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import difference_ci
from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
H200 = load_script(RESULTS / "ppo_horizon200" / "table.py", "ppo_horizon200")
TABLE40 = H200.READING.TABLE40
POOL30 = load_script(RESULTS / "replication_0_15" / "pool30.py", "pool30")
PRIMARY = (0, 10)
BLOCKS = (0, 10, 30, 70)
A2C_CELLS = 7


class Arm(NamedTuple):
    """A registered A2C arm: its name in the tables, its folder, and what its adoption
    would make the default."""

    name: str
    folder: Path
    adopted: str

    def runs(self, blocks: tuple[int, ...]) -> list[dict[str, Any]]:
        """The arm's runs of the seed blocks given (``<name>_s<F>``) that have all their runs."""
        return _block_runs(self.folder, self.name, blocks)


@functools.cache
def _block_runs(folder: Path, name: str, blocks: tuple[int, ...]) -> list[dict[str, Any]]:
    folders = [folder / f"{name}_s{f}" for f in blocks]
    done = [f for f in folders if f.is_dir() and len(list((f / "runs").glob("*.json"))) == 70]
    return pool_sweeps(done) if done else []


EVERY4 = Arm("every4", HERE, "adopt `feed_every=4` as A2C's default")


@functools.cache
def published() -> tuple[list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """Issue 13's published table: its PPO runs, and its A2C default's and MLP critic's runs."""
    runs, _, _ = H200.table_runs((H200.MCC,))
    ppo = [r for r in runs if r["spec"]["algo"] == "ppo"]
    a2c = [r for r in runs if r["spec"]["algo"] == "a2c"]
    default = [r for r in a2c if r["spec"]["critic"] != "mlp"]
    mlp = [r for r in a2c if r["spec"]["critic"] == "mlp"]
    return ppo, default, mlp


def n_seeds(runs: list[dict[str, Any]]) -> int:
    return len({r["spec"]["seed"] for r in runs})


def read(arm: Arm, blocks: tuple[int, ...], metric: str, title: str) -> list[tuple[str, str]]:
    """arm − default and arm − MLP on the seeds of ``blocks``; the rule's lines."""
    _, default_all, mlp_all = published()
    runs, default, mlp = TABLE40.on_common_seeds(arm.runs(blocks), default_all, mlp_all)
    label, name = H200.READING.LABELS[metric], arm.name
    print(f"## {title}: {n_seeds(runs)} seeds, {label}\n")
    if not runs:
        print("No finished block.\n")
        return [("no finished block", PARTIAL)]
    print(f"### {name} − default (family-wise over the {A2C_CELLS} A2C cells)\n")
    against = POOL30.against_baseline(runs, default, metric, A2C_CELLS)
    H200.print_table(against, label, f"{name} − default")
    print(f"\n### {name} − MLP and default − MLP, the table's rule (family-wise at 42)\n")
    new = POOL30.mlp_rows(runs + mlp, metric)
    old = POOL30.mlp_rows(default + mlp, metric)
    H200.print_table(new, label, f"{name} − MLP")
    print()
    H200.print_table(old, label, "default − MLP")
    print(f"\nCells ({name} / default against the MLP): {_counts(new)} / {_counts(old)}\n")
    worse_default = [env for (env, _), c in against.items() if c["verdict"] == "worse"]
    fw_worse = [env for (env, _), c in new.items() if c["fw_verdict"] == "worse"]
    complete = len(against) == A2C_CELLS and n_seeds(runs) == 10 * len(blocks)
    rules = [
        (f"1. {name} − default not worse at 95 % in any A2C cell", _holds(worse_default)),
        (f"2. {name} − MLP not worse family-wise in any A2C cell", _holds(fw_worse)),
    ]
    return [(text, state if complete else PARTIAL) for text, state in rules]


def _counts(rows: dict[tuple[str, str], dict[str, Any]]) -> str:
    verdicts = [c["verdict"] for c in rows.values()]
    fw = sum(c["fw_verdict"] == "better" for c in rows.values())
    better, same, worse = (verdicts.count(v) for v in ("better", "no difference", "worse"))
    return f"{better} better ({fw} family-wise), {same} no different, {worse} worse"


def full_table(arm: Arm, metric: str) -> None:
    """Issue 13's table with the arm as its A2C rows, where all four seed blocks finished."""
    runs = arm.runs(BLOCKS)
    if n_seeds(runs) < 10 * len(BLOCKS):
        print(f"\n## Issue 13's table with {arm.name}'s A2C rows: not every block finished\n")
        return
    ppo, default, mlp = published()
    label = H200.READING.LABELS[metric]
    print(f"\n## Issue 13's table with {arm.name}'s A2C rows (secondary), {label}\n")
    rows = POOL30.mlp_rows(ppo + runs + mlp, metric)
    H200.print_table(rows, label)
    today = POOL30.mlp_rows(ppo + default + mlp, metric)
    print(f"\nCells: {_counts(rows)}; today's: {_counts(today)}")


def critic_seconds() -> None:
    """The GP critic's update seconds per run, every4 against the default's stored runs."""
    _, default_all, _ = published()
    every4, default = TABLE40.on_common_seeds(EVERY4.runs(BLOCKS), default_all)
    print("\n## The GP's update seconds per run (median; the default's runs were made in "
          "session 36 on a machine about 4x slower, so the ratio is not a measurement: "
          "docs/benchmarks.md's interleaved one is)\n")  # fmt: skip
    print("| env | default | every4 | ratio |")
    print("|---|---:|---:|---:|")
    for env in sorted({r["spec"]["env_id"] for r in every4}):
        a, b = (float(np.median([r["critic_seconds"]["gp_update"] for r in runs
                                 if r["spec"]["env_id"] == env]))
                for runs in (default, every4))  # fmt: skip
        print(f"| {env} | {a:.1f} | {b:.1f} | {b / a:.2f} |")


def screens() -> None:
    """CartPole-v1, seeds 0-19: each screen and every4 against the default, final return."""
    _, default_all, _ = published()
    folders = {
        "every4 (registered)": [HERE / f"every4_s{f}" for f in PRIMARY],
        "every2": [HERE / "screen_every2"],
        "every4, refit every 4 blocks (max_gap=4)": [HERE / "screen_every4_gap4"],
    }
    print("## CartPole-v1, A2C, seeds 0-19: screens after the registered reading (exploratory)\n")
    print("| arm | mean | default | arm − default [95 % bootstrap] | runs below 500 |")
    print("|---|---:|---:|---|---:|")
    for name, dirs in folders.items():
        runs = [r for r in pool_sweeps(dirs) if r["spec"]["env_id"] == "CartPole-v1"]
        arm, default = TABLE40.on_common_seeds(runs, default_all)
        a, b = (np.array([r["final_return"] for r in sorted(x, key=lambda r: r["spec"]["seed"])])
                for x in (arm, default))  # fmt: skip
        est, lo, hi = (float(v) for v in difference_ci(a, b))
        print(f"| {name} ({len(a)} seeds) | {a.mean():.1f} | {b.mean():.1f} | "
              f"{est:+.1f} [{lo:+.1f}, {hi:+.1f}] | {int((a < 500).sum())} (default "
              f"{int((b < 500).sum())}) |")  # fmt: skip


def _holds(failures: list[str]) -> str:
    return "holds" if not failures else f"fails ({', '.join(failures)})"


def reading(arm: Arm, kept: str, metric: str) -> None:
    """The registered reading of ``arm`` (``kept``: what the default keeps if it fails)."""
    rules = read(arm, PRIMARY, metric, "Primary, seeds 0-19")
    if metric == "final_return":
        print("\n## The registered rule (final return, seeds 0-19)\n")
        print(registered_decision(rules, kept, arm.adopted) + "\n")
    finished = tuple(f for f in BLOCKS if arm.runs((f,)))
    if finished and finished != PRIMARY:
        blocks = ", ".join(map(str, finished))
        read(arm, finished, metric, f"Secondary, every finished block ({blocks})")
    full_table(arm, metric)


def arguments(description: str, screens: bool = False) -> argparse.Namespace:
    """``--metric`` (and ``--screens``) of a reading script."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--metric", choices=("final_return", "mean_return"), default="final_return")
    if screens:
        parser.add_argument("--screens", action="store_true", help="the CartPole-v1 screens only")
    return parser.parse_args()


def main() -> None:
    args = arguments(__doc__.split("\n\n")[0], screens=True)
    if args.screens:
        screens()
        return
    reading(EVERY4, "A2C keeps feeding every rollout", args.metric)
    if args.metric == "final_return":
        critic_seconds()


if __name__ == "__main__":
    main()
