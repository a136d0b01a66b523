"""What the hyperprior does inside training: the fitted lengthscales of the default GP critic
(A′, its runs on this machine) and of the critic with ``prior_sd=0.1`` (B) along PPO
CartPole-v1 runs whose default run fell (exploratory, session 38; read after ``read.md``).

Each run is re-run exactly (``../fall.py``'s ``rerun``, which checks the evaluations against the
published run) with a per-rollout record of what the GP critic logged. Writes
``lengthscales/<arm>_s<seed>.json`` and ``lengthscales/lengthscales.png``.

    python results/budget100k/prior/lengthscales.py --seeds 187 189 197

``--algo a2c`` (exploratory, session 39) asks the same of A2C's default GP critic (RBF kernel),
whose CartPole-v1 runs also fall late at 100,000 steps (``results/budget100k_a2c``): fresh
runs (nothing published to compare with), the default against the same with
``prior_sd=0.1``, into ``results/budget100k_a2c/lengthscales/``.

    python results/budget100k/prior/lengthscales.py --algo a2c --seeds 143 144 145 146 147 148
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import pyplot

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent))
from fall import rerun  # noqa: E402

#: The options of arm B, as its pre-registered command gave them.
PRIOR = {"max_gap": 16, "settle": False, "score_points": 256, "fold_points": 256,
         "fit_floor": 0.8, "summary": "snapshot", "prior_sd": 0.1}  # fmt: skip
#: A2C's default adaptation (``policies.DEFAULT_ADAPTATIONS``) with the prior.
A2C_PRIOR = {"max_gap": 16, "settle": False, "prior_sd": 0.1}
#: Per algorithm, each arm: where its published runs are (``None``: fresh runs), its GP options.
ARMS: dict[str, dict[str, tuple[Path | None, tuple[tuple[str, Any], ...]]]] = {
    "ppo": {
        "default": (HERE / "default_today_s180", ()),
        "prior_sd=0.1": (HERE / "gp_prior", (("adapt", PRIOR),)),
    },
    "a2c": {"default": (None, ()), "prior_sd=0.1": (None, (("adapt", A2C_PRIOR),))},
}
#: Per algorithm: its default GP critic and where the records go.
CRITIC = {"ppo": "laplacian", "a2c": "rbf"}
OUT = {"ppo": HERE / "lengthscales", "a2c": HERE.parents[1] / "budget100k_a2c" / "lengthscales"}
#: CartPole's observation: cart position, cart velocity, pole angle, pole angular velocity.
DIMENSIONS = ("cart position", "cart velocity", "pole angle", "pole angular velocity")


def segment_ends(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows with fitted lengthscales that start or end a stretch of equal lengthscales: the
    curves drawn from them are those of every row (A2C's 100,000 steps are 2,500 rollouts and
    about six refits)."""
    fitted = [r for r in rows if "gp/lengthscale_0" in r]

    def key(r: dict[str, Any]) -> list[float]:
        return [r[f"gp/lengthscale_{i}"] for i in range(len(DIMENSIONS))]

    keys = [key(r) for r in fitted]

    def bounds_a_stretch(i: int) -> bool:
        return i in (0, len(fitted) - 1) or keys[i] != keys[i - 1] or keys[i] != keys[i + 1]

    return [r for i, r in enumerate(fitted) if bounds_a_stretch(i)]


def record(algo: str, arm: str, seed: int) -> dict[str, Any]:
    path = OUT[algo] / f"{arm.replace('=', '')}_s{seed}.json"
    if not path.exists():
        published_in, options = ARMS[algo][arm]
        run = rerun(CRITIC[algo], seed, published_in, options, algo)
        path.write_text(json.dumps({**run, "rollouts": segment_ends(run["rollouts"])}))
    return json.loads(path.read_text())


def plot(
    runs: dict[tuple[str, int], dict[str, Any]], seeds: Sequence[int], path: Path, algo: str
) -> None:
    """Per seed: the evaluation curves of both arms, then each arm's lengthscales (log)."""
    plt = pyplot()
    fig, axes = plt.subplots(3, len(seeds), figsize=(4.6 * len(seeds), 8.4), squeeze=False)
    colors = {"default": "tab:green", "prior_sd=0.1": "tab:purple"}
    for col, seed in enumerate(seeds):
        for row, arm in enumerate(ARMS[algo], start=1):
            run = runs[arm, seed]
            axes[0][col].plot(run["eval"]["timesteps"], run["eval"]["mean_return"],
                              color=colors[arm], marker="o", ms=3, label=arm)  # fmt: skip
            fitted = [r for r in run["rollouts"] if "gp/lengthscale_0" in r]
            t = [r["timesteps"] for r in fitted]
            for i, name in enumerate(DIMENSIONS):
                axes[row][col].plot(t, [r[f"gp/lengthscale_{i}"] for r in fitted], label=name)
            axes[row][col].set(yscale="log", ylabel=f"{arm}: fitted lengthscale")
            axes[row][col].sharey(axes[1][0])
        axes[0][col].set(
            title=f"{algo.upper()} CartPole-v1, seed {seed}", ylabel="evaluation return"
        )
        axes[-1][col].set(xlabel="timesteps")
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8, loc="lower right")
    axes[1][0].legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[187, 189, 197])
    parser.add_argument("--algo", choices=sorted(ARMS), default="ppo")
    args = parser.parse_args(argv)
    OUT[args.algo].mkdir(exist_ok=True)
    runs = {(arm, seed): record(args.algo, arm, seed) for seed in args.seeds
            for arm in ARMS[args.algo]}  # fmt: skip
    for (arm, seed), run in runs.items():
        last = next(r for r in reversed(run["rollouts"]) if "gp/lengthscale_0" in r)
        first = next(r for r in run["rollouts"] if "gp/lengthscale_0" in r)
        first_ls, last_ls = ([round(r[f"gp/lengthscale_{i}"], 2) for i in range(len(DIMENSIONS))]
                             for r in (first, last))  # fmt: skip
        print(f"{arm}, seed {seed}: final return {run['eval']['mean_return'][-1]:g}; fitted "
              f"lengthscales first {first_ls}, last {last_ls}")  # fmt: skip
    plot(runs, args.seeds, OUT[args.algo] / "lengthscales.png", args.algo)


if __name__ == "__main__":
    main()
