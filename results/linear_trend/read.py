"""The reading of ``PLAN.md`` (session 86): ``trend="linear"`` against PPO's default GP critic
on HalfCheetah-v5 (seeds 1148-1162) and Hopper-v5 (1143-1152), paired by seed with the stored
default runs of ``results/lengthscale_rule``; then the exploratory screen::

    python results/linear_trend/read.py > results/linear_trend/read.md
    python results/linear_trend/read.py --curves results/linear_trend/curves.png

``--dir`` reads another folder of the same layout (a frozen worktree's runs).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sb3_geogp.comparison.report import pyplot
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import difference_ci

HERE = Path(__file__).resolve().parent
STORED = HERE.parent / "lengthscale_rule"
SHARED = load_script(STORED / "read.py", "lengthscale_rule_read")
runs_of, paired, interval, final_returns = (
    SHARED.runs_of, SHARED.paired, SHARED.interval, SHARED.final_returns
)  # fmt: skip
HALFCHEETAH_SEEDS, HOPPER_SEEDS = tuple(range(1148, 1163)), tuple(range(1143, 1153))
#: Each cell: its seeds, its role, and its verdict from the paired interval ``(low, high)``
CELLS = {
    "HalfCheetah-v5": (
        HALFCHEETAH_SEEDS,
        "primary",
        lambda low, high: "confirmed" if low > 0 else "not confirmed",
    ),
    "Hopper-v5": (HOPPER_SEEDS, "guard", lambda low, high: "worse" if high < 0 else "not worse"),
}
SCREEN_SEEDS = tuple(range(1143, 1148))


def stored(env: str, critic: str, seeds: tuple[int, ...]) -> SHARED.Runs:
    """The stored runs of ``critic`` (the default GP critic or SB3's MLP critic) on ``env``."""
    return {**runs_of(STORED / "spread", env, critic, seeds),
            **runs_of(STORED / "spread_more", env, critic, seeds)}  # fmt: skip


def reproduction(root: Path) -> bool:
    """Whether the re-run default run reproduces the stored one (PLAN.md); printed."""
    again = runs_of(root / "reproduce", "HalfCheetah-v5", "laplacian", (1148,))
    if not again:
        print("Reproduction check: not run; nothing is read.\n")
        return False
    new, old = again[1148], stored("HalfCheetah-v5", "laplacian", (1148,))[1148]
    same = new["final_return"] == old["final_return"] and new["eval"] == old["eval"]
    print(f"Reproduction check (HalfCheetah-v5, seed 1148, default GP critic): final return "
          f"{new['final_return']:.4f} re-run, {old['final_return']:.4f} stored: "
          f"{'reproduced bit for bit' if same else 'NOT reproduced'}.\n")  # fmt: skip
    return same


def registered(root: Path) -> None:
    print("## `trend=linear` − the default GP critic, paired by seed\n")
    print("| env | metric | seeds | default | linear | linear − default [95 %] | reading |")
    print("|---|---|---|---|---|---|---|")
    for env, (seeds, role, verdict) in CELLS.items():
        new = runs_of(root / "linear", env, "laplacian", seeds)
        old = stored(env, "laplacian", seeds)
        if not new:
            print(f"| {env} | | 0 | | | not run | |")
            continue
        partial = "" if len(new) == len(seeds) else f", partial: {len(new)} of {len(seeds)}"
        for metric, label in SHARED.LABELS.items():
            cells, low, high = paired(new, old, metric)
            reading = ""
            if metric == "final_return":
                reading = f"{verdict(low, high)} ({role}{partial})"
            print(f"| {env} | {label} | {' | '.join(cells)} | {reading} |")
    print()
    print("## Each GP critic − SB3's MLP critic (`VecNormalize`), final return, table's rule\n")
    print("| env | seeds | MLP | default − MLP [95 %] | linear − MLP [95 %] |")
    print("|---|---|---|---|---|")
    for env, (seeds, _, _) in CELLS.items():
        mlp = stored(env, "mlp", seeds)
        new = runs_of(root / "linear", env, "laplacian", tuple(mlp))
        if not mlp or not new:
            continue
        m = final_returns(mlp)
        old = interval(*difference_ci(final_returns(stored(env, "laplacian", tuple(mlp))), m))
        lin = interval(*difference_ci(final_returns(new), m))
        print(f"| {env} | {min(mlp)}-{max(mlp)} ({len(mlp)}) | {m.mean():.1f} | {old} | {lin} |")
    print()


def screen(root: Path) -> None:
    print("## Exploratory screen (before the plan): HalfCheetah-v5, seeds 1143-1147\n")
    print("| arm | seeds | default | arm | arm − default [95 %] |")
    print("|---|---|---|---|---|")
    old = stored("HalfCheetah-v5", "laplacian", SCREEN_SEEDS)
    for arm, label in (("returns", "`--target returns`"), ("linear", "`trend=linear`")):
        new = runs_of(root / "screen" / arm, "HalfCheetah-v5", "laplacian", SCREEN_SEEDS)
        if new:
            cells, _, _ = paired(new, old, "final_return")
            print(f"| {label} | {' | '.join(cells)} |")
    print()


def curves(root: Path, out: Path) -> None:
    """Each arm's evaluation return against timesteps on each cell's registered seeds: the mean
    over seeds and its 95 % percentile bootstrap band (SB3's MLP critic where stored)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(CELLS), figsize=(9, 3.4), squeeze=False)
    for ax, (env, (seeds, _, _)) in zip(axes[0], CELLS.items(), strict=True):
        arms = (
            ("default GP critic", stored(env, "laplacian", seeds), "tab:blue"),
            ("trend=linear", runs_of(root / "linear", env, "laplacian", seeds), "tab:red"),
            ("SB3's MLP critic (VecNormalize)", stored(env, "mlp", seeds), "tab:gray"),
        )
        for legend, runs, colour in arms:
            SHARED.draw_arm(ax, runs, legend, colour)
        SHARED.style_panel(ax, f"PPO {env}, seeds {seeds[0]}-{seeds[-1]}")
        ax.legend(fontsize=7, loc="upper left")
    SHARED.save_figure(fig, axes, "Mean and 95 % bootstrap band over seeds", out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", type=Path, default=HERE)
    parser.add_argument("--curves", type=Path)
    args = parser.parse_args()
    if args.curves:
        curves(args.dir, args.curves)
        return
    print("# A linear trend under PPO's GP critic on HalfCheetah-v5 (PLAN.md)\n")
    if reproduction(args.dir):
        registered(args.dir)
    screen(args.dir)


if __name__ == "__main__":
    main()
