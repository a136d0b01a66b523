"""Every PPO critic change tried at Acrobot's stalls, as what it gives Acrobot (seeds 10-19,
where the 0.15 default stalls) against what it costs CartPole (seeds 0-9), both against the
0.15 default on the same seeds: final return, difference of means, 95 % bootstrap interval;
SB3's MLP critic on the same seeds for comparison. Seeds 10-19 were chosen because the default
stalls there, so each change's Acrobot gain is inflated by regression to the mean (the MLP's:
+181.2 there, +90.7 over seeds 0-29; docs/results.md, session 29).

    python results/acrobot_tries/frontier.py   # -> frontier.md, frontier.png beside it
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from sb3_geogp.comparison.results import pool_sweeps  # noqa: E402
from sb3_geogp.toolbox.stats import difference_ci  # noqa: E402

HERE = Path(__file__).parent
RESULTS = HERE.parent
#: The 0.15 default's runs (as in docs/results.md, "A sloped level"); later folders win.
REFERENCE = [
    RESULTS / name
    for name in (
        "compare",
        "replication_s10/ppo",
        "shrink_points/s0_9",
        "replication_0_15/ppo_s10",
    )
]
#: The changes: label -> folders holding their Acrobot 10-19 and CartPole 0-9 runs.
VARIANTS = {
    'trend="sloped_level"': ["sloped_level/s0_9", "sloped_level/s10_19"],
    "broad component, w = 0.1": [
        "acrobot_tries/broad/w01_acrobot_s10",
        "acrobot_tries/broad/w01_cartpole_s0",
    ],
    "broad component, w = 0.3": ["acrobot_tries/broad/w03_s0", "acrobot_tries/broad/w03_s10"],
    "broad component, w fitted": [
        "acrobot_tries/broad/learned_acrobot_s10",
        "acrobot_tries/broad/learned_cartpole_s0",
    ],
    "optimism = 0.3": [
        "acrobot_tries/optimism/opt03_acrobot_s10",
        "acrobot_tries/optimism/opt03_cartpole_s0",
    ],
    "optimism = 1": [
        "acrobot_tries/optimism/opt1_acrobot_s10",
        "acrobot_tries/optimism/opt1_cartpole_s0",
    ],
}
CELLS = {"Acrobot-v1": range(10, 20), "CartPole-v1": range(10)}


def finals(runs: list[dict], env_id: str, seeds: range, critic: str = "laplacian") -> np.ndarray:
    chosen = {
        r["spec"]["seed"]: r["final_return"]
        for r in runs
        if r["spec"]["env_id"] == env_id
        and r["spec"]["algo"] == "ppo"
        and r["spec"]["critic"] == critic
        and r["spec"]["seed"] in seeds
    }
    if sorted(chosen) != list(seeds):
        raise ValueError(f"{env_id}: runs of seeds {sorted(chosen)}, expected {list(seeds)}")
    return np.array([chosen[s] for s in seeds])


def main() -> None:
    reference = pool_sweeps(REFERENCE)
    rows = {}
    for label, folders in VARIANTS.items():
        runs = pool_sweeps([RESULTS / f for f in folders])
        rows[label] = {
            env: difference_ci(finals(runs, env, seeds), finals(reference, env, seeds))
            for env, seeds in CELLS.items()
        }
    # Where the changes aim: SB3's MLP critic on the same seeds.
    rows["SB3 MLP critic (not a GP change)"] = {
        env: difference_ci(finals(reference, env, seeds, "mlp"), finals(reference, env, seeds))
        for env, seeds in CELLS.items()
    }
    lines = [
        "| change (PPO) | Acrobot 10-19 − 0.15 default | CartPole 0-9 − 0.15 default |",
        "|---|---|---|",
    ]
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for i, (label, cells) in enumerate(rows.items()):
        (ax_d, ax_lo, ax_hi), (cp_d, cp_lo, cp_hi) = (cells[e] for e in CELLS)
        cell = "{:+.1f} [{:+.1f}, {:+.1f}]"
        lines.append(
            f"| {label} | {cell.format(ax_d, ax_lo, ax_hi)} | {cell.format(cp_d, cp_lo, cp_hi)} |"
        )
        ax.errorbar(
            ax_d,
            cp_d,
            xerr=[[ax_d - ax_lo], [ax_hi - ax_d]],
            yerr=[[cp_d - cp_lo], [cp_hi - cp_d]],
            fmt="*" if label.startswith("SB3") else "o",
            color=f"C{i}",
            markersize=9,
            capsize=3,
            label=label,
            alpha=0.85,
        )
    ax.axhline(0, color="k", lw=0.8)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlabel("Acrobot-v1, seeds 10-19 (chosen for the default's stalls): − 0.15 default")
    ax.set_ylabel("CartPole-v1, seeds 0-9: final return − 0.15 default")
    ax.set_title("PPO changes: Acrobot at the default's stalled seeds, CartPole (95 % CI)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(HERE / "frontier.png", dpi=110)
    (HERE / "frontier.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
