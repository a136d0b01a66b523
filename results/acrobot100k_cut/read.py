"""The reading fixed in PREREGISTRATION.md: does 0.25's 200-step cut cost PPO Acrobot-v1 at
100,000 steps? 0.25's default (cut) against 0.24's (uncut) and SB3's MLP critic on fresh seeds
340-369 (session 45).

Arms: 0.25 (``H_s<F>``, critic ``laplacian``), 0.24 (``C_s<F>``) and SB3's MLP critic (``H_s<F>``,
critic ``mlp``). Only whole blocks of 10 seeds are read. The helpers are
``results/budget100k_0_23/read.py``'s; the pool with seeds 260-279 reads ``../budget100k_0_25``.

    python results/acrobot100k_cut/read.py --plot results/acrobot100k_cut/curves.png \\
        > results/acrobot100k_cut/read.md

``--addendum`` reads addendum 1 instead: runs ending at -500 per arm on every fresh seed
(340-429, whole blocks), Fisher's exact test (one-sided, 0.25 more), and the guard 0.24 − 0.25:

    python results/acrobot100k_cut/read.py --addendum \\
        --plot results/acrobot100k_cut/addendum.png > results/acrobot100k_cut/addendum.md
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import scipy.stats as sps

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
R = load_script(HERE.parent / "budget100k_0_23" / "read.py", "budget100k_0_23_read")
POOL30 = load_script(HERE.parent / "replication_0_15" / "pool30.py", "pool30")
EARLIER = load_script(HERE.parent / "budget100k_0_25" / "read.py", "budget100k_0_25_read")
ENVS = ("Acrobot-v1",)
ARMS = {"0.25": ("H_s", "laplacian"), "0.24": ("C_s", "laplacian"), "MLP": ("H_s", "mlp")}
COLOURS = {"0.25": "tab:purple", "0.24": "tab:green", "MLP": "0.35"}
STUDY = R.Study(HERE, (340, 350, 360), ARMS, COLOURS, ENVS)
#: Addendum 1: the two GP arms on every fresh block (no MLP critic from 370 on).
ADDENDUM = R.Study(HERE, tuple(range(340, 430, 10)), {a: ARMS[a] for a in ("0.25", "0.24")},
                   COLOURS, ENVS)  # fmt: skip


def addendum(argv: Sequence[str]) -> None:
    """Addendum 1's primary reading (runs at -500, Fisher one-sided) and guard."""
    runs, blocks, figure = R.start(ADDENDUM, argv, __doc__)
    cut, uncut = (list(runs[arm].values()) for arm in ("0.25", "0.24"))
    frozen = [sum(r["final_return"] <= -500 for r in arm) for arm in (cut, uncut)]
    table = [[frozen[0], len(cut) - frozen[0]], [frozen[1], len(uncut) - frozen[1]]]
    p = sps.fisher_exact(table, alternative="greater").pvalue
    seeds = sorted(s for (_, s), r in runs["0.25"].items() if r["final_return"] <= -500)
    print(f"**Primary**: runs ending at -500, 0.25 {frozen[0]} of {len(cut)} (seeds "
          f"{', '.join(map(str, seeds)) or '–'}), 0.24 {frozen[1]} of {len(uncut)}; Fisher's "
          f"exact p (one-sided, 0.25 more) = {p:.4f}: {'holds' if p < 0.05 else 'fails'}\n")  # fmt: skip
    print("**Guard**: 0.24 − 0.25, final return, not worse at 95 %:\n")
    guard = POOL30.against_baseline(uncut, cut, "final_return", 1)
    R.print_table(guard, "final return", "0.24 − 0.25")
    holds = guard[("Acrobot-v1", "ppo")]["verdict"] != "worse"
    print(f"\nguard: {'holds' if holds else 'fails'}")
    if len(blocks) < len(ADDENDUM.blocks):
        print("\nPARTIAL: not every block has finished; no decision")
    print("\n0.25 − 0.24 paired by seed (95 % t):\n")
    print(R.paired_header())
    print(R.paired(runs, "0.25", "0.24", "Acrobot-v1"))
    R.finish(ADDENDUM, runs, figure, blocks, "0.25's default GP critic (cut) and 0.24's (uncut)")


def main(argv: Sequence[str] | None = None) -> None:
    args = list(sys.argv[1:] if argv is None else argv)
    if "--addendum" in args:
        args.remove("--addendum")
        addendum(args)
        return
    runs, blocks, figure = R.start(STUDY, args, __doc__)
    new, old = (list(runs[arm].values()) for arm in ("0.25", "0.24"))
    print("**Primary**: 0.25 − 0.24, final return (the table's rule, one comparison):\n")
    R.print_table(
        POOL30.against_baseline(new, old, "final_return", 1), "final return", "0.25 − 0.24"
    )
    print("\n0.25 − 0.24 paired by seed (95 % t):\n")
    print(R.paired_header())
    print(R.paired(runs, "0.25", "0.24", "Acrobot-v1"))
    print("\nSecondary: 0.25 − 0.24 on the area under the curve:\n")
    R.print_table(POOL30.against_baseline(new, old, "mean_return", 1), "area under the curve",
                  "0.25 − 0.24")  # fmt: skip
    R.print_against_mlp(runs, ("0.25", "0.24"))
    earlier, _ = R.whole_blocks(EARLIER.STUDY)
    pooled = {arm: [r for (e, _), r in earlier[arm].items() if e == "Acrobot-v1"] + list(runs[arm].values())
              for arm in ("0.25", "0.24")}  # fmt: skip
    print("\nSecondary: 0.25 − 0.24, final return, pooled with seeds 260-279 "
          f"({len(pooled['0.25'])} seeds):\n")  # fmt: skip
    R.print_table(POOL30.against_baseline(pooled["0.25"], pooled["0.24"], "final_return", 1),
                  "final return", "0.25 − 0.24")  # fmt: skip
    what = "0.25's default GP critic (cut after 200 steps), 0.24's (uncut), SB3's MLP critic"
    R.finish(STUDY, runs, figure, blocks, what)


if __name__ == "__main__":
    main()
