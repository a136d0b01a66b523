"""``whole_batch=True`` as PPO's default: the registered reading (session 68).

``PREREGISTRATION.md`` fixes the runs (``run.sh``) and the rules read here: the critic-fit
benefit on Acrobot-v1 (``fit_default`` against ``fit_whole``, seeds 713-742), the check that the
cells the option cannot touch are unchanged (``check``), and issue 13's table on its 50 seeds
with the whole arm's runs (``table_s<F>``) in place of the default's in the four cells it can
touch. A partial run decides nothing.

    python results/whole_batch/read.py > results/whole_batch/read.md
    python results/whole_batch/read.py --metric mean_return > results/whole_batch/auc.md
    python results/whole_batch/read.py --metric critic_rmse > results/whole_batch/rmse.md
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
TABLE50 = load_script(RESULTS / "table50" / "read.py", "table50")
POOL30 = TABLE50.POOL30
LABELS = {**TABLE50.H200.READING.LABELS, "critic_rmse": "final critic RMSE (lower is better)"}
FIT_SEEDS = range(713, 743)
FIT_ENVS = ("Acrobot-v1", "Pendulum-v1")
#: the two arms' folders: without and with ``whole_batch``
ARMS = ("fit_default", "fit_whole")
BLOCKS = (0, 10, 150, 160, 570)
TOUCHED = ("CartPole-v1", "Acrobot-v1", "Pendulum-v1", "sb3_geogp/PaperPendulum-v0")
BETTER_TODAY = ("Acrobot-v1", "CartPole-v1", "Pendulum-v1")
CHECKED = ("MountainCarContinuous-v0", "sb3_geogp/WallMaze-v0", "sb3_geogp/WallMazeDiscrete-v0")


def fit_scores(folder: Path, arm: str, env: str, key: str, seeds: range) -> np.ndarray | None:
    """Each seed's score ``key`` of ``arm`` on ``env``; None unless every seed finished."""
    paths = [folder / arm / "runs" / f"laplacian__{env}__s{s}.json" for s in seeds]
    if not all(p.is_file() for p in paths):
        return None
    return np.array([json.loads(p.read_text())[key] for p in paths], dtype=float)


def fit_table(
    folder: Path,
    seeds: range,
    envs: tuple[str, ...],
    primary: str,
    arms: tuple[str, str] = ARMS,
    names: tuple[str, str] = ("default", "whole"),
) -> dict[tuple[str, str], np.ndarray]:
    """Print the fit of both arms (``arms``: the folders in ``folder`` of the baseline and the
    change, by default without and with ``whole_batch``; ``names``: their columns' names) and
    their paired differences by the mean's t interval and by ranks (``primary`` says which one
    its test's rule reads); return the differences change − baseline by (env, score key), for
    the (env, key) whose seeds all finished."""
    base, change = names
    print(f"## Fit: issue 13's critic-fit score, seeds {seeds.start}-{seeds.stop - 1}\n")
    print(f"| env | reading | {base} (at 0.9) | {change} (at 0.9) | {change} − {base} [95 % t] | "
          "paired median | seeds up / down | Wilcoxon p |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    diffs = {}
    for env in envs:
        for reading, key in (("per rollout", "tail_mean"), ("pooled", "tail_pooled")):
            default, whole = (fit_scores(folder, arm, env, key, seeds) for arm in arms)
            if default is None or whole is None:
                print(f"| {env} | {reading} | not every seed finished | | | | | |")
                continue
            diff = diffs[(env, key)] = whole - default
            mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
            cells = [f"{a.mean():.3f} ({int((a >= 0.9).sum())}/{len(a)})" for a in (default, whole)]
            signs = f"{int((diff > 0).sum())} / {int((diff < 0).sum())}"
            print(f"| {env} | {reading} | {' | '.join(cells)} | "
                  f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}] | "
                  f"{float(np.median(diff)):+.3f} | {signs} | {wilcoxon(diff):.2g} |")  # fmt: skip
    print(f"\n({primary}; the other columns are secondary, "
          "decided on by nothing. Wilcoxon: two-sided signed-rank test of the paired "
          "differences.)\n")  # fmt: skip
    return diffs


def wilcoxon(diff: np.ndarray) -> float:
    """Two-sided Wilcoxon signed-rank p of paired differences ``diff``; NaN where every
    difference is 0 (the runs are the same: no evidence either way)."""
    return float(sps.wilcoxon(diff).pvalue) if np.any(diff != 0) else math.nan


def fit() -> tuple[str, str]:
    """The fit table and rule 1."""
    rule = "The registered rule reads the per-rollout score's 95 % t interval"
    diffs = fit_table(HERE, FIT_SEEDS, FIT_ENVS, rule)
    text = "1. Acrobot-v1 fit, whole − default, 95 % t interval above 0"
    diff = diffs.get(("Acrobot-v1", "tail_mean"))
    if diff is None:
        return (text, PARTIAL)
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    return (text, "holds" if mean - half > 0 else "fails")


def check(published: list[dict[str, Any]]) -> tuple[str, str]:
    """Rule 3: the whole arm's seed-0 runs in the untouched cells equal the stored ones."""
    folder = HERE / "check"
    runs = pool_sweeps([folder]) if folder.is_dir() else []
    if len(runs) < len(CHECKED):
        return ("3. the untouched cells' seed-0 runs equal the default's", PARTIAL)
    differ = differing(runs, seed0_defaults(published))
    current = by_env(pool_sweeps([HERE / "check_default"]))
    # the addendum: against 0.34.1's default run instead of the stored one
    still = differing([r for r in runs if r["spec"]["env_id"] in differ], current)
    for env in differ:
        print(f"Addendum: {env}, seed 0, the whole arm equals 0.34.1's own default run "
              f"(`check_default/`) bit for bit: {env not in still}\n")  # fmt: skip
    return ("3. the untouched cells' seed-0 runs equal the default's", _holds(differ))


def by_env(runs: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """``runs`` by their env (one run each)."""
    return {r["spec"]["env_id"]: r for r in runs}


def seed0_defaults(published: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The stored default PPO GP critic's seed-0 run of every cell, by env."""
    return by_env([r for r in published if seed0_ppo_default(r)])


def differing(runs: list[dict[str, Any]], reference: dict[str, dict[str, Any]]) -> list[str]:
    """The envs of ``runs`` whose evaluations differ from their env's run in ``reference``
    (or that have none there)."""
    return [
        r["spec"]["env_id"]
        for r in runs
        if r["spec"]["env_id"] not in reference
        or r["eval"] != reference[r["spec"]["env_id"]]["eval"]
    ]


def table(published: list[dict[str, Any]], metric: str) -> list[tuple[str, str]]:
    """Rules 2a-c on issue 13's table with the whole arm in the cells it can touch."""
    whole = pool_sweeps([f for f in (HERE / f"table_s{b}" for b in BLOCKS) if f.is_dir()])
    complete = len(whole) == len(TOUCHED) * 10 * len(BLOCKS)
    default = [r for r in published if touched(r)]
    others = [r for r in published if not touched(r)]
    whole, same_seeds = TABLE50.VERDICT.H200.READING.TABLE40.on_common_seeds(whole, default)
    label = LABELS[metric]
    print(f"## Issue 13's table, {label}: whole − default in the four cells it can touch "
          f"(family-wise over 4)\n")  # fmt: skip
    if not whole:
        print("No finished run.\n")
        return [("2. the table", PARTIAL)]
    against = POOL30.against_baseline(whole, same_seeds, metric, len(TOUCHED))
    POOL30.print_table(against, label, "whole − default")
    new = POOL30.mlp_rows(others + whole, metric)
    old = POOL30.mlp_rows(published, metric)
    print(f"\n## Issue 13's table with the whole arm (the table's rule, family-wise at 42), "
          f"{label}\n")  # fmt: skip
    POOL30.print_table(new, label)
    print(f"\nToday's table on the same runs' seeds, {label}:\n")
    POOL30.print_table(old, label)
    print()
    fw_worse = [env for (env, _), c in new.items() if c["fw_verdict"] == "worse"]
    lost = [env for env in BETTER_TODAY if new[(env, "ppo")]["verdict"] != "better"]
    worse = [env for (env, _), c in against.items() if c["verdict"] == "worse"]
    rules = [
        ("2a. no cell worse than SB3's MLP critic family-wise", _holds(fw_worse)),
        ("2b. no cell better at 95 % today stops being better", _holds(lost)),
        ("2c. whole − default not worse at 95 % in the four cells", _holds(worse)),
    ]
    return [(text, state if complete else PARTIAL) for text, state in rules]


def seed0_ppo_default(run: dict[str, Any]) -> bool:
    """Whether ``run`` is the default PPO GP critic's run of seed 0."""
    s = run["spec"]
    return (s["algo"], s["critic"], s["seed"]) == ("ppo", "laplacian", 0)


def touched(run: dict[str, Any]) -> bool:
    """Whether ``run`` is one of the default GP critic's in a cell the option can touch."""
    s = run["spec"]
    return (s["algo"], s["critic"]) == ("ppo", "laplacian") and s["env_id"] in TOUCHED


def _holds(failures: list[str]) -> str:
    return "holds" if not failures else f"fails ({', '.join(failures)})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=tuple(LABELS), default="final_return")
    args = parser.parse_args()
    published = TABLE50.published_and_fresh()
    rules = [fit(), *table(published, args.metric), check(published)]
    if args.metric == "final_return":
        print("## The registered rule\n")
        adopted = "adopt `whole_batch=True` in PPO's default adaptation"
        print(registered_decision(rules, "PPO's default keeps `whole_batch=False`", adopted))


if __name__ == "__main__":
    main()
