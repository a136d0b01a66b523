"""The rule's untested middle: PPO Acrobot-v1 at ``gamma`` 0.999 (session 45, exploratory).

0.26 cuts PPO's Monte Carlo returns after 200 steps where ``gamma ** 200 >= 0.5``; the tasks
measured had 0.13 (Acrobot, ``gamma`` 0.99, frozen runs) and 0.98 (MountainCarContinuous,
0.9999, a gain). Many zoo configurations use ``gamma`` 0.999 (weight 0.82, cut by the rule).
This screen runs Acrobot with the zoo's hyperparameters but ``gamma`` 0.999, 100,000 steps, on
fresh PPO seeds 430-449, with the default feed (cut) and uncut returns: do cut runs freeze
there too? A screen on 20 seeds, not a test; no default changes on it.

    python results/acrobot100k_cut/gamma999.py > results/acrobot100k_cut/gamma999.md

``--registered`` runs and reads addendum 2 of PREREGISTRATION.md (session 46): the same two
arms on fresh seeds 450-489, its primary reading (uncut − cut, final return, 95 % percentile
bootstrap), the runs ending at -500 with Fisher's exact test (one-sided, cut more), the two
arms paired by seed, and the 60 seeds pooled with the screen's (reported, not decided on):

    python results/acrobot100k_cut/gamma999.py --registered \\
        > results/acrobot100k_cut/gamma999_registered.md

``--trace SEED`` re-runs one seed under both arms exactly as above with ``trace.py``'s
recorder (exploratory: did its training episodes ever reach the goal, did its advantages stop):

    python results/acrobot100k_cut/gamma999.py --trace 475 \\
        > results/acrobot100k_cut/gamma999_trace.md
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import scipy.stats as sps

from sb3_geogp.comparison.run import result_path, run_one
from sb3_geogp.comparison.specs import RunSpec, SweepConfig, fed
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import difference_ci, mean_ci

HERE = Path(__file__).resolve().parent
OUT = HERE / "gamma999"
SEEDS = tuple(range(430, 450))
#: Addendum 2's fresh seeds (session 46).
REGISTERED = tuple(range(450, 490))
GAMMA = 0.999
ARMS = {"cut (0.26 default)": None, "uncut": "monte_carlo"}


def specs(target: str | None, seeds: tuple[int, ...]) -> list[RunSpec]:
    config = SweepConfig(
        algos=("ppo",), critics=("laplacian",), envs=("Acrobot-v1",), seeds=seeds,
        timesteps=100_000, target=target,  # type: ignore[arg-type]
    )  # fmt: skip
    out = []
    for spec in config.specs():
        spec = dataclasses.replace(spec, hyperparams={**spec.hyperparams, "gamma": GAMMA})
        if target is None:  # the default feed at this discount, as GPValueCallback resolves it
            feed, horizon = fed(None, None, "ppo", "laplacian", GAMMA)
            spec = dataclasses.replace(spec, target=feed, horizon=horizon)
        out.append(spec)
    return out


def run(args: tuple[RunSpec, str]) -> dict[str, Any]:
    spec, folder = args
    path = result_path(OUT / folder, spec)
    if path.exists():  # resumed
        return json.loads(path.read_text())
    return run_one(spec, OUT / folder)


def finals(runs: list[dict[str, Any]]) -> np.ndarray:
    return np.array([r["final_return"] for r in runs])


def arms(seeds: tuple[int, ...]) -> dict[str, list[dict[str, Any]]]:
    """Each arm's runs on ``seeds``, in seed order (made first where missing)."""
    jobs = [(s, name.split()[0]) for name, t in ARMS.items() for s in specs(t, seeds)]
    with ProcessPoolExecutor(2) as pool:
        results = list(pool.map(run, jobs))
    return {name: [r for r, (_, f) in zip(results, jobs, strict=True) if f == name.split()[0]]
            for name in ARMS}  # fmt: skip


def print_arms(by_arm: dict[str, list[dict[str, Any]]], seeds: tuple[int, ...]) -> None:
    print(f"PPO Acrobot-v1, gamma {GAMMA}, 100,000 steps, seeds {seeds[0]}-{seeds[-1]}\n")
    print("| feed | mean final return | runs ending at -500 | all-zero warning |")
    print("|---|---:|---:|---:|")
    for name, runs in by_arm.items():
        final = finals(runs)
        warned = sum(any("is exactly 0" in w for w in r["warnings"]) for r in runs)
        print(f"| {name} | {final.mean():.1f} | {int((final <= -500).sum())} of {len(runs)} | "
              f"{warned} |")  # fmt: skip


def print_difference(by_arm: dict[str, list[dict[str, Any]]], label: str) -> None:
    estimate, lo, hi = difference_ci(*(finals(by_arm[a]) for a in ("uncut", "cut (0.26 default)")))
    verdict = "better" if lo > 0 else "worse" if hi < 0 else "no difference"
    print(f"\n{label}uncut − cut, final return: {estimate:+.1f} [{lo:+.1f}, {hi:+.1f}] "
          f"(95 % percentile bootstrap of the difference of means): {verdict}")  # fmt: skip


def registered() -> None:
    """Addendum 2: the primary reading, then the secondary ones."""
    by_arm = arms(REGISTERED)
    print_arms(by_arm, REGISTERED)
    print_difference(by_arm, "**Primary**: ")
    cut, uncut = (finals(by_arm[a]) for a in ARMS)
    frozen = [int((f <= -500).sum()) for f in (cut, uncut)]
    table = [[frozen[0], len(cut) - frozen[0]], [frozen[1], len(uncut) - frozen[1]]]
    p = sps.fisher_exact(table, alternative="greater").pvalue
    print(f"\nRuns ending at -500: cut {frozen[0]} of {len(cut)}, uncut {frozen[1]} of "
          f"{len(uncut)}; Fisher's exact p (one-sided, cut more) = {p:.4f}")  # fmt: skip
    mean, half = (float(v) for v in mean_ci(uncut - cut, nan_policy="propagate"))
    print(f"\nuncut − cut paired by seed: {mean:+.1f} "
          f"[{mean - half:+.1f}, {mean + half:+.1f}] (95 % t); "
          f"medians {np.median(uncut):.1f} (uncut), {np.median(cut):.1f} (cut)")  # fmt: skip
    screen = arms(SEEDS)
    pooled = {a: screen[a] + by_arm[a] for a in ARMS}
    print_difference(pooled, f"Pooled with the screen (seeds {SEEDS[0]}-{REGISTERED[-1]}): ")


def trace(seed: int) -> None:
    """Both arms of one seed, re-run with ``trace.py``'s recorder (which changes nothing)."""
    recorder = load_script(HERE / "trace.py", "acrobot100k_cut_trace")
    print(f"PPO Acrobot-v1, gamma {GAMMA}, 100,000 steps, seed {seed}, re-run with a recorder\n")
    print("| feed | final return (stored run) | first rollout with a goal | goals in training | "
          "advantages all equal from | advantage spread, rollouts 2-4 |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---|")
    for name, target in ARMS.items():
        (spec,) = specs(target, (seed,))
        rows = recorder.Trace()
        with tempfile.TemporaryDirectory() as out:
            final = run_one(spec, out, recorders=[rows])["final_return"]
        stored = json.loads(result_path(OUT / name.split()[0], spec).read_text())["final_return"]
        early = ", ".join(f"{r['advantage_sd']:.3g}" for r in rows.rows[1:4])
        print(f"| {name} | {final:.1f} ({stored:.1f}) | "
              f"{recorder.first(rows.rows, lambda r: r['goals'] > 0)} | "
              f"{sum(r['goals'] for r in rows.rows)} | {recorder.frozen_from(rows.rows)} | "
              f"{early} |")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--registered", action="store_true", help="addendum 2's test")
    parser.add_argument("--trace", type=int, metavar="SEED", help="trace one seed's two runs")
    args = parser.parse_args()
    if args.trace is not None:
        trace(args.trace)
        return
    if args.registered:
        registered()
        return
    by_arm = arms(SEEDS)
    print_arms(by_arm, SEEDS)
    print_difference(by_arm, "")


if __name__ == "__main__":
    main()
