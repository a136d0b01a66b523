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
BLOCKS = (0, 10, 150, 160, 570)
TOUCHED = ("CartPole-v1", "Acrobot-v1", "Pendulum-v1", "sb3_geogp/PaperPendulum-v0")
BETTER_TODAY = ("Acrobot-v1", "CartPole-v1", "Pendulum-v1")
CHECKED = ("MountainCarContinuous-v0", "sb3_geogp/WallMaze-v0", "sb3_geogp/WallMazeDiscrete-v0")


def fit_scores(arm: str, env: str, key: str) -> np.ndarray | None:
    """Each seed's score ``key`` of ``arm`` on ``env``; None unless every seed finished."""
    paths = [HERE / f"fit_{arm}" / "runs" / f"laplacian__{env}__s{s}.json" for s in FIT_SEEDS]
    if not all(p.is_file() for p in paths):
        return None
    return np.array([json.loads(p.read_text())[key] for p in paths], dtype=float)


def fit() -> tuple[str, str]:
    """The fit table and rule 1."""
    print("## Fit: issue 13's critic-fit score, seeds 713-742\n")
    print("| env | reading | default (at 0.9) | whole (at 0.9) | whole − default [95 % t] | "
          "paired median | seeds up / down | Wilcoxon p |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    rule = ("1. Acrobot-v1 fit, whole − default, 95 % t interval above 0", PARTIAL)
    for env in FIT_ENVS:
        for reading, key in (("per rollout", "tail_mean"), ("pooled", "tail_pooled")):
            default, whole = fit_scores("default", env, key), fit_scores("whole", env, key)
            if default is None or whole is None:
                print(f"| {env} | {reading} | not every seed finished | | |")
                continue
            diff = whole - default
            mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
            cells = [f"{a.mean():.3f} ({int((a >= 0.9).sum())}/{len(a)})" for a in (default, whole)]
            signs = f"{int((diff > 0).sum())} / {int((diff < 0).sum())}"
            p = float(sps.wilcoxon(diff).pvalue)
            print(f"| {env} | {reading} | {' | '.join(cells)} | "
                  f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}] | "
                  f"{float(np.median(diff)):+.3f} | {signs} | {p:.2g} |")  # fmt: skip
            if (env, key) == ("Acrobot-v1", "tail_mean"):
                rule = (rule[0], "holds" if mean - half > 0 else "fails")
    print("\n(The registered rule reads the t interval; the paired median, the seeds' signs "
          "and the two-sided Wilcoxon signed-rank test are secondary, decided on by "
          "nothing.)\n")  # fmt: skip
    return rule


def check(published: list[dict[str, Any]]) -> tuple[str, str]:
    """Rule 3: the whole arm's seed-0 runs in the untouched cells equal the stored ones."""
    folder = HERE / "check"
    runs = pool_sweeps([folder]) if folder.is_dir() else []
    if len(runs) < len(CHECKED):
        return ("3. the untouched cells' seed-0 runs equal the default's", PARTIAL)
    stored = {r["spec"]["env_id"]: r for r in published
              if r["spec"]["seed"] == 0 and r["spec"]["critic"] == "laplacian"}  # fmt: skip
    differ = [r["spec"]["env_id"] for r in runs
              if r["eval"] != stored[r["spec"]["env_id"]]["eval"]]  # fmt: skip
    current = {r["spec"]["env_id"]: r for r in pool_sweeps([HERE / "check_default"])}
    for env in differ:  # the addendum: against 0.34.1's default run instead of the stored one
        same = env in current and current[env]["eval"] == next(
            r["eval"] for r in runs if r["spec"]["env_id"] == env
        )
        print(f"Addendum: {env}, seed 0, the whole arm equals 0.34.1's own default run "
              f"(`check_default/`) bit for bit: {same}\n")  # fmt: skip
    return ("3. the untouched cells' seed-0 runs equal the default's", _holds(differ))


def table(published: list[dict[str, Any]], metric: str) -> list[tuple[str, str]]:
    """Rules 2a-c on issue 13's table with the whole arm in the cells it can touch."""
    whole = pool_sweeps([f for f in (HERE / f"table_s{b}" for b in BLOCKS) if f.is_dir()])
    complete = len(whole) == len(TOUCHED) * 10 * len(BLOCKS)
    default = [r for r in published if _touched(r)]
    others = [r for r in published if not _touched(r)]
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


def _touched(run: dict[str, Any]) -> bool:
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
