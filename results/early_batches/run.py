"""``PLAN.md``: the PPO default's on-line critic replayed with its window widened, on the
streams ``results/actor_features/run.py`` recorded into ``STREAMS``::

    python results/early_batches/run.py --streams STREAMS --out results/early_batches/runs
    python results/early_batches/run.py --read results/early_batches/runs \\
        > results/early_batches/read.md
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from sb3_geogp.comparison.run import write_json_atomic
from sb3_geogp.policies import DEFAULT_ADAPTATION
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import mean_ci

HERE = Path(__file__).resolve().parent
RECORDING = load_script(HERE.parent / "actor_features" / "run.py", "recording")
SCHEDULE = RECORDING.SCHEDULE
SEEDS = range(10)
SETTINGS: dict[str, dict[str, Any]] = {
    "default": RECORDING.RECORDED,
    "default, settings explicit (control)": {
        **RECORDING.RECORDED,
        **DEFAULT_ADAPTATION.as_dict(),
    },
    # interval unset means half the window: 8,192 points here, so the first batch closes no
    # block and is never refitted or rebuilt (PLAN.md's addendum: the first run's fault)
    "window 16384": {**RECORDING.RECORDED, **DEFAULT_ADAPTATION.as_dict(), "window": 16384},
    "window 16384, interval 1024": {
        **RECORDING.RECORDED,
        **DEFAULT_ADAPTATION.as_dict(),
        "window": 16384,
        "interval": DEFAULT_ADAPTATION.block,
    },
}


def run(streams: Path, out: Path) -> None:
    results: dict[int, Any] = {}
    for seed in tqdm(SEEDS, desc="seeds"):
        batches, _ = RECORDING.record(seed, streams)
        results[seed] = {
            name: SCHEDULE.replay(RECORDING.ENV, seed, batches, setting)
            for name, setting in SETTINGS.items()
        }
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "results.json", {"results": results, "provenance": provenance()})


def read(folder: Path) -> str:
    by_seed = json.loads((folder / "results.json").read_text())["results"]
    lines = [
        "| setting | batch 1, median | batch 1, mean | all scored batches | last 20 % |",
        "|---|---:|---:|---:|---:|",
    ]
    for name in SETTINGS:
        scores = [r[name]["explained_variance"] for r in by_seed.values()]
        first = [s[0] for s in scores]
        every = np.mean([np.mean(s) for s in scores])
        tail = np.mean([r[name]["tail"] for r in by_seed.values()])
        lines.append(
            f"| {name} | {np.median(first):.3f} | {np.mean(first):.3f} | {every:.3f} | {tail:.3f} |"
        )
    lines += [
        "",
        "| − default, paired by seed [95 % t] | batch 1 | all scored batches | last 20 % |",
    ]
    lines.append("|---|---:|---:|---:|")
    for name in ("window 16384", "window 16384, interval 1024"):
        cells = []
        for of in (
            lambda r: r["explained_variance"][0],
            lambda r: float(np.mean(r["explained_variance"])),
            lambda r: r["tail"],
        ):
            diff = np.array([of(r[name]) - of(r["default"]) for r in by_seed.values()])
            mean, half = (float(v) for v in mean_ci(diff, nan_policy="propagate"))
            cells.append(f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}]")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    same = all(
        r["default"]["explained_variance"]
        == r["default, settings explicit (control)"]["explained_variance"]
        for r in by_seed.values()
    )
    lines += ["", f"Control equal to the default's replay in every seed and batch: {same}.", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--streams", type=Path)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--read", type=Path, default=None, help="a run's folder to read")
    args = parser.parse_args()
    if args.read is not None:
        print(read(args.read))
    else:
        run(args.streams, args.out)


if __name__ == "__main__":
    main()
