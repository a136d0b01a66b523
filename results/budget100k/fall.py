"""The CartPole-v1 runs of results/budget100k whose GP-critic agents fell late, re-run exactly
with a per-rollout record (exploratory, session 37).

For each seed, both critics' runs are re-run through the comparison's own ``run_one`` (the
evaluations and Monte Carlo probes included, so the random streams are those of the published
run; the script checks that the evaluation curve is the published one) with a recorder that
keeps, per rollout: the training episodes' mean length (SB3's Monitor buffer, stochastic
policy), the spread of the rollout's returns, the critic's out-of-sample explained variance on
the rollout (its values were predicted before it learnt the rollout) and what the GP critic
logged. Writes ``fall/<critic>_s<seed>.json`` and ``fall/fall.png``.

    python results/budget100k/fall.py --seeds 172 173 179
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sb3_geogp.comparison.measurement import RolloutRecorder, rollout_explained_variance
from sb3_geogp.comparison.report import pyplot
from sb3_geogp.comparison.run import run_one
from sb3_geogp.comparison.specs import SweepConfig

HERE = Path(__file__).parent
CRITICS = ("mlp", "laplacian")


class RolloutRecord(RolloutRecorder):
    """Episode lengths, the returns' spread, the critic's fit and what the GP critic logged."""

    def row(self) -> dict[str, Any]:
        buffer = self.model.rollout_buffer
        explained = rollout_explained_variance(buffer)
        episodes = self.model.ep_info_buffer
        row = dict(
            timesteps=int(self.num_timesteps),
            episode_length=float(np.mean([e["l"] for e in episodes])) if episodes else None,
            return_std=float(np.sqrt(np.var(buffer.returns.ravel()))),
            explained_variance=None if np.isnan(explained) else explained,
        )
        logged = self.model.logger.name_to_value
        row.update({k: float(v) for k, v in logged.items() if k.startswith("gp/")})
        return row


def rerun(
    critic: str,
    seed: int,
    published_in: Path | None = HERE / "s170",
    gp_options: tuple[tuple[str, Any], ...] = (),
    algo: str = "ppo",
) -> dict[str, Any]:
    """Re-run the ``algo`` run of ``critic`` and ``seed`` published in ``published_in`` (made
    with ``gp_options``) with a :class:`RolloutRecord`; raises if its evaluations differ.
    ``published_in=None``: a run that no folder holds (nothing to compare)."""
    config = SweepConfig(algos=(algo,), critics=(critic,), envs=("CartPole-v1",),
                         seeds=(seed,), timesteps=100_000, gp_options=gp_options)  # fmt: skip
    (spec,) = config.specs()
    record = RolloutRecord()
    with tempfile.TemporaryDirectory() as scratch:
        result = run_one(spec, scratch, recorders=[record])
    if published_in is not None:
        published = json.loads((published_in / "runs" / f"{spec.run_id}.json").read_text())
        if result["eval"]["returns"] != published["eval"]["returns"]:
            raise RuntimeError(f"{spec.run_id}: the re-run's evaluations differ from the published")
    return dict(run_id=spec.run_id, eval=result["eval"], rollouts=record.rows)


def plot(runs: dict[tuple[str, int], dict[str, Any]], seeds: Sequence[int], path: Path) -> None:
    plt = pyplot()
    colors = {"mlp": "0.4", "laplacian": "tab:green"}
    fig, axes = plt.subplots(2, len(seeds), figsize=(4.6 * len(seeds), 6.2), squeeze=False)
    for col, seed in enumerate(seeds):
        for critic in CRITICS:
            run = runs[critic, seed]
            t = [r["timesteps"] for r in run["rollouts"]]
            top, bottom = axes[0][col], axes[1][col]
            top.plot(run["eval"]["timesteps"], run["eval"]["mean_return"], color=colors[critic],
                     marker="o", ms=3, label=f"{critic}: evaluation (deterministic)")  # fmt: skip
            top.plot(t, [r["episode_length"] for r in run["rollouts"]], color=colors[critic],
                     ls=":", label=f"{critic}: training episodes (stochastic)")  # fmt: skip
            ev = [np.nan if r["explained_variance"] is None else r["explained_variance"]
                  for r in run["rollouts"]]  # fmt: skip
            bottom.plot(t, np.clip(ev, -1, 1), color=colors[critic], lw=0.8, label=critic)
        axes[0][col].set(title=f"PPO CartPole-v1, seed {seed}", ylabel="episode length / return")
        axes[1][col].set(
            xlabel="timesteps", ylabel="explained variance, out of sample", ylim=(-1.05, 1.05)
        )
        for ax in (axes[0][col], axes[1][col]):
            ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7, loc="lower right")
    axes[1][0].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[172, 173, 179])
    args = parser.parse_args(argv)
    out = HERE / "fall"
    out.mkdir(exist_ok=True)
    runs = {}
    for seed in args.seeds:
        for critic in CRITICS:
            path = out / f"{critic}_s{seed}.json"
            if not path.exists():
                path.write_text(json.dumps(rerun(critic, seed)))
            runs[critic, seed] = json.loads(path.read_text())
            print(f"{critic} seed {seed}: done", flush=True)
    plot(runs, args.seeds, out / "fall.png")


if __name__ == "__main__":
    main()
