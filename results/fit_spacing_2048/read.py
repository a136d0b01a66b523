"""PREREGISTRATION.md's reading (session 78): ``fit_spacing=2048`` against 0.39's default
(4,096)::

    python results/fit_spacing_2048/read.py > results/fit_spacing_2048/read.md

Rules 1-2: the critic-fit score on fresh seeds 1003-1022 (``fit_default/``, ``fit_2048/``).
Rule 3: issue 13's table with the 2,048 arm's runs (``table/``) in place of 0.39's default
(``results/fit_spacing/table``) in the seven PPO cells, read by ``results/fit_spacing``'s
functions. A rule whose runs have not all finished stays partial. Rule 1 failed on its finished
runs, the table's sweep was stopped (its runs could not change the decision), and, after the
decision, ``fit_none/`` added 0.38's critic (no spacing) on the same seeds (exploratory).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.tables import PARTIAL, registered_decision

HERE = Path(__file__).resolve().parent
SPACING = load_script(HERE.parent / "fit_spacing" / "read.py", "fit_spacing")
TABLE = SPACING.TABLE
WHOLE = TABLE.WHOLE
NAMES = ("2048", "0.39's default")
SEEDS = range(1003, 1023)


def fit_rules() -> list[tuple[str, str]]:
    """Print the critic-fit table; return rules 1 and 2."""
    note = "rules 1 and 2 read the per-rollout rows"
    diffs = WHOLE.fit_table(HERE, SEEDS, ("CartPole-v1", "Acrobot-v1"), note,
                            ("fit_default", "fit_2048"), NAMES[::-1])  # fmt: skip
    cartpole, acrobot = (diffs.get((env, "tail_mean")) for env in ("CartPole-v1", "Acrobot-v1"))
    rule1 = rule2 = PARTIAL
    if cartpole is not None:
        p, median = WHOLE.wilcoxon(cartpole), float(np.median(cartpole))
        rule1 = "holds" if p < 0.05 and median > 0 else f"fails (p = {p:.2g}, median {median:+.3f})"
    if acrobot is not None:
        mean, half = (float(v) for v in mean_ci(acrobot, nan_policy="propagate"))
        rule2 = (
            "holds"
            if mean + half > 0
            else f"fails ({mean:+.3f} [{mean - half:+.3f}, {mean + half:+.3f}])"
        )
    return [
        ("1. CartPole-v1's fit better (Wilcoxon p < 0.05, positive median)", rule1),
        ("2. Acrobot-v1's fit not worse (95 % t interval's upper end above 0)", rule2),
    ]


def main() -> None:
    states = fit_rules()
    table = SPACING.table_rules(SPACING.today_spaced(), TABLE.drift_runs(HERE / "table"), NAMES)
    states += table or [("3. issue 13's table (no cell finished)", PARTIAL)]
    print("\n## The registered rule\n")
    kept = "0.39's default stays (fit_spacing=4096)"
    print(registered_decision(states, kept, "adopt `fit_spacing=2048` in PPO's default adaptation"))
    after_the_decision()


def after_the_decision() -> None:
    """Exploratory, run after rule 1 failed: 0.38's critic (no spacing, ``fit_none/``) on the
    same fresh seeds, against 0.39's default and against 2,048."""
    if not (HERE / "fit_none").is_dir():
        return
    print("\n## After the decision (exploratory): no spacing on the same fresh seeds\n")
    note = "exploratory, after the decision"
    envs = ("CartPole-v1", "Acrobot-v1")
    for arm, name in (("fit_default", "4096"), ("fit_2048", "2048")):
        WHOLE.fit_table(HERE, SEEDS, envs, note, ("fit_none", arm), ("no spacing", name))


if __name__ == "__main__":
    main()
