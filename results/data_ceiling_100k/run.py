"""``PLAN.md``: ``results/data_ceiling``'s predictors on Acrobot-v1's batches of 100,000-step
runs, the off-line ones fitted for the tail score's batches only (one call per core)::

    python results/data_ceiling_100k/run.py --steps 100000 --seeds 0 2 4 6 8 \\
        --streams STREAMS --out results/data_ceiling_100k/a
    python results/data_ceiling_100k/run.py --steps 100000 --seeds 1 3 5 7 9 \\
        --streams STREAMS --out results/data_ceiling_100k/b
    python results/data_ceiling_100k/read.py --plot results/data_ceiling_100k/read.png \\
        > results/data_ceiling_100k/read.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
CEILING = load_script(HERE.parent / "data_ceiling" / "run.py", "data_ceiling")


def main() -> None:
    settings = {**CEILING.SETTINGS, "tail_only": True}
    CEILING.RECORDING.run_replays(__doc__, CEILING.replays(tail_only=True), settings, seeded=True)


if __name__ == "__main__":
    main()
