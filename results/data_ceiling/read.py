"""``PLAN.md``'s reading of ``run.py``'s results (folders ``a`` and ``b``)::

    python results/data_ceiling/read.py --plot results/data_ceiling/read.png \\
        > results/data_ceiling/read.md
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
ADDITIVE = load_script(HERE.parent / "additive_kernel" / "read.py", "additive_kernel_read")
MODELS = ("mlp_ppo", "online", "gbt_newest", "gbt_all", "mlp_all")
PAIRS = tuple((m, "online") for m in MODELS if m != "online")
OFFLINE = ("gbt_newest", "gbt_all", "mlp_all")


def best_note(runs: ADDITIVE.Runs) -> str:
    """The best off-line predictor per seed, chosen after seeing the scores (an upper bound)."""
    best = np.array([max(runs[s][m]["tail"] for m in OFFLINE) for s in runs])
    return (
        f"The best off-line predictor of each seed, chosen after seeing the scores (so biased "
        f"upwards): {best.mean():.3f} [{best.min():.2f}, {best.max():.2f}], seeds at 0.9: "
        f"{int((best >= 0.9).sum())} of {len(best)} (descriptive, PLAN.md: no rule). "
        "`mlp_ppo − online` is SB3's MLP critic against the drop-in GP critic on the same "
        "batches."
    )


def main(doc: str = __doc__, folder: Path = HERE, steps: str = "30,000") -> None:
    """Read the runs in ``folder`` (``doc``: its script's docstring; ``steps``: their length)."""
    ADDITIVE.report(
        doc,
        folder,
        MODELS,
        PAIRS,
        best_note,
        title=f"Acrobot-v1, {steps} steps: predictors of the next batch's returns",
        predicted_by="the predictors of PLAN.md, fitted to the batches before it",
        rule=False,
        steps=steps,
    )


if __name__ == "__main__":
    main()
