"""The readings of ``PLAN.md`` (the Matérn kernel as PPO's GP critic, session 65)::

    python docs/critic_fit_matern/read.py --plot docs/critic_fit_matern/read.png \\
        > docs/critic_fit_matern/read.md

Per environment and arm (the default's Laplacian kernel, Matérn 5/2 and 3/2 with the engine's
novelty rule, and both at the Laplacian default's basis spacing, "dense"): the goal's
reading and the pooled one, mean over seeds 0-9 [lowest, highest], the runs at 0.9 or more and
the median; each Matérn arm minus the default paired by seed (mean [95 % t], median). On
Acrobot-v1 (the addendum): on G and the value RMSE to ``V^pi`` against the default's runs of
``docs/critic_fit_lag``. Model level: the exact GPs of ``exact.py`` against the Laplacian row
and the on-line critic of ``results/model_ceiling``.
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
DOCS = HERE.parent
MODEL_CEILING = DOCS.parent / "results" / "model_ceiling"
ENVS = ("Pendulum-v1", "CartPole-v1", "Acrobot-v1")
SEEDS = range(10)
#: arm -> (folder, critic name in it)
ARMS = {
    "Laplacian (default)": (HERE / "runs52", "laplacian"),
    "Matérn 5/2": (HERE / "runs52", "matern"),
    "Matérn 3/2": (HERE / "runs32", "matern"),
    # addendum 2: at the Laplacian default's basis spacing
    "Matérn 5/2, dense": (HERE / "runs52_dense", "matern"),
    "Matérn 3/2, dense": (HERE / "runs32_dense", "matern"),
}
DEFAULT = "Laplacian (default)"
#: Acrobot's readings against V^pi: arm -> (folder, critic)
CEILING_ARMS = {
    DEFAULT: (DOCS / "critic_fit_lag", "laplacian"),
    "Matérn 5/2": (HERE / "ceiling52", "matern"),
}
Reading = Callable[[dict[str, Any]], float]
READINGS: dict[str, Reading] = {
    "goal's reading": lambda r: r["tail_mean"],
    "pooled": lambda r: r["tail_pooled"],
}
CEILING_READINGS: dict[str, Reading] = {
    "goal's reading": lambda r: r["tail_mean"],
    "on G, pooled": lambda r: r["ceiling"]["mc_critic_pooled"],
    "value RMSE to V^pi": lambda r: float(
        np.mean([c["value_rmse"] for c in r["ceiling"]["rollouts"]])
    ),
}
EXACT_LAPLACE = "exact GP, newest batch, Laplacian, its own hyperparameters"


def runs(folder: Path, critic: str, env: str, get: Reading) -> np.ndarray:
    return np.array(
        [
            get(json.loads((folder / "runs" / f"{critic}__{env}__s{s}.json").read_text()))
            for s in SEEDS
        ]
    )


def paired(a: np.ndarray, b: np.ndarray) -> str:
    d = a - b
    mean, half = (float(v) for v in mean_ci(d, nan_policy="propagate"))
    return f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}], median {np.median(d):+.3f}"


def describe(v: np.ndarray, goal: bool) -> str:
    reach = f", {int((v >= 0.9).sum())}/10" if goal else ""
    return f"{v.mean():.3f} [{v.min():.2f}, {v.max():.2f}]{reach}, median {np.median(v):.3f}"


def table(
    arms: dict[str, tuple[Path, str]], envs: tuple[str, ...], readings: dict[str, Reading]
) -> list[str]:
    lines = ["| env | reading | arm | mean [lowest, highest] | − default, paired by seed |"]
    lines.append("|---|---|---|---|---|")
    for env in envs:
        for reading, get in readings.items():
            base = runs(*arms[DEFAULT], env, get)
            for arm, where in arms.items():
                v = base if arm == DEFAULT else runs(*where, env, get)
                goal = reading in ("goal's reading", "pooled")
                diff = "" if arm == DEFAULT else paired(v, base)
                lines.append(f"| {env} | {reading} | {arm} | {describe(v, goal)} | {diff} |")
    return lines


def exact_table() -> list[str]:
    found = json.loads((HERE / "exact.json").read_text())["results"]
    published: dict[int, Any] = {}
    for half in ("laplacian_a", "laplacian_b"):
        data = json.loads((MODEL_CEILING / half / "results.json").read_text())
        published |= {int(s): r for s, r in data["results"]["Acrobot-v1"].items()}
    laplace = np.array([published[s][EXACT_LAPLACE]["tail"] for s in SEEDS])
    online = np.array([published[s]["default"]["tail"] for s in SEEDS])
    lines = [
        "| exact GP, newest batch, maximum likelihood | explained variance of the next batch's "
        "targets | − Laplacian exact | − on-line critic |",
        "|---|---|---|---|",
        f"| Laplacian (`results/model_ceiling`) | {describe(laplace, False)} | | "
        f"{paired(laplace, online)} |",
    ]
    for kernel, name in (("matern52", "Matérn 5/2"), ("matern32", "Matérn 3/2")):
        v = np.array([found[f"{kernel}/{s}"]["tail"] for s in SEEDS])
        lines.append(
            f"| {name} | {describe(v, False)} | {paired(v, laplace)} | {paired(v, online)} |"
        )
    lines.append(f"| on-line critic (the default, replayed) | {describe(online, False)} | | |")
    return lines


def plot(path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(17, 4.2))
    for ax, env in zip(axes[:3], ENVS, strict=True):
        for i, (arm, where) in enumerate(ARMS.items()):
            v = runs(*where, env, READINGS["goal's reading"])
            jitter = np.linspace(-0.15, 0.15, len(v))
            ax.scatter(i + jitter, v, s=16, label=arm)
            ax.hlines(np.median(v), i - 0.25, i + 0.25, color="k")
        ax.axhline(0.9, color="tab:red", ls="--", lw=1)
        ax.set_xticks(range(len(ARMS)), list(ARMS), rotation=15, fontsize=8)
        ax.set_ylim(top=1.05)
        ax.set_title(f"{env}: goal's reading per run", fontsize=9)
    ax = axes[3]
    for arm, where in CEILING_ARMS.items():
        goal = runs(*where, "Acrobot-v1", CEILING_READINGS["goal's reading"])
        on_g = runs(*where, "Acrobot-v1", CEILING_READINGS["on G, pooled"])
        ax.scatter(goal, on_g, s=18, label=arm)
    ax.set_xlabel("goal's reading", fontsize=8)
    ax.set_ylabel("on G (returns bootstrapped with V^pi)", fontsize=8)
    ax.set_title("Acrobot-v1: the two readings per run", fontsize=9)
    ax.legend(fontsize=7)
    fig.suptitle("PPO 30,000 steps, seeds 0-9; dashed: issue 13's goal 0.9; bars: medians")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path)
    args = parser.parse_args()
    lines = ["# The Matérn kernel as PPO's GP critic: critic fit (session 65)", ""]
    lines += ["PPO, 30,000 steps, seeds 0-9; the drop-in default with only the kernel changed.", ""]
    lines += table(ARMS, ENVS, READINGS)
    lines += ["", "## Acrobot-v1 against the policy's own values (the addendum)", ""]
    lines += table(CEILING_ARMS, ("Acrobot-v1",), CEILING_READINGS)
    lines += ["", "## Model level: exact GPs on the default's Acrobot-v1 batches", ""]
    lines += exact_table()
    print("\n".join(lines))
    if args.plot:
        plot(args.plot)


if __name__ == "__main__":
    main()
