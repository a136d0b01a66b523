"""The confirmation of Monte Carlo targets under PPO on fresh seeds 240-259, read as
``PREREGISTRATION.md`` fixes (session 42).

C: PPO's GP critic fed ``GPValueCallback(target="monte_carlo")`` (0.24's default); A: the same
critic fed SB3's returns (0.23's default); SB3's MLP critic; folders ``{C,A,mlp}_{ac,mcc}_sF``
made by ``run.sh``. Final return (or ``--metric mean_return``), difference of means, 95 %
percentile bootstrap; C − A family-wise over the two primary cells (Acrobot-v1, CartPole-v1),
C − MLP family-wise at the published 42 comparisons; the same printing and figure as
``results/ppo_mc_targets/table.py``. Only seeds all three arms have are compared, so a partial
sweep reads on its finished seeds (whole MountainCarContinuous blocks only, by the
registration: ``--first-seeds``).

    python results/ppo_mc_confirm/table.py --plot results/ppo_mc_confirm/table.png \\
        > results/ppo_mc_confirm/table.md
    python results/ppo_mc_confirm/table.py --metric mean_return > results/ppo_mc_confirm/auc.md

``table_ac.md``, ``auc_ac.md`` and ``table_ac.png`` are the same commands with
``--first-seeds`` (no MountainCarContinuous block), written when the Acrobot and CartPole block
(the primary reading, all 20 seeds) had finished and MountainCarContinuous was running.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sb3_geogp.comparison.results import pool_sweeps
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
#: Cells of the primary reading: C − A family-wise over these.
PRIMARY = ("Acrobot-v1", "CartPole-v1")


#: ``results/ppo_mc_targets/table.py``, whose reading this one repeats.
READING = load_script(HERE.parent / "ppo_mc_targets" / "table.py", "ppo_mc_targets")


def arms(first_seeds: tuple[int, ...]) -> tuple[list[dict[str, Any]], ...]:
    """C, A and the MLP critic's runs, each on the seeds all three have (MountainCarContinuous
    from the blocks of ``first_seeds`` only)."""

    def pooled(arm: str) -> list[dict[str, Any]]:
        blocks = ["ac_s240", *(f"mcc_s{f}" for f in first_seeds)]
        return pool_sweeps([d for b in blocks if (d := HERE / f"{arm}_{b}").is_dir()])

    return READING.TABLE40.on_common_seeds(pooled("C"), pooled("A"), pooled("mlp"))


def main() -> None:
    parser = READING.TABLE40.reading_parser(__doc__, "C", verdict=False)
    parser.add_argument(
        "--first-seeds",
        type=int,
        nargs="*",
        default=[240, 250],
        help="MountainCarContinuous blocks to read (whole blocks all three arms finished)",
    )
    args = parser.parse_args()
    mc, returns, mlp = arms(tuple(args.first_seeds))
    READING.report(mc, returns, mlp, args.metric, len(PRIMARY), args.plot, a_name="SB3's returns")


if __name__ == "__main__":
    main()
