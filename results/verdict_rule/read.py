"""How often the verdict rule errs, and issue 13's table re-read with two exact-level tests
(session 58, after an audit; not registered).

The comparisons' verdict rule (``sb3_geogp.toolbox.stats.difference_ci``, used by every table
since 0.1): a 95 % percentile-bootstrap interval of the difference of means, family-wise at
``1 - 0.05 / 42``. A percentile bootstrap's interval is too narrow for small samples (it
spreads by the sample's standard deviation with divisor n, and by normal quantiles), and a
group whose runs are all equal is resampled as if its mean were known exactly. This script
measures the rule's error rate where the critics do not differ (simulated; Welch's t-test on
the same data beside it), then re-reads issue 13's table (``results/table50``'s runs) with
Welch's t-test and a permutation test of the difference of means (scipy's; 100,000
permutations, seeded), at the same two levels::

    python results/verdict_rule/read.py > results/verdict_rule/read.md
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats
from tqdm import tqdm

from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import difference_ci, permutation_pvalue

HERE = Path(__file__).resolve().parent
TABLE50 = load_script(HERE.parent / "table50" / "read.py", "table50_read")
FAMILY = 42  # the published family size
LEVELS = {"95 %": 0.05, "family-wise": 0.05 / FAMILY}
N_NULL = 2000
PERMUTATIONS = 100_000


def rejects(a: np.ndarray, b: np.ndarray) -> dict[str, dict[str, bool]]:
    """Whether each rule finds ``a`` and ``b`` different, at each of :data:`LEVELS`."""
    welch = stats.ttest_ind(a, b, equal_var=False).pvalue
    out: dict[str, dict[str, bool]] = {"bootstrap": {}, "Welch": {}}
    for name, alpha in LEVELS.items():
        _, low, high = difference_ci(a, b, level=1 - alpha)
        out["bootstrap"][name] = bool(low > 0 or high < 0)
        out["Welch"][name] = bool(welch < alpha)
    return out


def null_rates(draw: Any, label: str) -> list[str]:
    """Rejection rates of both rules over :data:`N_NULL` datasets of ``draw(rng)``."""
    counts: dict[tuple[str, str], int] = defaultdict(int)
    rng = np.random.default_rng(0)
    for _ in tqdm(range(N_NULL), desc=label, leave=False):
        a, b = draw(rng)
        for rule, by_level in rejects(a, b).items():
            for level, rejected in by_level.items():
                counts[rule, level] += rejected
    rate = {k: v / N_NULL for k, v in counts.items()}
    return [
        f"| {label} | {rate['bootstrap', '95 %']:.4f} | {rate['Welch', '95 %']:.4f} "
        f"| {rate['bootstrap', 'family-wise']:.5f} | {rate['Welch', 'family-wise']:.5f} |"
    ]


def floor(rng: np.random.Generator, n: int) -> np.ndarray:
    """Runs at a floor (-99.9) or, with probability 0.08, above it: the shape of A2C
    MountainCarContinuous-v0's final returns."""
    above = rng.random(n) < 0.08
    return np.where(above, -99.9 + rng.exponential(30.0, n), -99.9)


def cells(runs: list[dict[str, Any]]) -> dict[tuple[str, str], dict[str, np.ndarray]]:
    """Final returns by (algo, env) and critic."""
    out: dict[tuple[str, str], dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in runs:
        out[r["spec"]["algo"], r["spec"]["env_id"]][r["spec"]["critic"]].append(r["final_return"])
    return {cell: {c: np.array(v) for c, v in by.items()} for cell, by in out.items()}


def reread(runs: list[dict[str, Any]], label: str) -> list[str]:
    """Each cell's GP − MLP difference of mean final return, and each rule's verdict."""
    lines = [
        f"\n**{label}**\n",
        "| cell | GP − MLP | bootstrap (published rule) | Welch p | permutation p |",
        "|---|---:|---|---:|---:|",
    ]
    tally: dict[str, list[int]] = {"bootstrap": [0, 0], "Welch": [0, 0], "permutation": [0, 0]}
    for (algo, env), by in tqdm(sorted(cells(runs).items()), desc=label, leave=False):
        gp_name = next(c for c in by if c != "mlp")
        assert set(by) == {gp_name, "mlp"}, by.keys()
        a, b = by[gp_name], by["mlp"]
        p = {
            "Welch": stats.ttest_ind(a, b, equal_var=False).pvalue,
            "permutation": permutation_pvalue(a, b, n_resamples=PERMUTATIONS, seed=0),
        }
        boot = rejects(a, b)["bootstrap"]
        better = a.mean() > b.mean()
        for i, level in enumerate(LEVELS):
            tally["bootstrap"][i] += boot[level] and better
            for rule in p:
                tally[rule][i] += bool(p[rule] < LEVELS[level]) and better
        worse = "" if better else " (GP lower)"
        verdict = "family-wise" if boot["family-wise"] else "95 %" if boot["95 %"] else "no"
        lines.append(
            f"| {algo} {env} | {a.mean() - b.mean():+.1f}{worse} | {verdict} "
            f"| {p['Welch']:.2g} | {p['permutation']:.2g} |"
        )
    lines.append("")
    lines.append("| rule | better at 95 % | better family-wise |")
    lines.append("|---|---:|---:|")
    for rule, (at95, fw) in tally.items():
        lines.append(f"| {rule} | {at95} | {fw} |")
    return lines


def main() -> None:
    lines = [
        "## How often the verdict rule errs (session 58)\n",
        f"Rejection rates where the two groups do not differ, {N_NULL:,} simulated datasets each "
        f"(nominal: 0.05 at 95 %, {0.05 / FAMILY:.5f} family-wise at 1 − 0.05/{FAMILY}):\n",
        "| null data, per group | bootstrap, 95 % | Welch, 95 % | bootstrap, family-wise "
        "| Welch, family-wise |",
        "|---|---:|---:|---:|---:|",
    ]
    for n in (10, 40, 50):
        lines += null_rates(
            lambda rng, n=n: (rng.normal(size=n), rng.normal(size=n)), f"normal, {n}"
        )
    for n in (10, 50):
        lines += null_rates(lambda rng, n=n: (floor(rng, n), floor(rng, n)), f"floor-shaped, {n}")
    tables = {
        "50 seeds per cell (the table since session 48)": TABLE50.published_and_fresh(),
        "the published 40 seeds (the registered table of session 45)": TABLE50.H200.table_runs(
            (TABLE50.H200.MCC,)
        )[0],
        "the fresh 10 seeds alone": TABLE50.fresh_runs(),
    }
    for label, runs in tables.items():
        lines += reread(runs, label)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
