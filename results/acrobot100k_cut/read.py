"""The reading fixed in PREREGISTRATION.md: does 0.25's 200-step cut cost PPO Acrobot-v1 at
100,000 steps? 0.25's default (cut) against 0.24's (uncut) and SB3's MLP critic on fresh seeds
340-369 (session 45).

Arms: 0.25 (``H_s<F>``, critic ``laplacian``), 0.24 (``C_s<F>``) and SB3's MLP critic (``H_s<F>``,
critic ``mlp``). Only whole blocks of 10 seeds are read. The helpers are
``results/budget100k_0_23/read.py``'s; the pool with seeds 260-279 reads ``../budget100k_0_25``.

    python results/acrobot100k_cut/read.py --plot results/acrobot100k_cut/curves.png \\
        > results/acrobot100k_cut/read.md
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
R = load_script(HERE.parent / "budget100k_0_23" / "read.py", "budget100k_0_23_read")
POOL30 = load_script(HERE.parent / "replication_0_15" / "pool30.py", "pool30")
EARLIER = load_script(HERE.parent / "budget100k_0_25" / "read.py", "budget100k_0_25_read")
ENVS = ("Acrobot-v1",)
ARMS = {"0.25": ("H_s", "laplacian"), "0.24": ("C_s", "laplacian"), "MLP": ("H_s", "mlp")}
COLOURS = {"0.25": "tab:purple", "0.24": "tab:green", "MLP": "0.35"}
STUDY = R.Study(HERE, (340, 350, 360), ARMS, COLOURS, ENVS)


def main(argv: Sequence[str] | None = None) -> None:
    runs, blocks, figure = R.start(STUDY, argv, __doc__)
    new, old = (list(runs[arm].values()) for arm in ("0.25", "0.24"))
    print("**Primary**: 0.25 − 0.24, final return (the table's rule, one comparison):\n")
    R.print_table(POOL30.against_baseline(new, old, "final_return", 1), "final return", "0.25 − 0.24")
    print("\n0.25 − 0.24 paired by seed (95 % t):\n")
    print(R.paired_header())
    print(R.paired(runs, "0.25", "0.24", "Acrobot-v1"))
    print("\nSecondary: 0.25 − 0.24 on the area under the curve:\n")
    R.print_table(POOL30.against_baseline(new, old, "mean_return", 1), "area under the curve",
                  "0.25 − 0.24")  # fmt: skip
    for arm in ("0.25", "0.24"):
        for metric, label in (("final_return", "final return"), ("mean_return", "area under the curve")):
            print(f"\nSecondary: {arm} − MLP, {label}, family-wise at the published 42:\n")
            mlp = POOL30.mlp_rows(list(runs[arm].values()) + list(runs["MLP"].values()), metric)
            R.print_table(mlp, label, f"{arm} − MLP")
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
