"""The reading fixed in PREREGISTRATION.md: 0.25's PPO default (Monte Carlo returns cut after
200 steps) at 100,000 steps on seeds 260-279, against 0.24's (uncut) and SB3's MLP critic, on
CartPole-v1 and Acrobot-v1, the cells of ``../budget100k_0_24`` the cut changes (session 44).

Arms: 0.25 (``H_s<F>``) and 0.24 (``C_s<F>``), both run here; SB3's MLP critic's runs of
``../budget100k_0_24`` (``s<F>``). Only whole blocks of 10 seeds are read (every arm, cell and
seed of the block finished). The helpers are ``results/budget100k_0_23/read.py``'s.

    python results/budget100k_0_25/read.py --plot results/budget100k_0_25/curves.png \\
        > results/budget100k_0_25/read.md
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
R = load_script(HERE.parent / "budget100k_0_23" / "read.py", "budget100k_0_23_read")
POOL30 = load_script(HERE.parent / "replication_0_15" / "pool30.py", "pool30")
ENVS = ("CartPole-v1", "Acrobot-v1")
STUDY = R.Study(
    HERE,
    (260, 270),
    {
        "0.25": ("H_s", "laplacian"),
        "0.24": ("C_s", "laplacian"),
        "MLP": ("../budget100k_0_24/s", "mlp"),
    },
    {"0.25": "tab:purple", "0.24": "tab:green", "MLP": "0.35"},
    ENVS,
)


def main(argv: Sequence[str] | None = None) -> None:
    runs, blocks, figure = R.start(STUDY, argv, __doc__)
    print("**Primary**: 0.25 − 0.24, final return, family-wise over the 2 cells:\n")
    new, old = (list(runs[arm].values()) for arm in ("0.25", "0.24"))
    primary = POOL30.against_baseline(new, old, "final_return", 2)
    R.print_table(primary, "final return", "0.25 − 0.24")
    print("\n0.25 − 0.24 paired by seed (95 % t):\n")
    print(R.paired_header())
    for env in ENVS:
        print(R.paired(runs, "0.25", "0.24", env))
    R.print_against_mlp(runs, ("0.25", "0.24"))
    what = "0.25's default GP critic (cut after 200 steps), 0.24's (uncut), SB3's MLP critic"
    R.finish(STUDY, runs, figure, blocks, what)


if __name__ == "__main__":
    main()
