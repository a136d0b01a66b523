"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``), with the check that
its ``full`` predictor equals ``results/additive_kernel``'s::

    python results/symmetric_kernel/read.py --plot results/symmetric_kernel/read.png \\
        > results/symmetric_kernel/read.md
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "read.py", "additive_kernel_read")
MODELS = ("full", "mirror", "mirror_learned")
PRIMARY = ("mirror", "full")
SECONDARY = ("mirror_learned", "full")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, default=None)
    args = parser.parse_args()
    runs = ADDITIVE.load(HERE)
    seeds = list(runs)
    tail = ADDITIVE.tables(runs, MODELS, (PRIMARY, SECONDARY), same_control(runs))
    weights = [v for s in seeds for v in runs[s]["mirror_learned"]["mirror_weight"]]
    print(f"\nPrimary ({' − '.join(PRIMARY)}, last 20 %), by PLAN.md's rule: "
          f"**{ADDITIVE.verdict(tail[PRIMARY[0]] - tail[PRIMARY[1]])}** ({len(seeds)} seeds). "
          f"The learned mirror weight `w`, quartiles over its fits: "
          f"{ADDITIVE.quartiles(weights)}.")  # fmt: skip
    if args.plot:
        title = "Acrobot-v1: exact GPs on the newest batch, by mirror weight"
        ADDITIVE.plot(tail, seeds, args.plot, MODELS, title)


def same_control(runs: dict[int, dict[str, dict[str, list[float] | float]]]) -> str:
    """Whether the ``full`` predictor of ``runs`` equals ``results/additive_kernel``'s, in
    words."""
    additive = ADDITIVE.load()
    same = [s for s in runs if s in additive and runs[s]["full"] == additive[s]["full"]]
    return (
        f"`full` equals `results/additive_kernel`'s `full` on {len(same)} of {len(runs)} "
        "seeds (every batch's score to the last digit)."
    )


if __name__ == "__main__":
    main()
