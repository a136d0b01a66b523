"""``whole_batch=True`` as PPO's default, the second registered test: the reading (session 68).

``PREREGISTRATION.md`` fixes the runs (``run.sh``: ``fit_default`` and ``fit_whole``, seeds
743-782) and the rules read here: the Acrobot-v1 fit by a two-sided Wilcoxon signed-rank test
(p < 0.05, positive paired median), CartPole-v1's and Pendulum-v1's not worse by the same test,
and the first test's (``results/whole_batch``) table rules 2a-c and its check of the untouched
cells against 0.34.1's own default. A partial run decides nothing.

    python results/whole_batch_ranks/read.py > results/whole_batch_ranks/read.md
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

HERE = Path(__file__).resolve().parent
FIRST = load_script(HERE.parent / "whole_batch" / "read.py", "whole_batch")
SEEDS = range(743, 783)
ENVS = ("Acrobot-v1", "CartPole-v1", "Pendulum-v1")
ALPHA = 0.05


def better(diff: np.ndarray | None) -> str:
    """Rule 1's state: the paired differences rise by the rank test."""
    if diff is None:
        return PARTIAL
    rises = FIRST.wilcoxon(diff) < ALPHA and float(np.median(diff)) > 0
    return "holds" if rises else "fails"


def not_worse(diff: np.ndarray | None) -> str:
    """Rule 2's state for one env: the paired differences do not fall by the rank test."""
    if diff is None:
        return PARTIAL
    falls = FIRST.wilcoxon(diff) < ALPHA and float(np.median(diff)) < 0
    return "fails" if falls else "holds"


def untouched() -> str:
    """Rule 4's state: the whole arm's seed-0 runs equal 0.34.1's default's in the cells the
    option cannot touch (MountainCarContinuous against ``check_default/``, the WallMazes
    against the stored runs, which 0.34.1 reproduces there)."""
    check, current = (FIRST.pool_sweeps([FIRST.HERE / f]) for f in ("check", "check_default"))
    published = FIRST.TABLE50.published_and_fresh()
    reference = {**FIRST.seed0_defaults(published), **FIRST.by_env(current)}
    differ = FIRST.differing(check, reference)
    return "holds" if len(check) == len(FIRST.CHECKED) and not differ else f"fails ({differ})"


def pooled_seeds(diffs: dict[tuple[str, str], np.ndarray]) -> None:
    """Secondary: Acrobot-v1's per-rollout differences of both tests' seeds together."""
    ours = diffs.get(("Acrobot-v1", "tail_mean"))
    scores = [FIRST.fit_scores(FIRST.HERE, arm, "Acrobot-v1", "tail_mean", FIRST.FIT_SEEDS)
              for arm in FIRST.ARMS]  # fmt: skip
    if ours is None or any(s is None for s in scores):
        return
    both = np.concatenate([scores[1] - scores[0], ours])
    mean, half = (float(v) for v in FIRST.mean_ci(both, nan_policy="propagate"))
    print(f"Secondary, Acrobot-v1 per rollout, both tests' {len(both)} seeds: whole − default "
          f"{mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}] (95 % t), paired median "
          f"{float(np.median(both)):+.3f}, {int((both > 0).sum())} up / {int((both < 0).sum())} "
          f"down, Wilcoxon p = {FIRST.wilcoxon(both):.2g}\n")  # fmt: skip


def main() -> None:
    primary = "The registered rule reads the per-rollout score's Wilcoxon signed-rank test"
    diffs = FIRST.fit_table(HERE, SEEDS, ENVS, primary)
    pooled_seeds(diffs)
    published = FIRST.TABLE50.published_and_fresh()
    table = FIRST.table(published, "final_return")
    rules = [
        ("1. Acrobot-v1 fit rises (Wilcoxon p < 0.05, median > 0)",
         better(diffs.get(("Acrobot-v1", "tail_mean")))),
        *((f"2. {env} fit not worse (not p < 0.05 with median < 0)",
           not_worse(diffs.get((env, "tail_mean")))) for env in ENVS[1:]),
        *((f"3{text[1:]} (the first test's)", state) for text, state in table),
        ("4. the untouched cells' seed-0 runs equal 0.34.1's default's", untouched()),
    ]  # fmt: skip
    print("## The registered rule\n")
    adopted = "adopt `whole_batch=True` in PPO's default adaptation"
    print(registered_decision(rules, "PPO's default keeps `whole_batch=False`", adopted))


if __name__ == "__main__":
    main()
