"""Read ``run.py``'s runs: per arm, what the advantages told the actor about its noise, how
far the noise fell, and whether the agents held the pole (session 81, exploratory)::

    python results/heldout_noise/read.py > results/heldout_noise/read.md
    python results/heldout_noise/read.py --figure results/heldout_noise/noise.png

Per run: ``corr(A, z**2)`` averaged over its rollouts, and over the rollouts while it held
the pole (those whose last 5 training episodes average at least 950); the actor's standard deviation
``exp(log_std)`` at the end; the mean return of the training episodes over the last tenth of
the rollouts (the stochastic policy's, 5 episodes per reading), and whether that is at least
950 (the held-out study's threshold). Means over the seeds with 95 % percentile-bootstrap
intervals (resampling seeds).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from run import ARMS, STEPS, THRESHOLD

from sb3_geogp.comparison.report import pyplot
from sb3_geogp.toolbox.stats import bootstrap_ci, difference_ci

HERE = Path(__file__).resolve().parent
LAST = 0.1  # the last tenth of the rollouts


def seeds(folder: Path, arm: str) -> list[int]:
    """The seeds of the arm's runs in ``folder``, in order."""
    return sorted(int(p.stem.rpartition("__s")[2]) for p in folder.glob(f"{arm}__s*.npz"))


def load(folder: Path, arm: str) -> list[dict[str, np.ndarray]]:
    """The arm's runs in ``folder``, in seed order."""
    return [dict(np.load(folder / f"{arm}__s{seed}.npz")) for seed in seeds(folder, arm)]


def seed_range(folder: Path, arms: Iterable[str]) -> str:
    """``"first-last"`` of the seeds of those arms' runs in ``folder``."""
    found = sorted({seed for arm in arms for seed in seeds(folder, arm)})
    return f"{found[0]}-{found[-1]}"


def per_run(run: dict[str, np.ndarray]) -> dict[str, float]:
    """The run's readings."""
    tail = int(np.ceil(LAST * len(run["steps"])))
    late = float(np.nanmean(run["episode_return"][-tail:]))
    holding = run["episode_return"] >= THRESHOLD
    return dict(
        corr_z2=float(np.nanmean(run["corr_z2"])),
        corr_z2_holding=float(np.nanmean(run["corr_z2"][holding])) if holding.any() else np.nan,
        std=float(np.exp(run["log_std"][-1])),
        late_return=late,
        held=float(late >= THRESHOLD),
    )


def interval(values: list[float], digits: int) -> str:
    """``mean [low, high]`` over the runs."""
    est, low, high = bootstrap_ci(np.asarray(values))
    return f"{est:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"


def readings(folder: Path) -> dict[str, list[dict[str, float]]]:
    """:func:`per_run` of each arm's runs in ``folder``, the arms that have runs only."""
    by_arm = {arm: [per_run(r) for r in load(folder, arm)] for arm in ARMS}
    return {arm: rows for arm, rows in by_arm.items() if rows}


def table(by_arm: dict[str, list[dict[str, float]]]) -> str:
    lines = [
        "| arm | runs | corr(A, z²), run mean | the same while holding: runs, mean | "
        "actor std at the end | return, last tenth | held (>= 950) |",
        "|---|---:|---|---|---|---|---:|",
    ]
    for arm, rows in by_arm.items():
        holding = [r["corr_z2_holding"] for r in rows if np.isfinite(r["corr_z2_holding"])]
        cells = [
            interval([r["corr_z2"] for r in rows], 3),
            f"{len(holding)}: " + (interval(holding, 3) if holding else "none"),
            interval([r["std"] for r in rows], 2),
            interval([r["late_return"] for r in rows], 0),
            f"{int(sum(r['held'] for r in rows))}/{len(rows)}",
        ]
        lines.append(f"| `{arm}` | {len(rows)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


#: The arms the difference tables subtract: the study's GP critic and its MLP critic.
REFERENCES = ("gp_actor_normalized", "mlp_vecnormalize")


def differences(by_arm: dict[str, list[dict[str, float]]], reference: str) -> str:
    """Each arm's late return minus the reference arm's, with a 95 % bootstrap interval
    resampling each arm's seeds separately."""
    late = {arm: np.array([r["late_return"] for r in rows]) for arm, rows in by_arm.items()}
    lines = [
        f"| arm | return, last tenth: arm − `{reference}` [95 %] |",
        "|---|---|",
    ]
    for arm, values in late.items():
        if arm == reference or reference not in late:
            continue
        est, low, high = difference_ci(values, late[reference])
        lines.append(f"| `{arm}` | {est:+.0f} [{low:+.0f}, {high:+.0f}] |")
    return "\n".join(lines)


def provenance_lines(folder: Path) -> str:
    """Which commits made the runs."""
    commits: dict[str, int] = {}
    for path in sorted(folder.glob("*.json")):
        made = json.loads(path.read_text())["provenance"]
        key = f"{made['git_commit'][:8]} (uncommitted changes: {made['git_dirty']})"
        commits[key] = commits.get(key, 0) + 1
    return "\n".join(f"- {n} runs at commit {c}" for c, n in commits.items())


def smoothed(values: np.ndarray, window: int = 50) -> np.ndarray:
    """Trailing mean over ``window`` rollouts along the last axis (shorter at the start)."""
    cumulative = np.cumsum(np.nan_to_num(values), axis=-1)
    shifted = np.concatenate([np.zeros_like(cumulative[..., :window]), cumulative], axis=-1)
    counts = np.minimum(np.arange(1, values.shape[-1] + 1), window)
    return (cumulative - shifted[..., : values.shape[-1]]) / counts


#: The figure's arms and their line styles (the rest are in the table only).
FIGURE_ARMS = {
    "mlp_vecnormalize": "-",
    "mlp_rewards_only": "-",
    "mlp_observations_only": "-",
    "mlp_raw": "-",
    "gp_actor_normalized": "--",
    "gp_no_trend": "--",
    "gp_actor_normalized_low_noise": ":",
    "mlp_vecnormalize_low_noise": ":",
}


def figure(folder: Path, path: Path) -> None:
    """The actor's noise, corr(A, z²) and the training return along training, means over
    seeds."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.5), constrained_layout=True)
    panels = (
        ("log_std", np.exp, "actor's standard deviation", "The actor's noise"),
        ("corr_z2", smoothed, "corr(A, z²), mean of 50 rollouts", "What the advantages say"),
        ("episode_return", None, "training return (last 5 episodes)", "The pole held"),
    )
    for arm, style in FIGURE_ARMS.items():
        runs = load(folder, arm)
        if not runs:
            continue
        steps = runs[0]["steps"]
        for ax, (key, f, _, _) in zip(axes, panels, strict=True):
            values = np.array([r[key] for r in runs])
            values = f(values) if f is not None else values
            ax.plot(steps, np.nanmean(values, axis=0), style, label=f"{arm} ({len(runs)})")
    for ax, (_, _, ylabel, title) in zip(axes, panels, strict=True):
        ax.set(xlabel="steps", ylabel=ylabel, title=title)
    axes[1].axhline(0, color="grey", lw=0.8)
    axes[2].axhline(THRESHOLD, color="grey", lw=0.8)
    axes[0].legend(fontsize=8)
    seeds_drawn = seed_range(folder, FIGURE_ARMS)
    fig.suptitle(f"PPO InvertedPendulum-v5, the zoo's entry, seeds {seeds_drawn}")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=HERE / "runs")
    parser.add_argument("--figure", type=Path)
    args = parser.parse_args()
    if args.figure is not None:
        figure(args.runs, args.figure)
        return
    print("# What PPO's advantages tell the actor about its noise: InvertedPendulum-v5\n")
    print(f"{STEPS:,} steps, seeds {seed_range(args.runs, ARMS)}, the arms of `run.py`.\n")
    by_arm = readings(args.runs)
    print(table(by_arm))
    for reference in REFERENCES:
        print()
        print(differences(by_arm, reference))
    print("\n## What the runs executed\n")
    print(provenance_lines(args.runs))


if __name__ == "__main__":
    main()
