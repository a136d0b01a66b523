"""Why the GP critic stalls PPO on Acrobot-v1: what each critic's values say about height.

Run: ``python examples/acrobot_stall.py --seeds 11 15 --out docs/acrobot_stall`` (PPO with the
comparison's zoo hyperparameters and budget; about 2 minutes a run on one core).

Per rollout, for SB3's MLP critic, 0.8's default GP critic (Laplacian, adaptive, constant prior
mean, no trend: since 0.9 the default moves a level) and the same GP critic with
``prior_mean="linear"``, on the same seeds (the actor starts from the same parameters; run
today, both GP critics have today's adaptation and starting forgetting, so
``docs/acrobot_stall``, made with 0.8, does not repeat): how many episodes of the rollout
reached the goal (episodes shorter than the 500-step cap), and the correlation, over the
rollout's states, between the critic's values (predicted before it learns from the rollout:
those the advantages use) and the height of the acrobot's tip, ``-cos(t1) - cos(t1 + t2)``.
Reaching the goal means reaching height 1; a critic whose values rise with height points the
actor there. Also per rollout: the critic's out-of-sample explained variance on it (SB3's
``explained_variance`` of those values against the rollout's GAE returns, as
``examples/critic_fit.py`` measures it), the correlation of those returns themselves with the
height (what a critic fitted to them could learn of it) and, for a GP critic, the forgetting
its adaptation chose last (``gp/forgetting``).

``--gp LABEL=JSON`` (repeatable) replaces the GP critics above by the Laplacian GP critic with
the options of ``JSON`` (the policy's defaults for the rest), e.g. today's default and 0.13's:

    python examples/acrobot_stall.py --seeds 12 15 --gp 0.15={} --gp '0.13={"forgetting": 1.0}'

Writes ``acrobot_stall.json`` (every rollout's figures) and ``acrobot_stall.png``.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.utils import explained_variance
from tqdm.auto import tqdm

from sb3_geogp import GPValueCallback
from sb3_geogp.comparison.hyperparams import GP_KWARGS, hyperparams
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.specs import RunSpec
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg

#: Critic label -> (critic of the comparison, extra GP options).
CRITICS: dict[str, tuple[str, dict[str, Any]]] = {
    "MLP": ("mlp", {}),
    "GP, constant mean (default)": ("laplacian", {"trend": "none"}),
    "GP, linear mean": ("laplacian", {"prior_mean": "linear", "trend": "none"}),
}
ENV_ID = "Acrobot-v1"
CAP = 500


def tip_height(obs: np.ndarray) -> np.ndarray:
    """``-cos(t1) - cos(t1 + t2)`` of Acrobot observations ``(n, 6)``
    (``cos t1, sin t1, cos t2, sin t2, ...``), in [-2, 2]."""
    cos_sum = obs[:, 0] * obs[:, 2] - obs[:, 1] * obs[:, 3]
    return -obs[:, 0] - cos_sum


def gp_critic(text: str) -> tuple[str, tuple[str, dict[str, Any]]]:
    """``LABEL=JSON`` as ``(LABEL, ("laplacian", options))``, the options a JSON object."""
    label, sep, options = text.partition("=")
    try:
        parsed = json.loads(options) if sep and label else None
    except ValueError:
        parsed = None
    if not isinstance(parsed, dict):
        raise argparse.ArgumentTypeError(
            f'expected LABEL=JSON with a JSON object of GP options (e.g. \'0.13={{"forgetting": '
            f"1.0}}'), got {text!r}"
        )
    return label, ("laplacian", parsed)


class RolloutRecorder(BaseCallback):
    """Per rollout: episodes ended, episodes that reached the goal, corr(values, height), the
    values' explained variance of the GAE returns, corr(returns, height) and a GP critic's last
    chosen forgetting."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, float]] = []
        self._ended = self._goals = 0

    def _on_step(self) -> bool:
        for info in self.locals["infos"]:
            if "episode" in info:
                self._ended += 1
                # The goal step earns 0, not -1: an episode reaching it even on its last step
                # returns more than -CAP (a step count < CAP would miss that one).
                self._goals += int(info["episode"]["r"] > -CAP)
        return True

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer  # type: ignore[attr-defined]
        values = buffer.values.ravel()
        height = tip_height(buffer.observations.reshape(-1, buffer.obs_shape[0]))
        corr = float(np.corrcoef(values, height)[0, 1]) if values.std() > 0 else 0.0
        row = dict(timesteps=self.num_timesteps, ended=self._ended, goals=self._goals, corr=corr)
        returns = buffer.returns.ravel()
        row["explained"] = float(explained_variance(values, returns))
        row["returns_corr"] = float(np.corrcoef(returns, height)[0, 1])
        gp = getattr(self.model.policy, "gp", None)
        if gp is not None:
            row["forgetting"] = float(gp.last_stats.get("forgetting", gp.forgetting))
        self.rows.append(row)
        self._ended = self._goals = 0


def run(
    label: str, seed: int, timesteps: int, critics: dict[str, tuple[str, dict[str, Any]]] = CRITICS
) -> list[dict[str, float]]:
    """One PPO run of the critic ``critics[label]`` on ``seed``: its rollouts' figures."""
    critic, extra = critics[label]
    params = hyperparams("ppo", ENV_ID)
    spec = RunSpec(
        algo="ppo", critic=critic, env_id=ENV_ID, seed=seed, total_timesteps=timesteps,
        gp_kwargs=tuple(sorted({**GP_KWARGS, **extra}.items())),
        hyperparams=params.values, hyperparams_source=params.source, threshold=-100.0,
    )  # fmt: skip
    model = build_model(spec)
    recorder = RolloutRecorder()
    feed = GPValueCallback(target=spec.target, horizon=spec.horizon)  # the spec's: SB3's returns
    callbacks: list[BaseCallback] = [recorder] if critic == "mlp" else [feed, recorder]
    model.learn(timesteps, callback=CallbackList(callbacks))
    env = model.get_env()
    assert env is not None
    env.close()
    return recorder.rows


def plot(results: dict[str, Any], path: Path) -> None:
    """Goals per rollout, corr(values, height) and the values' explained variance (clipped at
    -1), a row each, a column per seed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    seeds = sorted({int(s) for runs in results.values() for s in runs})
    fig, axes = plt.subplots(3, len(seeds), figsize=(4.2 * len(seeds), 8.5), squeeze=False)
    for k, label in enumerate(results):
        for j, seed in enumerate(seeds):
            rows = results[label][str(seed)]
            t = [r["timesteps"] for r in rows]
            axes[0, j].plot(t, [r["goals"] for r in rows], "o-", color=f"C{k}", label=label)
            axes[1, j].plot(t, [r["corr"] for r in rows], "o-", color=f"C{k}", label=label)
            explained = [max(-1.0, r["explained"]) for r in rows]
            axes[2, j].plot(t, explained, "o-", color=f"C{k}", label=label)
    for j, seed in enumerate(seeds):
        axes[0, j].set_title(f"PPO {ENV_ID}, seed {seed}", fontsize=10)
        axes[0, j].set_ylabel("episodes reaching the goal")
        axes[1, j].set_ylabel("corr(critic values, tip height)")
        axes[2, j].set_ylabel("explained variance (out of sample)")
        axes[2, j].set_xlabel("timesteps")
        for ax in axes[1:, j]:
            ax.axhline(0, color="k", lw=0.8)
        for ax in axes[:, j]:
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[11, 15])
    parser.add_argument("--timesteps", type=count_arg, default=30_000)
    parser.add_argument("--out", type=Path, default=Path("acrobot_stall"))
    parser.add_argument(
        "--gp",
        type=gp_critic,
        action="append",
        metavar="LABEL=JSON",
        help="a Laplacian GP critic with these options, instead of the two above (repeatable)",
    )
    args = parser.parse_args(argv)
    critics = {"MLP": CRITICS["MLP"], **dict(args.gp)} if args.gp else CRITICS
    th.set_num_threads(1)
    args.out.mkdir(parents=True, exist_ok=True)
    results: dict[str, Any] = {label: {} for label in critics}
    jobs = [(label, seed) for seed in args.seeds for label in critics]
    for label, seed in tqdm(jobs, unit="run", desc="runs"):
        results[label][str(seed)] = run(label, seed, args.timesteps, critics)
    (args.out / "acrobot_stall.json").write_text(json.dumps(results, indent=1))
    plot(results, args.out / "acrobot_stall.png")
    for label, runs in results.items():
        for seed, rows in runs.items():
            goals = " ".join(f"{r['goals']:2d}" for r in rows)
            corr = " ".join(f"{r['corr']:+.2f}" for r in rows)
            explained = " ".join(f"{r['explained']:+.2f}" for r in rows)
            returns = " ".join(f"{r['returns_corr']:+.2f}" for r in rows)
            print(f"{label:28s} seed {seed}: goals {goals} | corr {corr} | explained {explained}")
            print(f"{'':28s} {'':{len(seed) + 6}s} corr(returns, height) {returns}")
            if "forgetting" in rows[0]:
                chosen = " ".join(f"{r['forgetting']:.2f}" for r in rows)
                print(f"{'':28s} {'':{len(seed) + 6}s} forgetting {chosen}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
