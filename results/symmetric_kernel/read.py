"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``), with the check that
its ``full`` predictor equals ``results/additive_kernel``'s::

    python results/symmetric_kernel/read.py --plot results/symmetric_kernel/read.png \\
        > results/symmetric_kernel/read.md
"""

from __future__ import annotations

from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "read.py", "additive_kernel_read")
MODELS = ("full", "mirror", "mirror_learned")
PRIMARY = ("mirror", "full")
SECONDARY = ("mirror_learned", "full")


def main() -> None:
    title = "Acrobot-v1: exact GPs on the newest batch, by mirror weight"
    pairs = (PRIMARY, SECONDARY)
    ADDITIVE.report(__doc__, HERE, MODELS, pairs, weight_note, same_control, title)


def weight_note(runs: ADDITIVE.Runs) -> str:
    weights = [v for s in runs for v in runs[s]["mirror_learned"]["mirror_weight"]]
    return (
        f" The learned mirror weight `w`, quartiles over its fits: {ADDITIVE.quartiles(weights)}."
    )


def same_control(runs: ADDITIVE.Runs) -> str:
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
