"""The advantages PPO's actor learned from on WallMaze-v0, against the GAE advantages with the
policy's own value function (PLAN.md's fourth and fifth addenda).

Re-runs stored WallMaze-v0 runs of two arms with a recorder that, every ``EVERY``-th
rollout, estimates ``V^pi`` at the rollout's states by Monte Carlo in a forked random stream
(each re-run must reproduce its stored final return and evaluation curve exactly) and scores
the buffer's advantages against the reference ones; the first arm minus the second, paired by
seed. ``--compare oracle`` (default, the fourth addendum): the screen's ``oracle`` and
``blind`` runs, seeds 580-589; ``--compare mlp`` (the fifth): issue 13's table's ``laplacian``
and ``mlp`` runs, seeds 570-579. Finished runs are kept in ``<stem>[_mlp].json`` (an
interrupted call resumes); the table goes to stdout, the figure to ``<stem>[_mlp].png``.

    python results/maze_oracle/advantages.py --stem advantages > results/maze_oracle/advantages.md
    python results/maze_oracle/advantages.py --stem advantages --compare mlp \
        > results/maze_oracle/advantages_mlp.md

Addendum 6 adds the policy-gradient readings (:func:`gradient_cosines`) in new runs:

    python results/maze_oracle/advantages.py > results/maze_oracle/advantages_gradient.md
    python results/maze_oracle/advantages.py --compare mlp \
        > results/maze_oracle/advantages_gradient_mlp.md

and addendum 7 what each PPO update achieved (``Advantages._score_update``):

    python results/maze_oracle/advantages.py --stem advantages_update \
        > results/maze_oracle/advantages_update.md
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import multiprocessing
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import torch
from tqdm.auto import tqdm

from sb3_geogp.comparison.run import result_path, run_one
from sb3_geogp.envs.wall_maze import WALL_MAZE_ID, MazeLayout, distances_to_walls
from sb3_geogp.studies.value_ceiling import ceiling, reference_advantages
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import correlation

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RUN = load_script(HERE / "run.py", "maze_oracle_run")
READ = load_script(HERE / "read.py", "maze_oracle_read")
CRITIC_FIT = load_script(ROOT / "examples" / "critic_fit.py", "critic_fit")


@dataclass(frozen=True)
class Arm:
    """Where an arm's stored runs are, its critic, and whether its kernel is the oracle's."""

    folder: Path
    critic: str
    oracle: bool = False


TABLE = ROOT / "results" / "table50" / "ppo_s570"
#: ``--compare`` -> (arms, first minus second; seeds; suffix of the output files).
COMPARISONS: dict[str, tuple[dict[str, Arm], tuple[int, ...], str]] = {
    "oracle": (
        {
            "oracle": Arm(HERE / "oracle", "geodesic", True),
            "blind": Arm(HERE / "blind", "geodesic"),
        },
        RUN.SEEDS,
        "",
    ),
    "mlp": (
        {"laplacian": Arm(TABLE, "laplacian"), "mlp": Arm(TABLE, "mlp")},
        tuple(range(570, 580)),
        "_mlp",
    ),
}
#: Every this many rollouts one is measured (the 3rd, 6th, ...).
EVERY = 3
#: Monte Carlo rollouts per state, and the return left out at the cut (rewards are -1).
N_ROLLOUTS, TAIL = 16, 1.0
#: Steps that start this close to an interior wall count as next to it (exploratory split).
NEAR = 0.1
#: Per-run readings: key -> (row label, prediction's direction or "" for exploratory).
READINGS = {
    "advantage_correlation": "advantage correlation with V^pi's (primary)",
    "value_rmse": "value RMSE against V^pi at the rollout's states",
    "advantage_reliability": "reliability of the reference (halves' correlation)",
    "near_correlation": f"advantage correlation, steps within {NEAR} of an interior wall",
    "far_correlation": "advantage correlation, the other steps",
    "value_bias": "mean value bias V - V^pi",
    "mc_se": "Monte Carlo standard error of V^pi (root mean square)",
    "gradient_cosine": "policy-gradient cosine, critic against V^pi (addendum 6)",
    "gradient_cosine_mean": "the same, action mean's parameters only (without log std)",
    "gradient_reliability": "policy-gradient cosine between the halves' references",
    "update_improvement": "true gain of the update, mean r A* (addendum 7)",
    "update_surrogate": "the same with the critic's advantages (what PPO optimised)",
    "update_step": "mean absolute log ratio of the update",
}


class Advantages(CRITIC_FIT.WithCeiling):  # type: ignore[name-defined,misc]
    """Every ``EVERY``-th rollout: the buffer's advantages and values against ``V^pi``'s."""

    def __init__(self, seed: int) -> None:
        super().__init__(WALL_MAZE_ID, first=0, n_rollouts=N_ROLLOUTS, tail=TAIL, seed=seed)
        self.walls = np.asarray(MazeLayout().walls, dtype=np.float64)
        # A measured rollout waiting for PPO's update on it: its row, states, actions, log
        # probabilities under the rollout policy and both advantages (addendum 7).
        self.pending: tuple[dict[str, Any], torch.Tensor, torch.Tensor, torch.Tensor,
                            list[np.ndarray]] | None = None  # fmt: skip

    def _on_rollout_start(self) -> None:
        super()._on_rollout_start()
        self._score_update()

    def _on_training_end(self) -> None:
        self._score_update()

    def _score_update(self) -> None:
        """Addendum 7's readings of the pending rollout, once PPO has trained on it."""
        if self.pending is None:
            return
        row, obs, actions, old, advantages = self.pending
        self.pending = None
        with torch.no_grad():
            log_ratio = self.model.policy.get_distribution(obs).log_prob(actions) - old
        ratio = log_ratio.exp().double().cpu().numpy()
        critic, reference = ((a - a.mean()) / (a.std(ddof=1) + 1e-8) for a in advantages)
        row["update_improvement"] = float(np.mean(ratio * reference))
        row["update_surrogate"] = float(np.mean(ratio * critic))
        row["update_step"] = float(log_ratio.abs().mean())

    def row(self) -> dict[str, Any]:
        row: dict[str, Any] = {"timesteps": int(self.num_timesteps)}
        if (len(self.rows) + 1) % EVERY:
            return row
        model, buffer = self.model, self.model.rollout_buffer
        gamma, lam = float(model.gamma), float(model.gae_lambda)
        rollout, mc = self.monte_carlo()
        advantages = buffer.advantages.ravel()
        scores = ceiling(
            rollout, mc, gamma, lam, critic=buffer.values.ravel(), advantages=advantages
        )
        reference = reference_advantages(rollout, mc, gamma, lam)
        near = distances_to_walls(buffer.observations.reshape(-1, 2), self.walls) < NEAR
        row.update({k: scores[k] for k in READINGS if k in scores})
        row["near_correlation"] = correlation(reference[near], advantages[near])
        row["far_correlation"] = correlation(reference[~near], advantages[~near])
        row["near_share"] = float(near.mean())
        halves = [reference_advantages(rollout, mc[:, k::2], gamma, lam) for k in (0, 1)]
        row.update(gradient_cosines(model.policy, buffer, advantages, reference, halves))
        n = buffer.rewards.size
        obs = torch.as_tensor(buffer.observations.reshape(n, -1), device=model.policy.device)
        actions = torch.as_tensor(buffer.actions.reshape(n, -1), device=model.policy.device)
        with torch.no_grad():
            old = model.policy.get_distribution(obs).log_prob(actions)
        self.pending = (row, obs, actions, old, [advantages.copy(), reference])
        return row


def policy_gradients(
    policy: Any, buffer: Any, advantages: list[np.ndarray]
) -> tuple[list[torch.Tensor], list[torch.Tensor]]:
    """Per advantage vector (one per rollout step, flattened as the buffer), the first policy
    gradient of PPO's update, ``mean_t A_t grad log pi(a_t | s_t)`` with the advantages
    normalised as PPO normalises them (here over the whole rollout), flattened over all the
    actor's parameters; and the same without the log standard deviation. Gradients by
    ``torch.autograd.grad``: no parameter, ``.grad`` or random stream is touched."""
    n = buffer.rewards.size
    obs = torch.as_tensor(buffer.observations.reshape(n, -1), device=policy.device)
    actions = torch.as_tensor(buffer.actions.reshape(n, -1), device=policy.device)
    log_prob = policy.get_distribution(obs).log_prob(actions)
    params = [p for p in policy.parameters() if p.requires_grad]
    log_std = getattr(policy, "log_std", None)
    full, mean_only = [], []
    for a in advantages:
        adv = torch.as_tensor(a, dtype=log_prob.dtype, device=policy.device)
        adv = (adv - adv.mean()) / (adv.std() + 1e-8)
        grads = torch.autograd.grad((adv * log_prob).mean(), params, retain_graph=True,
                                    allow_unused=True)  # fmt: skip
        used = [(p, g) for p, g in zip(params, grads, strict=True) if g is not None]
        full.append(torch.cat([g.ravel() for _, g in used]).double())
        mean_only.append(torch.cat([g.ravel() for p, g in used if p is not log_std]).double())
    return full, mean_only


def gradient_cosines(
    policy: Any,
    buffer: Any,
    advantages: np.ndarray,
    reference: np.ndarray,
    halves: list[np.ndarray],
) -> dict[str, float]:
    """Addendum 6's readings: the cosine between the policy gradients with the critic's and
    with the reference advantages (all actor parameters, and without the log std), and
    between those with the two halves' references."""
    full, mean_only = policy_gradients(policy, buffer, [advantages, reference, *halves])
    cos = torch.nn.functional.cosine_similarity
    return {
        "gradient_cosine": float(cos(full[0], full[1], dim=0)),
        "gradient_cosine_mean": float(cos(mean_only[0], mean_only[1], dim=0)),
        "gradient_reliability": float(cos(full[2], full[3], dim=0)),
    }


def one(arm: Arm, seed: int) -> list[dict[str, Any]]:
    """The recorder's rows of one re-run, checked against its stored run."""
    spec = next(s for s in RUN.specs(arm.critic, (WALL_MAZE_ID,), (seed,)))
    recorder = Advantages(seed)
    kernel = RUN.arm_kernel("oracle") if arm.oracle else None
    with tempfile.TemporaryDirectory() as tmp:
        result = run_one(spec, tmp, recorders=[recorder], kernel=kernel)
    stored = json.loads(result_path(arm.folder, spec).read_text())
    if result["final_return"] != stored["final_return"] or result["eval"] != stored["eval"]:
        raise RuntimeError(f"{spec.run_id} did not reproduce its stored run")
    return recorder.rows


def run_all(arms: dict[str, Arm], seeds: tuple[int, ...], out: Path) -> list[dict[str, Any]]:
    done = json.loads(out.read_text()) if out.exists() else []
    have = {(r["arm"], r["seed"]) for r in done}
    jobs = [(name, seed) for name in arms for seed in seeds if (name, seed) not in have]
    context = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(2, mp_context=context) as pool:
        futures = {pool.submit(one, arms[name], seed): (name, seed) for name, seed in jobs}
        for future in tqdm(cf.as_completed(futures), total=len(futures), desc="runs"):
            name, seed = futures[future]
            done.append({"arm": name, "seed": seed, "rollouts": future.result()})
            out.write_text(json.dumps(sorted(done, key=lambda r: (r["arm"], r["seed"]))))
    return sorted(done, key=lambda r: (r["arm"], r["seed"]))


def measured(run: dict[str, Any]) -> list[dict[str, Any]]:
    return [r for r in run["rollouts"] if "advantage_correlation" in r]


def per_run(runs: list[dict[str, Any]], names: list[str], key: str) -> dict[str, np.ndarray]:
    """Per arm, the run means over measured rollouts (NaN rollouts left out), in seed order."""
    return {
        name: np.array(
            [np.nanmean([r[key] for r in measured(run)]) for run in runs if run["arm"] == name]
        )
        for name in names
    }


def stored(arms: dict[str, Arm], seeds: tuple[int, ...]) -> dict[str, dict[str, np.ndarray]]:
    """Per reading and arm, the stored runs' area under the curve and final return."""
    results = {
        name: [
            json.loads(result_path(arm.folder, spec).read_text())
            for spec in RUN.specs(arm.critic, (WALL_MAZE_ID,), seeds)
        ]
        for name, arm in arms.items()
    }
    return {
        "area under the learning curve (stored runs)": {
            name: np.array([np.mean(r["eval"]["mean_return"]) for r in rs])
            for name, rs in results.items()
        },
        "final return (stored runs)": {
            name: np.array([r["final_return"] for r in rs]) for name, rs in results.items()
        },
    }


def table(runs: list[dict[str, Any]], arms: dict[str, Arm], seeds: tuple[int, ...]) -> str:
    first, second = arms
    span = f"{seeds[0]}-{seeds[-1]}"
    lines = [
        f"## The advantages PPO learned from: WallMaze-v0, seeds {span}, every third rollout "
        f"(re-runs reproduce the stored runs; V^pi by Monte Carlo, {N_ROLLOUTS} rollouts per "
        "state)\n",
        f"| per run, mean over measured rollouts | {first} | {second} | "
        f"{first} − {second} [95 % t] |",
        "|---|---:|---:|---|",
    ]
    present = [key for key in READINGS if key in measured(runs[0])[0]]
    rows = {READINGS[key]: per_run(runs, [first, second], key) for key in present}
    for name, v in {**rows, **stored(arms, seeds)}.items():
        lines.append(
            f"| {name} | {v[first].mean():.3f} | {v[second].mean():.3f} | "
            f"{READ.paired(v[first], v[second], 3)} |"
        )
    share = np.mean([r["near_share"] for run in runs for r in measured(run)])
    lines.append(f"\nShare of steps within {NEAR} of an interior wall: {share:.3f}.")
    return "\n".join(lines)


def plot(runs: list[dict[str, Any]], names: list[str], title: str, path: Path) -> None:
    keys = tuple(
        k
        for k in (
            "advantage_correlation",
            "value_rmse",
            "advantage_reliability",
            "gradient_cosine",
            "update_improvement",
        )
        if k in measured(runs[0])[0]
    )
    fig, axes = plt.subplots(1, len(keys), figsize=(4.2 * len(keys), 3.4))
    for ax, key in zip(axes, keys, strict=True):
        for name, colour in zip(names, ("tab:red", "tab:blue"), strict=True):
            rows = [measured(run) for run in runs if run["arm"] == name]
            t = np.array([r["timesteps"] for r in rows[0]])
            y = np.array([[r[key] for r in run] for run in rows], dtype=np.float64)
            mean = np.nanmean(y, axis=0)
            half = 1.96 * np.nanstd(y, axis=0, ddof=1) / np.sqrt(np.sum(~np.isnan(y), axis=0))
            ax.plot(t, mean, color=colour, label=name)
            ax.fill_between(t, mean - half, mean + half, color=colour, alpha=0.2)
        ax.set(xlabel="timesteps", title=READINGS[key].split(" (")[0])
        ax.grid(alpha=0.3)
    axes[0].legend()
    fig.suptitle(f"WallMaze-v0, PPO, {title}: mean over seeds, 95 % normal band")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--compare", choices=list(COMPARISONS), default="oracle")
    parser.add_argument(
        "--stem",
        default="advantages_gradient",
        help="name of the runs' JSON and the figure (addenda 4-5: advantages, made before "
        "the gradient readings)",
    )
    args = parser.parse_args()
    arms, seeds, suffix = COMPARISONS[args.compare]
    runs = run_all(arms, seeds, HERE / f"{args.stem}{suffix}.json")
    print(table(runs, arms, seeds))
    plot(runs, list(arms), f"seeds {seeds[0]}-{seeds[-1]}", HERE / f"{args.stem}{suffix}.png")


if __name__ == "__main__":
    main()
