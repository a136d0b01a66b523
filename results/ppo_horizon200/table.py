"""The screen of ``horizon=200`` on PPO Acrobot-v1 and CartPole-v1, read as
``PREREGISTRATION.md`` fixes (session 43).

H: PPO's default GP critic fed Monte Carlo returns cut after 200 steps (``H_s<F>``); C: 0.24's
default, uncut, re-run on the same machine (``C_s<F>``); SB3's MLP critic's stored runs of issue
13's table (``results/table40_prior/table.py``'s arms). Final return (or ``--metric
mean_return``), difference of means, 95 % percentile bootstrap: H − C per cell, family-wise over
the two cells; H − MLP and C − MLP family-wise at the published 42; H − C also paired by seed;
Acrobot runs at the -500 cap. Only whole blocks of 10 seeds (both arms, both cells) are read.

    python results/ppo_horizon200/table.py --plot results/ppo_horizon200/table.png \\
        > results/ppo_horizon200/table.md
    python results/ppo_horizon200/table.py --metric mean_return > results/ppo_horizon200/auc.md

``--confirm`` reads addendum 1's confirmation on fresh seeds 300-319 instead (``confirm/``;
Acrobot, CartPole and MountainCarContinuous, the MLP critic run beside; a cell on the blocks
whose three arms finished it):

    python results/ppo_horizon200/table.py --confirm \\
        --plot results/ppo_horizon200/confirm/table.png > results/ppo_horizon200/confirm/table.md
    python results/ppo_horizon200/table.py --confirm --metric mean_return \\
        > results/ppo_horizon200/confirm/auc.md
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "replication_0_15"))
from pool30 import print_table  # noqa: E402

from sb3_geogp.comparison.report import plot_difference_panels  # noqa: E402
from sb3_geogp.comparison.results import pool_sweeps  # noqa: E402
from sb3_geogp.toolbox.scripts import load_script  # noqa: E402

#: ``results/ppo_mcc_horizon/table.py``: the differences, the paired reading and the arms.
HORIZON = load_script(HERE.parent / "ppo_mcc_horizon" / "table.py", "ppo_mcc_horizon")
READING = HORIZON.READING
ENVS = ("Acrobot-v1", "CartPole-v1")
FIRST_SEEDS = READING.FIRST_SEEDS
#: Addendum 1's blocks and cells.
CONFIRM_BLOCKS = (300, 310)
CONFIRM_ENVS = (*ENVS, "MountainCarContinuous-v0")


def arms() -> tuple[list[dict[str, Any]], ...]:
    """The screen's H, C and MLP runs of the whole blocks, on the seeds all three have."""
    horizon: list[dict[str, Any]] = []
    mc: list[dict[str, Any]] = []
    for first in FIRST_SEEDS:
        folders = [HERE / f"{arm}_s{first}" for arm in ("H", "C")]
        if not all(folder.is_dir() for folder in folders):
            continue
        block = [pool_sweeps([folder]) for folder in folders]
        if all(len(runs) == 10 * len(ENVS) for runs in block):
            horizon.extend(block[0])
            mc.extend(block[1])
    _, _, mlp = READING.arms()
    mlp = [r for r in mlp if r["spec"]["env_id"] in ENVS]
    return READING.TABLE40.on_common_seeds(horizon, mc, mlp)


def main() -> None:
    parser = READING.TABLE40.reading_parser(__doc__, "H", verdict=False)
    parser.add_argument(
        "--confirm", action="store_true", help="addendum 1's confirmation on seeds 300-319"
    )
    args = parser.parse_args()
    if args.confirm:
        horizon, mc, mlp = HORIZON.confirmation(HERE / "confirm", CONFIRM_BLOCKS, CONFIRM_ENVS)
    else:
        horizon, mc, mlp = arms()
    envs = sorted({r["spec"]["env_id"] for r in horizon})
    label = READING.LABELS[args.metric]
    sets = HORIZON.differences({"H": horizon, "C": mc, "MLP": mlp}, args.metric, len(envs))
    names = "H: cut after 200 steps; C: 0.24's default, run here"
    for name, rows in sets.items():
        print(f"\n### {name} ({names})\n")
        print_table(rows, label, name)
    print("\n### H − C paired by seed (95 % t)\n")
    print("\n".join(HORIZON.paired(horizon, mc, envs=tuple(envs))))
    stalls = [f"{n} {READING.stalls(a)}" for n, a in (("H", horizon), ("C", mc), ("MLP", mlp))]
    print(f"\nAcrobot runs at the -500 cap: {', '.join(stalls)}")
    if args.plot:
        panels = [
            {"env": env, "algo": "ppo", **{k: t.get((env, "ppo")) for k, t in sets.items()}}
            for env in envs
        ]
        seeds = len({r["spec"]["seed"] for r in horizon})
        what = "confirmation, fresh seeds" if args.confirm else "screen"
        title = f"PPO, {what} ({seeds} seeds): horizon=200 (H), 0.24's default (C), {label}"
        plot_difference_panels(panels, list(sets), args.plot, title, len(envs), (3.2, 2.8))


if __name__ == "__main__":
    main()
