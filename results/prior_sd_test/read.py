"""``prior_sd=0.3`` as PPO's default: the registered reading (session 47).

``PREREGISTRATION.md`` fixes the runs (``run.sh``) and the rule read here: the fit on fresh
Acrobot-v1 seeds 510-529 at 100,000 steps (``fit_<arm>``), the returns at 100,000 steps on fresh
seeds 530-569 (``long_<arm>``) and issue 13's 30k PPO cells with ``prior_sd=0.3``
(``table_s<F>``) against the published table's default and SB3's MLP critic. A partial sweep
reads on its finished runs and decides nothing.

    python results/prior_sd_test/read.py > results/prior_sd_test/read.md
    python results/prior_sd_test/read.py --metric mean_return > results/prior_sd_test/auc.md
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.comparison.results import load_results, pool_sweeps
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import difference_ci, mean_ci
from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
DOCS = RESULTS.parent / "docs"
H200 = load_script(RESULTS / "ppo_horizon200" / "table.py", "ppo_horizon200")
TABLE40 = H200.READING.TABLE40
FALLS = load_script(RESULTS / "budget100k" / "falls.py", "budget100k_falls")
ARMS = ("default", "prior30")
FIT_SEEDS = range(510, 530)
LONG_SEEDS = range(530, 570)
TABLE_SEEDS = (0, 10, 150, 160)
LONG_ENVS = ("CartPole-v1", "Acrobot-v1")
#: The PPO cells better than SB3's MLP critic at 95 % in today's table.
BETTER_TODAY = 4
PPO_CELLS = 7
#: A rule's text and its state: "holds", "fails ..." or :data:`PARTIAL`.
Rule = tuple[str, str]


def fit_scores(folder: Path) -> dict[int, float | None]:
    """Issue 13's critic-fit score by seed of the GP critic's Acrobot-v1 runs in an
    ``examples/critic_fit.py`` output folder."""
    runs = [json.loads(p.read_text()) for p in sorted((folder / "runs").glob("*.json"))]
    return {r["seed"]: r["tail_mean"] for r in runs
            if (r["env_id"], r["critic"]) == ("Acrobot-v1", "laplacian")}  # fmt: skip


def paired(a: dict[int, float | None], b: dict[int, float | None]) -> tuple[float, float, int]:
    """``b − a`` paired by the seeds where both are defined: mean, 95 % t half-width, seeds."""
    seeds = sorted(s for s in set(a) & set(b) if a[s] is not None and b[s] is not None)
    diff = np.array([b[s] - a[s] for s in seeds])  # type: ignore[operator]
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    return mean, half, len(diff)


def read_fit() -> list[Rule]:
    """The fit's table and rule 1."""
    scores = {arm: fit_scores(HERE / f"fit_{arm}") for arm in ARMS}
    screen = {
        "default": fit_scores(DOCS / "critic_fit_0_26_100k"),
        "prior30": fit_scores(DOCS / "critic_fit_0_26_screens" / "prior_sd_0.3_100k"),
    }
    screen["default"] = {s: v for s, v in screen["default"].items() if s in screen["prior30"]}
    print("## 1. Fit: Acrobot-v1, 100,000 steps, issue 13's critic-fit score\n")
    print("| seeds | default | prior30 | prior30 − default, paired [95 % t] (seeds) |")
    print("|---|---:|---:|---|")
    rows = {"510-529 (registered)": scores, "0-9 (session 46's screen)": screen}
    rows["pooled (secondary)"] = {arm: {**screen[arm], **scores[arm]} for arm in ARMS}
    for name, arms in rows.items():
        defined = [[v for v in arms[arm].values() if v is not None] for arm in ARMS]
        if not all(defined):
            continue
        means = [np.mean(values) for values in defined]
        mean, half, n = paired(arms["default"], arms["prior30"])
        print(f"| {name} | {means[0]:.3f} | {means[1]:.3f} | "
              f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}] ({n}) |")  # fmt: skip
    mean, half, n = paired(scores["default"], scores["prior30"])
    complete = all(set(scores[arm]) == set(FIT_SEEDS) for arm in ARMS)
    state = ("holds" if mean - half > 0 else "fails") if complete else PARTIAL
    return [(f"1. fit, prior30 − default above 0 at 95 % ({n} seeds)", state)]


def _returns_row(
    runs: dict[str, list[dict[str, Any]]], env_id: str, name: str
) -> tuple[list[int], str]:
    """The seeds both arms have on ``env_id`` and the table row of their final returns."""
    by_seed = [{r["spec"]["seed"]: r["final_return"] for r in runs[arm]
                if r["spec"]["env_id"] == env_id} for arm in ARMS]  # fmt: skip
    seeds = sorted(set(by_seed[0]) & set(by_seed[1]))
    if not seeds:
        return seeds, "–"
    a, b = (np.array([arm[s] for s in seeds]) for arm in by_seed)
    est, lo, hi = (float(v) for v in difference_ci(b, a))
    mean, half = (float(v) for v in mean_ci(b - a, nan_policy="propagate"))
    verdict = "worse" if hi < 0 else "better" if lo > 0 else "no difference"
    print(f"| {env_id}, {name} ({len(seeds)} seeds) | {a.mean():.1f} | {b.mean():.1f} | "
          f"{est:+.1f} [{lo:+.1f}, {hi:+.1f}] | {mean:+.1f} [{mean - half:+.1f}, "
          f"{mean + half:+.1f}] | {verdict} |")  # fmt: skip
    return seeds, verdict


def read_long() -> list[Rule]:
    """The 100,000-step returns, CartPole falls and Acrobot runs at -500, and rule 3; the
    returns pooled with session 46's screen (seeds 490-509) as a secondary reading."""
    runs = {arm: load_results(HERE / f"long_{arm}") for arm in ARMS}
    screen = RESULTS / "prior_sd_screen"
    pooled = {arm: runs[arm] + load_results(screen / arm) for arm in ARMS}
    print("\n## 3. Long: PPO, 100,000 steps, fresh seeds 530-569, final return\n")
    print("| env | default | prior30 | prior30 − default [95 % bootstrap] | paired [95 % t] | "
          "verdict |")  # fmt: skip
    print("|---|---:|---:|---|---|---|")
    lines, complete = [], True
    for env_id in LONG_ENVS:
        seeds, verdict = _returns_row(runs, env_id, "registered")
        complete &= seeds == list(LONG_SEEDS)
        lines.append((f"3. long, {env_id} prior30 − default not worse at 95 %",
                      "holds" if verdict != "worse" else "fails"))  # fmt: skip
    for env_id in LONG_ENVS:
        _returns_row(pooled, env_id, "with the screen's 490-509 (secondary)")
    lines += _rare_failures(runs)
    return [(text, state if complete else PARTIAL) for text, state in lines]


def _rare_failures(runs: dict[str, list[dict[str, Any]]]) -> list[Rule]:
    """CartPole falls and Acrobot runs at -500 per arm, Fisher one-sided (prior30 more)."""
    print(f"\nCartPole-v1 falls (reach {FALLS.THRESHOLD:g} at a checkpoint, end below "
          f"{FALLS.FALLEN:g}; of the runs that reach it) and Acrobot-v1 runs ending at -500 "
          "(of all runs):\n")  # fmt: skip
    print("| event | default | prior30 | Fisher p (one-sided, prior30 more) |")
    print("|---|---:|---:|---:|")
    lines = []
    for name, env_id in (("CartPole fall", "CartPole-v1"), ("Acrobot at -500", "Acrobot-v1")):
        cells = []
        for arm in ARMS:
            mine = [r for r in runs[arm] if r["spec"]["env_id"] == env_id]
            if env_id == "CartPole-v1":
                _, n, fell = FALLS.counts(mine, "laplacian")
                cells.append((len(fell), n, fell))
            else:
                stuck = [r["spec"]["seed"] for r in mine if r["final_return"] <= -500]
                cells.append((len(stuck), len(mine), stuck))
        (k0, n0, s0), (k1, n1, s1) = cells
        p = float(sps.fisher_exact([[k1, n1 - k1], [k0, n0 - k0]], alternative="greater").pvalue)
        print(f"| {name} | {k0} of {n0} {s0 or ''} | {k1} of {n1} {s1 or ''} | {p:.3f} |")
        lines.append((f"3. {name} not more frequent with prior30 (p {p:.3f})",
                      "holds" if p >= 0.05 else "fails"))  # fmt: skip
    return lines


def table_arms(runs: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], ...]:
    """prior30's, the published default's and SB3's MLP critic's PPO runs of issue 13's table
    (``runs``), on the (env, seed) pairs all three have, and the table's A2C runs."""
    folders = [HERE / f"table_s{f}" for f in TABLE_SEEDS]
    prior = pool_sweeps([f for f in folders if f.is_dir()])
    ppo = [r for r in runs if r["spec"]["algo"] == "ppo"]
    default = [r for r in ppo if r["spec"]["critic"] != "mlp"]
    mlp = [r for r in ppo if r["spec"]["critic"] == "mlp"]
    a2c = [r for r in runs if r["spec"]["algo"] == "a2c"]
    return (*TABLE40.on_common_seeds(prior, default, mlp), a2c)


def read_table(metric: str) -> list[Rule]:
    """Issue 13's table with prior30 in the PPO cells, prior30 − default, and rule 2."""
    published, _, _ = H200.table_runs((H200.MCC,))
    prior, default, mlp, a2c = table_arms(published)
    label = H200.READING.LABELS[metric]
    new = H200.mlp_rows(prior + mlp + a2c, metric)
    old = H200.mlp_rows(published, metric)
    print(f"\n## 2. Table: issue 13's 30k cells, prior30 in the PPO rows, {label}\n")
    H200.print_table(new, label)
    print(f"\n### prior30 − default (family-wise over the {PPO_CELLS} PPO cells)\n")
    against = TABLE40.against_default(prior, default, metric)
    H200.print_table(against, label, "prior30 − default")
    ppo_new = {k: c for k, c in new.items() if k[1] == "ppo"}
    lost = [env for (env, algo), c in old.items() if algo == "ppo"
            and c["verdict"] == "better" and (env, algo) in ppo_new
            and ppo_new[env, algo]["verdict"] != "better"]  # fmt: skip
    worse = [sum(c["verdict"] == "worse" for c in t.values()) for t in (new, old)]
    fw_worse = [env for (env, _), c in new.items() if c["fw_verdict"] == "worse"]
    worse_default = [env for (env, _), c in against.items() if c["fw_verdict"] == "worse"]
    complete = len(ppo_new) == PPO_CELLS and all(c["n_a"] == 40 for c in ppo_new.values())
    better_today = sum(c["verdict"] == "better" for (_, algo), c in old.items() if algo == "ppo")
    assert metric != "final_return" or better_today == BETTER_TODAY, "the table changed"
    rules = [
        ("2. no cell worse than the MLP family-wise", _holds(fw_worse)),
        ("2. no PPO cell better today lost", _holds(lost)),
        (f"2. cells worse at 95 %: {worse[0]}, not more than today's {worse[1]}",
         "holds" if worse[0] <= worse[1] else "fails"),
        (f"2. prior30 − default not worse family-wise over the {PPO_CELLS} cells",
         _holds(worse_default)),
    ]  # fmt: skip
    return [(text, state if complete else PARTIAL) for text, state in rules]


def _holds(failures: list[str]) -> str:
    return "holds" if not failures else f"fails ({', '.join(failures)})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=("final_return", "mean_return"), default="final_return")
    args = parser.parse_args()
    if args.metric == "mean_return":
        read_table(args.metric)
        return
    rules = read_fit() + read_table(args.metric) + read_long()
    print("\n## The registered rule\n")
    kept, adopted = "the default keeps `prior_sd=0.1`", "adopt `prior_sd=0.3` as PPO's default"
    print(registered_decision(rules, kept, adopted))


if __name__ == "__main__":
    main()
