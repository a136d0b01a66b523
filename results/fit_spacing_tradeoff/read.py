"""PLAN.md's curve (session 78, exploratory): CartPole-v1's critic-fit score per fit spacing,
paired by seed against no spacing (the registered test's ``fit_default``), and the training
benchmark's wall clock where it has run::

    python results/fit_spacing_tradeoff/read.py > results/fit_spacing_tradeoff/read.md
"""

from __future__ import annotations

import json
from pathlib import Path

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RESULTS = HERE.parent
WHOLE = load_script(RESULTS / "whole_batch" / "read.py", "whole_batch")
BENCH = load_script(RESULTS.parent / "examples" / "benchmark_training.py", "benchmark_training")
#: Each spacing's critic-fit runs, relative to ``results/``.
ARMS = {
    2048: f"{HERE.name}/s2048",
    3072: f"{HERE.name}/s3072",
    4096: "fit_spacing/fit_spaced",
}
NONE = "fit_spacing/fit_default"


def main() -> None:
    print("# What the fit spacing trades on PPO CartPole-v1 (PLAN.md, exploratory)\n")
    for spacing, arm in ARMS.items():
        print(f"### fit_spacing={spacing} against no spacing\n")
        names = ("no spacing", str(spacing))
        WHOLE.fit_table(RESULTS, range(10), ("CartPole-v1",), "no rule", (NONE, arm), names)
    bench = HERE / "training.json"
    if bench.exists():
        record = json.loads(bench.read_text())
        print("## Training benchmark\n\n" + record["header"] + "\n")
        print(BENCH.table(record["results"]))


if __name__ == "__main__":
    main()
