"""Issue 13's table aggregated over its cells with rliable: the probability of improvement.

A secondary reading (session 50), defined after all the table's runs: for each of the 14 cells,
``P(GP > MLP)``, the probability that a run of the default GP critic ends above a run of SB3's
MLP critic (Mann-Whitney U over all pairs of the cell's 50 + 50 runs, ties counting half), and
its mean over the cells (all 14, PPO's 7, A2C's 7) with a 95 % stratified-bootstrap interval
(runs resampled within each cell and critic, seeded), as rliable computes them (Agarwal et al. 2021,
``rliable.metrics.probability_of_improvement``). 0.5 is no difference; unlike the table's
difference of means it needs no score normalisation across tasks and weighs each cell alike.
Needs ``pip install "sb3_geogp[rliable]"`` (rliable, with pandas < 3 for its dependency arch).

    python results/table50/aggregate.py --plot results/table50/aggregate.png \\
        > results/table50/aggregate.md
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps
from rliable import library as rly
from rliable import metrics

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
READ = load_script(HERE / "read.py", "table50_read")
REPS = 20_000


def cell_scores(metric: str) -> tuple[list[tuple[str, str]], np.ndarray, np.ndarray]:
    """Cells (algo, env) and the GP's and the MLP critic's scores, each (runs, cells)."""
    published, _, _ = READ.H200.table_runs((READ.H200.MCC,))
    runs = published + READ.fresh_runs()
    by_cell: dict[tuple[str, str], dict[str, dict[int, float]]] = {}
    for r in runs:
        spec = r["spec"]
        arm = "mlp" if spec["critic"] == "mlp" else "gp"
        value = (
            r["final_return"]
            if metric == "final_return"
            else float(np.mean(r["eval"]["mean_return"]))
        )
        by_cell.setdefault((spec["algo"], spec["env_id"]), {}).setdefault(arm, {})[spec["seed"]] = (
            value
        )
    cells = sorted(by_cell, key=lambda c: (c[0] != "ppo", c[1]))
    # Runs are exchangeable within a cell and the cells' seed sets differ (the table pooled
    # different published seeds per algorithm): each cell's column holds its own runs.
    sizes = {len(by_cell[c][arm]) for c in cells for arm in ("gp", "mlp")}
    if len(sizes) != 1:
        raise ValueError(
            f"every cell needs the same number of runs per critic, got {sorted(sizes)}"
        )
    gp, mlp = (
        np.array([[v for _, v in sorted(by_cell[c][arm].items())] for c in cells]).T
        for arm in ("gp", "mlp")
    )
    return cells, gp, mlp


def per_cell(gp: np.ndarray, mlp: np.ndarray) -> np.ndarray:
    """``P(GP > MLP)`` of each cell (ties half), shape (cells,)."""
    return np.array(
        [metrics.probability_of_improvement(gp[:, [j]], mlp[:, [j]]) for j in range(gp.shape[1])]
    )


def aggregate(gp: np.ndarray, mlp: np.ndarray, columns: list[int]) -> tuple[float, float, float]:
    pairs = {"gp,mlp": (gp[:, columns], mlp[:, columns])}
    # rliable's stratified bootstraps draw their indices from NumPy's global generator
    # (``np.random.choice``), whatever ``random_state`` says: seeding it makes the interval
    # reproducible (checked: two runs with a RandomState alone gave different intervals).
    np.random.seed(0)  # noqa: NPY002  (the generator rliable uses)
    point, interval = rly.get_interval_estimates(
        pairs, metrics.probability_of_improvement, reps=REPS
    )
    lo, hi = interval["gp,mlp"].ravel()
    return float(point["gp,mlp"]), float(lo), float(hi)


def report(metric: str, plot: str | None) -> None:
    cells, gp, mlp = cell_scores(metric)
    label = {"final_return": "final return", "mean_return": "area under the curve"}[metric]
    print(f"## Probability of improvement, GP over MLP, {label} ({gp.shape[0]} seeds per cell)\n")
    print("| cells | P(GP > MLP) [95 % stratified bootstrap] |")
    print("|---|---|")
    groups = {
        "all 14": list(range(len(cells))),
        "PPO (7)": [j for j, c in enumerate(cells) if c[0] == "ppo"],
        "A2C (7)": [j for j, c in enumerate(cells) if c[0] == "a2c"],
    }
    results = {}
    for name, columns in groups.items():
        results[name] = aggregate(gp, mlp, columns)
        p, lo, hi = results[name]
        print(f"| {name} | {p:.3f} [{lo:.3f}, {hi:.3f}] |")
    probs = per_cell(gp, mlp)
    print("\n| algo | env | P(GP > MLP) | Mann-Whitney p (two-sided) |")
    print("|---|---|---:|---:|")
    for (algo, env), prob, j in zip(cells, probs, range(len(cells)), strict=True):
        same = np.array_equal(gp[:, j], mlp[:, j])
        p = "–" if same else f"{sps.mannwhitneyu(gp[:, j], mlp[:, j]).pvalue:.2g}"
        print(f"| {algo.upper()} | {env} | {prob:.3f} | {p} |")
    if plot:
        draw(cells, probs, results, label, plot)


def draw(
    cells: list[tuple[str, str]], probs: np.ndarray, results: dict[str, Any], label: str, path: str
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [f"{a.upper()} {e.split('/')[-1]}" for a, e in cells]
    fig, (top, bottom) = plt.subplots(
        2, 1, figsize=(7, 7.5), height_ratios=[len(results), len(cells)], layout="constrained"
    )
    for i, (p, lo, hi) in enumerate(results.values()):
        top.errorbar(p, i, xerr=[[p - lo], [hi - p]], fmt="o", color="k", capsize=4)
    top.set_yticks(range(len(results)), list(results))
    bottom.barh(
        range(len(cells)),
        probs - 0.5,
        left=0.5,
        color=["tab:blue" if p > 0.5 else "tab:red" for p in probs],
    )
    bottom.set_yticks(range(len(cells)), names, fontsize=8)
    for ax in (top, bottom):
        ax.axvline(0.5, color="grey", lw=1, ls="--")
        ax.set_xlim(0, 1)
        ax.invert_yaxis()
        ax.grid(axis="x", alpha=0.3)
    top.set_title(f"P(GP critic > MLP critic), {label}: mean over cells, 95 % CI", fontsize=10)
    bottom.set_title("per cell (50 + 50 runs each)", fontsize=10)
    bottom.set_xlabel("probability of improvement (0.5: no difference)")
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metric", choices=("final_return", "mean_return"), default="final_return")
    parser.add_argument("--plot", metavar="PNG")
    args = parser.parse_args()
    report(args.metric, args.plot)


if __name__ == "__main__":
    main()
