"""The reading of ``PLAN.md``: an exact GP on PPO's actor features against the same GP on
the raw observations, on the drop-in PPO default's Acrobot batches (``run.py``'s docstring
has the commands)::

    python results/actor_features/read.py --plot results/actor_features/read.png \\
        --streams STREAMS > results/actor_features/read.md

With ``--streams`` (``run.py``'s recordings) it also reports how far the actor moved. The
tables and the plot serve ``results/return_noise/read.py`` too.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ENV = "Acrobot-v1"
ROWS = {
    "default": "on-line GP critic, replayed",
    "raw": "exact Laplacian GP, newest batch, raw observations",
    "actor": "exact Laplacian GP, newest batch, the actor's features",
}
READINGS = (("actor", "raw"), ("actor", "default"), ("raw", "default"))
#: ``PLAN.md``'s rule: what an interval of ``actor - raw`` above, inside or below ±0.05 says.
RULE = (
    "the actor's features let the GP predict the next batch better",
    "the actor's features do not let the GP predict the next batch better",
    "the actor's features make the GP predict the next batch worse",
)
BySeed = dict[str, dict[str, Any]]
#: Session 64's reading: its paired difference of the tail scores serves here too.
paired = load_script(HERE.parent / "model_ceiling" / "read.py", "model_ceiling_read").paired


def load(folders: list[Path]) -> BySeed:
    """Per seed, every row's result, merged over the ``results.json`` of ``folders``."""
    out: BySeed = {}
    for folder in folders:
        data = json.loads((folder / "results.json").read_text())
        for seed, rows in data["results"][ENV].items():
            out.setdefault(seed, {}).update(rows)
    return dict(sorted(out.items(), key=lambda kv: int(kv[0])))


def verdict(interval: tuple[float, float, float], rule: tuple[str, str, str]) -> str:
    """A plan's rule: ``rule``'s first, second or third phrase for an interval wholly above
    +0.05, inside ±0.05 or wholly below -0.05; otherwise inconclusive."""
    _, low, high = interval
    if low > 0.05:
        return rule[0]
    if low >= -0.05 and high <= 0.05:
        return rule[1]
    if high < -0.05:
        return rule[2]
    return "inconclusive"


def report(
    by_seed: BySeed,
    rows: dict[str, str],
    readings: tuple[tuple[str, str], ...],
    rule: tuple[str, str, str],
    title: str,
) -> str:
    """The rows' scores and fitted noise, the readings paired by seed, the first reading's
    verdict by ``rule``, and every seed's scores, as markdown."""
    lines = [
        f"# {title}",
        "",
        f"{ENV}, seeds {list(map(int, by_seed))}. Explained variance of the fed targets by each",
        "predictor before it learns the batch, mean over the last 20 % of scored batches, then",
        "over seeds (lowest, highest); all batches: mean over every scored batch, then seeds.",
        "",
        "| row | predictor | score | lowest | highest | all batches | median noise variance |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for name, what in rows.items():
        tails = [r[name]["tail"] for r in by_seed.values()]
        every = np.mean([np.mean(r[name]["explained_variance"]) for r in by_seed.values()])
        noise = [v for r in by_seed.values() for v in r[name].get("noise_var", [])]
        shown = f"{np.median(noise):.3g}" if noise else "–"
        lines.append(
            f"| {name} | {what} | {np.mean(tails):.3f} | {min(tails):.3f} | {max(tails):.3f} "
            f"| {every:.3f} | {shown} |"
        )
    lines += ["", "| reading | paired by seed [95 % t] |", "|---|---|"]
    for first, second in readings:
        mean, low, high = paired(by_seed, first, second)
        lines.append(f"| {first} − {second} | {mean:+.3f} [{low:+.3f}, {high:+.3f}] |")
    lines += [
        "",
        "| seed | batches | " + " | ".join(rows) + " |",
        "|---|---:|" + "---:|" * len(rows),
    ]
    for seed, result in by_seed.items():
        cells = " | ".join(f"{result[name]['tail']:.3f}" for name in rows)
        lines.append(f"| {seed} | {result[next(iter(rows))]['n_batches']} | {cells} |")
    first, second = readings[0]
    found = verdict(paired(by_seed, first, second), rule)
    lines += ["", f"`PLAN.md`'s rule on {first} − {second}: {found}.", ""]
    return "\n".join(lines) + "\n"


def actor_drift(streams: Path, seeds: list[int]) -> str:
    """Per layer, the relative change of the actor's weights from the first feed to the last,
    ``|W_last - W_first| / |W_first|`` (Frobenius), over seeds: how far its features moved."""
    import torch as th

    changes = []
    for seed in seeds:
        path = next(streams.glob(f"{ENV}__s{seed}__t*__actors.pt"))
        actors = th.load(path, weights_only=False)
        first, last = (
            [p.detach() for n, p in a.named_parameters() if n.endswith("weight")]
            for a in (actors[0], actors[-1])
        )
        changes.append([float((b - a).norm() / a.norm()) for a, b in zip(first, last, strict=True)])
    change = np.array(changes)
    cells = ", ".join(
        f"layer {k + 1} {col.mean():.3f} [{col.min():.3f}, {col.max():.3f}]"
        for k, col in enumerate(change.T)
    )
    return (
        "How far the actor moved between the first feed and the last (relative change of its "
        f"weights, mean [lowest, highest] over seeds): {cells}.\n"
    )


def plot(by_seed: BySeed, rows: dict[str, str], title: str, path: Path) -> None:
    """Score per batch, every seed (thin) and the mean (thick), clipped at -1."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.0, 5.5))
    for k, (name, what) in enumerate(rows.items()):
        scores = [r[name]["explained_variance"] for r in by_seed.values()]
        # Monte Carlo feeds end episodes, not rollouts: runs differ in their batch counts
        curves = np.full((len(scores), max(map(len, scores))), np.nan)
        for row, score in zip(curves, scores, strict=True):
            row[: len(score)] = score
        batches = np.arange(1, curves.shape[1] + 1)
        for row in curves:
            ax.plot(batches, np.clip(row, -1, 1), color=f"C{k}", alpha=0.2, lw=0.8)
        mean = np.clip(np.nanmean(curves, axis=0), -1, 1)
        ax.plot(batches, mean, "o-", color=f"C{k}", label=what, lw=2, ms=4)
    ax.set(
        xlabel="batch predicted (in feeding order)",
        ylabel="explained variance of the fed targets",
        title=f"{ENV}, PPO 30,000 steps: {title}",
        ylim=(-1.05, 1.0),
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    parser.add_argument("--streams", type=Path, default=None, help="run.py's recordings")
    args = parser.parse_args()
    by_seed = load([HERE / "a", HERE / "b"])
    title = "An exact GP on PPO's actor features against the raw observations"
    print(report(by_seed, ROWS, READINGS, RULE, title))
    same = {}
    for folder in ("a", "b"):
        same.update(json.loads((HERE / folder / "results.json").read_text())["same_as_check"])
    equal = sum(v is True for v in same.values())
    print(f"Batches equal to session 64's streams bit for bit: {equal} of {len(same)} seeds.\n")
    if args.streams is not None:
        print(actor_drift(args.streams, list(map(int, by_seed))))
    if args.plot is not None:
        plot(by_seed, ROWS, "exact GPs on the batch before, by their inputs", args.plot)


if __name__ == "__main__":
    main()
