"""The screen of ``horizon=500`` on PPO MountainCarContinuous-v0, read as
``PREREGISTRATION.md`` fixes (session 43).

H: PPO's default GP critic fed Monte Carlo returns cut after 500 steps
(``GPValueCallback(target="monte_carlo", horizon=500)``; folders ``s0``, ``s10``, ``s150``,
``s160``); C: 0.24's default (uncut Monte Carlo returns), A: 0.23's (SB3's returns) and SB3's
MLP critic, the runs ``results/ppo_mc_targets/table.py`` reads. Final return (or ``--metric
mean_return``), difference of means, 95 % percentile bootstrap; H − C the primary reading (one
cell), H − MLP and C − MLP family-wise at the published 42 comparisons. Only seeds all four
arms have are compared. The identity control (``identity``: H on CartPole-v1 and Acrobot-v1,
seed 0, where no episode exceeds 500 steps) is compared with C's stored runs first; addendum
1's control (``c_rerun_s0``: C re-run on this machine, seeds 0-9) is read last, paired by seed.

    python results/ppo_mcc_horizon/table.py --plot results/ppo_mcc_horizon/table.png \\
        > results/ppo_mcc_horizon/table.md
    python results/ppo_mcc_horizon/table.py --metric mean_return > results/ppo_mcc_horizon/auc.md

``--confirm`` reads addendum 2's confirmation on fresh seeds 280-299 instead (``confirm/``;
whole blocks of 10 seeds only), H − C also paired by seed:

    python results/ppo_mcc_horizon/table.py --confirm \\
        --plot results/ppo_mcc_horizon/confirm/table.png > results/ppo_mcc_horizon/confirm/table.md
    python results/ppo_mcc_horizon/table.py --confirm --metric mean_return \\
        > results/ppo_mcc_horizon/confirm/auc.md
"""

from __future__ import annotations

import itertools
import json
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "replication_0_15"))
from pool30 import against_baseline, mlp_rows, print_table  # noqa: E402

from sb3_geogp.comparison.report import plot_difference_panels  # noqa: E402
from sb3_geogp.comparison.results import pool_sweeps  # noqa: E402
from sb3_geogp.toolbox.scripts import load_script  # noqa: E402

#: ``results/ppo_mc_targets/table.py``: C's, A's and the MLP critic's runs, and the parser.
READING = load_script(HERE.parent / "ppo_mc_targets" / "table.py", "ppo_mc_targets")
#: ``results/budget100k_0_23/read.py``: differences paired by seed.
PAIRED = load_script(HERE.parent / "budget100k_0_23" / "read.py", "budget100k_0_23_read")
ENV = "MountainCarContinuous-v0"
#: Addendum 2's blocks of fresh seeds, and the critics of its ``C_s<F>`` folders (C, MLP).
CONFIRM_BLOCKS = (280, 290)
CRITICS = ("laplacian", "mlp")


def identity(
    runs: Path = HERE / "identity" / "runs",
    reference: Path = HERE.parent / "ppo_mc_targets" / "s0" / "runs",
) -> list[str]:
    """One line per identity-control run in ``runs``: equal to the run of the same cell and
    seed in ``reference`` (here C's stored runs), or how it differs."""
    lines = []
    for path in sorted(runs.glob("*.json")):
        h = json.loads(path.read_text())
        c = json.loads((reference / path.name).read_text())
        same = h["final_return"] == c["final_return"] and h["eval"] == c["eval"]
        verdict = "identical" if same else "differ"
        final = f"H {h['final_return']:.1f}, C {c['final_return']:.1f}"
        lines.append(f"- `{path.stem}`: final return and evaluations {verdict} ({final})")
    return lines


def arms_of_screen() -> tuple[list[dict[str, Any]], ...]:
    """H, C, A and the MLP critic's MountainCarContinuous runs on the seeds all four have."""
    folders = [HERE / f"s{f}" for f in READING.FIRST_SEEDS]
    horizon = pool_sweeps([folder for folder in folders if folder.is_dir()])
    return READING.TABLE40.on_common_seeds(
        horizon, *([r for r in runs if r["spec"]["env_id"] == ENV] for runs in READING.arms())
    )


def paired(
    *arms: list[dict[str, Any]],
    names: tuple[str, ...] = ("H", "C"),
    envs: tuple[str, ...] = (ENV,),
) -> list[str]:
    """Each consecutive pair of ``arms`` (named ``names``) differenced in each cell of
    ``envs``, paired by seed, on the (cell, seed) pairs all of them have."""
    cells = set.intersection(*({(r["spec"]["env_id"], r["spec"]["seed"]) for r in a} for a in arms))
    if not cells:
        return ["(not run)"]
    runs = {
        name: {key: r for r in arm if (key := (r["spec"]["env_id"], r["spec"]["seed"])) in cells}
        for name, arm in zip(names, arms, strict=True)
    }
    rows = [
        PAIRED.paired(runs, a, b, env)
        for env in envs
        if any(e == env for e, _ in cells)
        for a, b in itertools.pairwise(names)
    ]
    return [PAIRED.paired_header(), *rows]


def same_machine(horizon: list[dict[str, Any]], mc: list[dict[str, Any]]) -> list[str]:
    """Addendum 1's control: H − C re-run on this machine (``c_rerun_s0``), and the re-run −
    the stored C, each paired by seed on the seeds the re-run has."""
    folder = HERE / "c_rerun_s0"
    rerun = pool_sweeps([folder]) if folder.is_dir() else []
    return paired(horizon, rerun, mc, names=("H", "C re-run", "C"))


def confirmation(
    folder: Path = HERE / "confirm",
    blocks: tuple[int, ...] = CONFIRM_BLOCKS,
    envs: tuple[str, ...] = (ENV,),
) -> tuple[list[dict[str, Any]], ...]:
    """A confirmation's H, C and MLP runs (``folder/H_s<F>``; C and the MLP critic in
    ``folder/C_s<F>``): each cell of ``envs`` on the blocks of 10 seeds whose three arms have
    all finished it (here addendum 2's)."""
    out: tuple[list[dict[str, Any]], ...] = ([], [], [])
    for first in blocks:
        folders = [folder / f"{arm}_s{first}" for arm in ("H", "C")]
        if not all(f.is_dir() for f in folders):
            continue
        horizon, rest = (pool_sweeps([f]) for f in folders)
        block = (horizon, *([r for r in rest if r["spec"]["critic"] == c] for c in CRITICS))
        for env in envs:
            cells = [[r for r in runs if r["spec"]["env_id"] == env] for runs in block]
            if all(len(cell) == 10 for cell in cells):
                for pooled, cell in zip(out, cells, strict=True):
                    pooled.extend(cell)
    return out


def differences(
    arms: dict[str, list[dict[str, Any]]], metric: str, family: int = 1
) -> dict[str, dict[tuple[str, str], dict[str, Any]]]:
    """H − C (family-wise over ``family`` cells), each arm but the MLP − MLP (family-wise at
    the published 42), and H − A where ``arms`` has A."""

    sets = {"H − C": against_baseline(arms["H"], arms["C"], metric, family)}
    for arm in ("H", "C"):
        sets[f"{arm} − MLP"] = mlp_rows(arms[arm] + arms["MLP"], metric)
    if "A" in arms:
        sets["H − A"] = against_baseline(arms["H"], arms["A"], metric, family)
    return sets


def main() -> None:
    parser = READING.TABLE40.reading_parser(__doc__, "H", verdict=False)
    parser.add_argument(
        "--confirm", action="store_true", help="addendum 2's confirmation on seeds 280-299"
    )
    args = parser.parse_args()
    label = READING.LABELS[args.metric]
    if args.confirm:
        horizon, mc, mlp = confirmation()
        arms = {"H": horizon, "C": mc, "MLP": mlp}
        what = "confirmation, fresh seeds"
    else:
        horizon, mc, returns, mlp = arms_of_screen()
        arms = {"H": horizon, "C": mc, "A": returns, "MLP": mlp}
        what = "screen"
        print("## Identity control (H where no episode exceeds 500 steps)\n")
        print("\n".join(identity()) or "(not run)")
    sets = differences(arms, args.metric)
    names = "H: cut after 500 steps; C: 0.24's default; A: SB3's returns"
    for name, rows in sets.items():
        print(f"\n### {name} ({names})\n")
        print_table(rows, label, name)
    if args.confirm:
        print("\n### H − C paired by seed\n")
        print("\n".join(paired(horizon, mc)))
    else:
        print("\n### Same-machine control (addendum 1, exploratory): paired by seed\n")
        print("\n".join(same_machine(horizon, mc)))
    if args.plot:
        panels = [{"env": ENV, "algo": "ppo", **{k: t.get((ENV, "ppo")) for k, t in sets.items()}}]
        n = len({r["spec"]["seed"] for r in horizon})
        title = f"PPO {ENV}, {what} ({n} seeds): horizon=500 (H), 0.24's default (C), {label}"
        plot_difference_panels(
            panels, list(sets), args.plot, title, n_cols=1, panel_size=(4.5, 3.2)
        )


if __name__ == "__main__":
    main()
