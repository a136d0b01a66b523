"""``max_basis=128`` as A2C's GP critic capacity: the registered reading (session 49).

``PREREGISTRATION.md`` fixes the runs (``run.sh``: ``basis128_s<F>``, issue 13's seven A2C cells
with 128 basis vectors) and the rule read here, on seeds 0-19: basis128 − the default's stored
runs not worse at 95 % in any cell, basis128 − SB3's MLP critic not worse family-wise (the
table's 42). The reading is ``results/a2c_feed_every``'s, for this arm. The secondary readings
take every seed finished, whole blocks of ten only. A partial primary sweep decides nothing.

    python results/a2c_basis128/read.py > results/a2c_basis128/read.md
    python results/a2c_basis128/read.py --metric mean_return > results/a2c_basis128/auc.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
FEED_EVERY = load_script(HERE.parent / "a2c_feed_every" / "read.py", "a2c_feed_every_read")
BASIS128 = FEED_EVERY.Arm("basis128", HERE, "adopt `max_basis=128` as A2C's default")


def main() -> None:
    args = FEED_EVERY.arguments(__doc__.split("\n\n")[0])
    FEED_EVERY.reading(BASIS128, "A2C keeps 256 basis vectors", args.metric)


if __name__ == "__main__":
    main()
