"""The reading fixed in PREREGISTRATION.md: 0.24's PPO default (Monte Carlo targets) at
100,000 steps on fresh seeds 260-279, against 0.23's (SB3's returns) and SB3's MLP critic
(session 42).

Arms: 0.24, the default GP critic fed Monte Carlo returns (``mc_s<F>``, critic
``laplacian``); 0.23, the same fed SB3's returns (``s<F>``); SB3's MLP critic (``s<F>``). Only
whole blocks of 10 seeds are read (every arm, cell and seed of the block finished), so a
partial sweep reads as such. The helpers are ``results/budget100k_0_23/read.py``'s.

    python results/budget100k_0_24/read.py --plot results/budget100k_0_24/curves.png \\
        > results/budget100k_0_24/read.md
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
R = load_script(HERE.parent / "budget100k_0_23" / "read.py", "budget100k_0_23_read")
STUDY = R.Study(
    HERE,
    (260, 270),
    {"0.24": ("mc_s", "laplacian"), "0.23": ("s", "laplacian"), "MLP": ("s", "mlp")},
    {"0.24": "tab:green", "0.23": "tab:blue", "MLP": "0.35"},
)


def main(argv: Sequence[str] | None = None) -> None:
    runs, blocks, figure = R.start(STUDY, argv, __doc__)
    print("**Co-primary**: 0.24 − MLP, final return, family-wise over these 3 cells:\n")
    R.print_table(R.against_mlp(runs, "0.24", "final_return"), "final return", "0.24 − MLP")
    for level, name in ((0.95, "95 %"), (1 - 0.05 / 3, "98.33 %")):
        print(f"\n**Co-primary**: 0.24 − 0.23, paired by seed, {name} t (98.33 %: family-wise):\n")
        print(R.paired_header(name))
        for env in R.ENVS:
            print(R.paired(runs, "0.24", "0.23", env, level))
    print("\nSecondary: 0.23 against the MLP critic, and the area under the curve.\n")
    R.print_table(R.against_mlp(runs, "0.23", "final_return"), "final return", "0.23 − MLP")
    for arm in ("0.24", "0.23"):
        print()
        auc = R.against_mlp(runs, arm, "mean_return")
        R.print_table(auc, "area under the curve", f"{arm} − MLP")
    what = "0.24's default GP critic (Monte Carlo targets), 0.23's (SB3's returns), MLP critic"
    R.finish(STUDY, runs, figure, blocks, what)


if __name__ == "__main__":
    main()
