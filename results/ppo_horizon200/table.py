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

``--registered`` reads addendum 2's registered test on fresh seeds 320-339 (``registered/``,
laid out as ``confirm/``) and checks its primary reading and guards; Acrobot's H − C is also
read paired over every seed run so far. ``--verdict`` prints issue 13's verdict table with H's
runs in the three PPO cells a 200-step cut changes (the screen's ``H_s<F>`` and ``mcc_s<F>``),
every other cell as published, against SB3's MLP critic, and checks addendum 2's adoption rule
against the published table (``results/ppo_mc_targets/table.py --verdict``); it first compares
H and C run on seed 0 of the four PPO cells whose episodes last at most 200 steps
(``identity/``, session 44, after the adoption reading), where the cut should change nothing:

    python results/ppo_horizon200/table.py --registered \\
        --plot results/ppo_horizon200/registered/table.png \\
        > results/ppo_horizon200/registered/table.md
    python results/ppo_horizon200/table.py --registered --metric mean_return \\
        > results/ppo_horizon200/registered/auc.md
    python results/ppo_horizon200/table.py --verdict > results/ppo_horizon200/verdict.md
    python results/ppo_horizon200/table.py --verdict --metric mean_return \\
        > results/ppo_horizon200/verdict_auc.md
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "replication_0_15"))
from pool30 import mlp_rows, print_table  # noqa: E402

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
MCC = "MountainCarContinuous-v0"
CONFIRM_ENVS = (*ENVS, MCC)
#: Addendum 2's blocks of fresh seeds.
REGISTERED_BLOCKS = (320, 330)


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


def pooled_acrobot() -> tuple[list[dict[str, Any]], ...]:
    """H's and C's Acrobot runs of every sample so far (the screen, addenda 1 and 2), whole
    blocks only."""
    samples = [
        arms(),
        HORIZON.confirmation(HERE / "confirm", CONFIRM_BLOCKS, CONFIRM_ENVS),
        HORIZON.confirmation(HERE / "registered", REGISTERED_BLOCKS, CONFIRM_ENVS),
    ]
    return tuple(
        [r for sample in samples for r in sample[i] if r["spec"]["env_id"] == "Acrobot-v1"]
        for i in (0, 1)
    )


def registered_rule(h_c: dict[tuple[str, str], dict[str, Any]]) -> list[str]:
    """Addendum 2's primary reading and guards, each as a line saying whether it holds."""
    if set(h_c) != {(env, "ppo") for env in CONFIRM_ENVS}:
        return ["- partial: not every cell has finished; no decision"]
    primary = h_c[(MCC, "ppo")]["verdict"] == "better"
    guards = {env: h_c[(env, "ppo")]["verdict"] != "worse" for env in ENVS}
    lines = [f"- primary, {MCC} H − C better at 95 %: {'holds' if primary else 'fails'}"]
    lines += [f"- guard, {env} H − C not worse at 95 %: {'holds' if ok else 'fails'}"
              for env, ok in guards.items()]  # fmt: skip
    return lines


def table_runs(cut: tuple[str, ...] = CONFIRM_ENVS) -> tuple[list[dict[str, Any]], ...]:
    """The runs of issue 13's table with H in the ``cut`` cells (the default critic's and SB3's
    MLP critic's, both algorithms), the published table's, and the H cells' names."""
    mcc = pool_sweeps([f for f in (HERE / f"mcc_s{s}" for s in FIRST_SEEDS) if f.is_dir()])
    horizon = [r for r in mcc + arms()[0] if r["spec"]["env_id"] in cut]
    published, _, mlp = READING.arms()
    changed = {r["spec"]["env_id"] for r in horizon}
    kept = [r for r in published if r["spec"]["env_id"] not in changed]
    a2c = READING.TABLE40.a2c_runs()
    return horizon + kept + mlp + a2c, published + mlp + a2c, sorted(changed)


def verdict(metric: str, cut: tuple[str, ...] = CONFIRM_ENVS) -> list[str]:
    """Issue 13's table with H in the ``cut`` cells of those a 200-step cut changes (by
    default all three), and addendum 2's adoption rule checked against the published table
    (both on the seeds every arm has)."""
    runs, published, changed = table_runs(cut)
    new = mlp_rows(runs, metric)
    old = mlp_rows(published, metric)
    print_table(new, READING.LABELS[metric])
    lost = [f"{env} {algo}" for (env, algo), c in old.items()
            if c["verdict"] == "better" and new[(env, algo)]["verdict"] != "better"]  # fmt: skip
    worse = [sum(c["verdict"] == "worse" for c in t.values()) for t in (new, old)]
    fw_worse = [k for k, c in new.items() if c["fw_verdict"] == "worse"]
    complete = all(env in changed and new[(env, "ppo")]["n_a"] == 40 for env in cut)
    return [
        *([] if complete else ["- partial: a changed cell lacks H's 40 seeds; no decision"]),
        f"- no cell worse family-wise: {'holds' if not fw_worse else f'fails ({fw_worse})'}",
        f"- worse at 95 %: {worse[0]} (published {worse[1]}): "
        f"{'holds' if worse[0] <= worse[1] else 'fails'}",
        f"- no better cell lost: {'holds' if not lost else f'fails ({lost})'}",
    ]


def main() -> None:
    parser = READING.TABLE40.reading_parser(__doc__, "H", verdict=False)
    sample = parser.add_mutually_exclusive_group()
    sample.add_argument(
        "--confirm", action="store_true", help="addendum 1's confirmation on seeds 300-319"
    )
    sample.add_argument(
        "--registered", action="store_true", help="addendum 2's test on seeds 320-339"
    )
    sample.add_argument(
        "--verdict", action="store_true", help="issue 13's table with H in its changed cells"
    )
    args = parser.parse_args()
    if args.verdict:
        print("## Identity control: H and C where no episode exceeds 200 steps, seed 0\n")
        print("\n".join(HORIZON.identity(*(HERE / "identity" / a / "runs" for a in "HC"))))
        print("\n## Issue 13's table, H in the PPO cells a 200-step cut changes\n")
        rule = verdict(args.metric)
        if args.metric == "final_return":
            print("\n### Addendum 2's adoption rule\n")
            print("\n".join(rule))
        return
    if args.confirm or args.registered:
        folder, blocks = (
            ("registered", REGISTERED_BLOCKS) if args.registered else ("confirm", CONFIRM_BLOCKS)
        )
        horizon, mc, mlp = HORIZON.confirmation(HERE / folder, blocks, CONFIRM_ENVS)
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
    if args.registered and args.metric == "final_return":
        print("\n### Addendum 2's rule\n")
        print("\n".join(registered_rule(sets["H − C"])))
        print("\n### Acrobot H − C paired by seed, every sample so far (secondary)\n")
        print("\n".join(HORIZON.paired(*pooled_acrobot(), envs=("Acrobot-v1",))))
    if args.plot:
        panels = [
            {"env": env, "algo": "ppo", **{k: t.get((env, "ppo")) for k, t in sets.items()}}
            for env in envs
        ]
        seeds = len({r["spec"]["seed"] for r in horizon})
        what = "fresh seeds" if args.confirm or args.registered else "screen"
        title = f"PPO, {what} ({seeds} seeds): horizon=200 (H), 0.24's default (C), {label}"
        plot_difference_panels(panels, list(sets), args.plot, title, len(envs), (3.2, 2.8))


if __name__ == "__main__":
    main()
