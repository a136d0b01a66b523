"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``)::

    python results/additive_kernel/read.py --plot results/additive_kernel/read.png \\
        > results/additive_kernel/read.md
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
ENV = "Acrobot-v1"
MODELS = ("full", "full+additive", "additive")
PRIMARY = ("full+additive", "full")
SECONDARY = ("additive", "full")
#: Each seed's results by seed, model and field.
Runs = dict[int, dict[str, dict[str, Any]]]


def load(folder: Path = HERE) -> Runs:
    """Every seed's results in ``folder`` (its parts ``a`` and ``b``), by seed and model."""
    runs: Runs = {}
    for part in ("a", "b"):
        path = folder / part / "results.json"
        if path.is_file():
            runs |= {int(s): r for s, r in json.loads(path.read_text())["results"][ENV].items()}
    return dict(sorted(runs.items()))


def interval(diff: np.ndarray) -> str:
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    return f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]"


def verdict(diff: np.ndarray) -> str:
    """``PLAN.md``'s rule on the primary difference."""
    mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
    if mean - half > 0 and mean >= 0.05:
        return "a gain"
    if mean - half > -0.05 and mean + half < 0.05:
        return "no gain"
    return "inconclusive"


def main() -> None:
    report(__doc__, HERE, MODELS, (PRIMARY, SECONDARY), share_note)


def share_note(runs: Runs) -> str:
    share = [v for s in runs for v in runs[s]["full+additive"]["additive_share"]]
    return (
        " The additive term's share of the fitted signal variance in `full+additive`, "
        f"quartiles over its fits: {quartiles(share)}."
    )


def report(
    doc: str,
    folder: Path,
    models: tuple[str, ...],
    pairs: tuple[tuple[str, str], ...],
    note: Callable[[Runs], str] = lambda runs: "",
    preface: Callable[[Runs], str] = lambda runs: "",
    title: str = "Acrobot-v1: exact GPs on the newest batch, by kernel",
    predicted_by: str = "an exact GP on the batch before it",
    rule: bool = True,
    steps: str = "30,000",
) -> None:
    """The command line of these exact-GP studies' readings (``--plot PNG``): the results in
    ``folder`` (:func:`load`) as :func:`tables`, then the verdict of ``pairs``' first
    difference by :func:`verdict` (unless not ``rule``: a descriptive study) and what ``note``
    says of them."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    runs = load(folder)
    tail = tables(runs, models, pairs, preface(runs), predicted_by, steps)
    primary = pairs[0]
    ruled = (
        f"Primary ({' − '.join(primary)}, last 20 %), by PLAN.md's rule: "
        f"**{verdict(tail[primary[0]] - tail[primary[1]])}** ({len(runs)} seeds)."
    )
    print(f"\n{ruled if rule else ''}{note(runs)}")
    if args.plot:
        plot(tail, list(runs), args.plot, models, title)


def tables(
    runs: Runs,
    models: tuple[str, ...],
    pairs: tuple[tuple[str, str], ...],
    preface: str = "",
    predicted_by: str = "an exact GP on the batch before it",
    steps: str = "30,000",
) -> dict[str, np.ndarray]:
    """Print each model's score and the paired differences of ``pairs`` (``preface`` after
    the heading, which says what each batch is ``predicted_by`` in runs of ``steps`` steps;
    "not fitted" where a predictor scored the tail alone); return each model's tail score by
    seed, in ``runs``' order."""
    seeds = list(runs)
    tail = {m: np.array([runs[s][m]["tail"] for s in seeds]) for m in models}
    every = {
        m: np.array(
            [np.mean(np.array(runs[s][m]["explained_variance"], dtype=float)) for s in seeds]
        )
        for m in models
    }
    print(f"Acrobot-v1, PPO {steps} steps, seeds {', '.join(map(str, seeds))}: each batch "
          f"predicted by {predicted_by} (PLAN.md)\n")  # fmt: skip
    if preface:
        print(f"{preface}\n")
    print("| model | last 20 % of scored batches [lowest, highest] | all scored batches |")
    print("|---|---:|---:|")
    for m in models:
        whole = f"{every[m].mean():.3f}" if np.isfinite(every[m]).all() else "not fitted"
        print(f"| {m} | {tail[m].mean():.3f} [{tail[m].min():.2f}, {tail[m].max():.2f}] | "
              f"{whole} |")  # fmt: skip
    print("\n| difference, paired by seed [95 % t] | last 20 % | all scored batches | up / down |")
    print("|---|---:|---:|---:|")
    for a, b in pairs:
        diff, whole = tail[a] - tail[b], every[a] - every[b]
        wholes = interval(whole) if np.isfinite(whole).all() else "not fitted"
        print(f"| {a} − {b} | {interval(diff)} | {wholes} | "
              f"{int((diff > 0).sum())} / {int((diff < 0).sum())} |")  # fmt: skip
    return tail


def quartiles(values: list[float]) -> str:
    return " / ".join(f"{q:.2f}" for q in np.quantile(values, [0.25, 0.5, 0.75]))


def plot(
    tail: dict[str, np.ndarray],
    seeds: list[int],
    path: Path,
    models: tuple[str, ...] = MODELS,
    title: str = "Acrobot-v1: exact GPs on the newest batch, by kernel",
) -> None:
    """Each seed's tail score under ``models``, joined by seed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    x = np.arange(len(models))
    for i, seed in enumerate(seeds):
        ax.plot(x, [tail[m][i] for m in models], "-o", color="0.6", lw=0.8, ms=3)
        ax.annotate(str(seed), (x[-1] + 0.05, tail[models[-1]][i]), fontsize=7, color="0.4")
    ax.plot(x, [tail[m].mean() for m in models], "-s", color="C3", lw=2, label="mean over seeds")
    ax.set_xticks(x, models)
    ax.set_ylabel("explained variance of the next batch (last 20 %)")
    ax.set_title(title)
    ax.legend(loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
