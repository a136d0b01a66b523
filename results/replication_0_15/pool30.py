"""Issue 13's table pooled over 30 seeds per cell (addendum 1 of PREREGISTRATION.md): the
default critic (PPO: the 0.15 default, Laplacian; A2C: the geodesic default) against SB3's MLP
critic, final return, under the published rule (difference of means, 95 % percentile
bootstrap, family-wise at the published 42 comparisons).

    python results/replication_0_15/pool30.py > results/replication_0_15/pool30.md
    python results/replication_0_15/pool30.py --a2c 0.17 > results/a2c_rare_refits/pool30.md

PPO: seeds 0-9 (`results/shrink_points/s0_9`, MLP `results/compare`), 10-19
(`results/replication_0_15/ppo_s10`, MLP `results/replication_s10/ppo`) and 150-159 (the
pre-registered test of the 0.15 default, `results/shrink_points/s150_*`). A2C: seeds 0-9
(`results/a2c_adaptation/default_s0_9`, MLP `results/compare`), 10-19
(`results/replication_0_15/a2c_s10`) and 20-29 (`results/fresh_0_12/a2c_default`, MLP
`results/replication_s10/a2c`). ``--a2c 0.17`` (session 27) takes the A2C rows from the A2C
default of 0.17 instead (rare refits): seeds 0-9 and 10-19 (`results/a2c_rare_refits/
default_0_17_s0`, `..._s10`, MLP as above) and 30-39 (its pre-registered test,
`results/a2c_rare_refits/candidate_s30`, MLP `mlp_s30`).

``--add`` pools further seed sets of today's defaults (session 31,
`results/table40/PREREGISTRATION.md`): ``fresh40`` the pre-registered fresh sets (PPO seeds
160-169, A2C 70-79), ``a2c_s60`` session 30's A2C seeds 60-69; ``--only-added`` leaves the 30
seeds out; ``--plot`` also draws each cell on the 30 seeds, on the added ones alone and pooled.
The files of `results/table40` (session 32, when its PPO arms had finished):

    python results/replication_0_15/pool30.py --a2c 0.17 --add fresh40 \
        --plot results/table40/pool40.png > results/table40/pool40.md
    python results/replication_0_15/pool30.py --a2c 0.17 --add fresh40 --only-added \
        > results/table40/fresh.md
    python results/replication_0_15/pool30.py --a2c 0.17 --add fresh40 --add a2c_s60  # 50 A2C seeds

``--a2c 0.22`` (session 36, `results/table40_rbf`) takes the A2C rows from 0.22's default (the
RBF kernel) on the 40-seed table's A2C seeds 0-19, 30-39 and 70-79; ``--add ppo160`` adds the
PPO seeds 160-169 alone. `results/table40_rbf/table.py` reads that table.
"""

from __future__ import annotations

import argparse
from typing import Any

from sb3_geogp.comparison.report import plot_difference_panels
from sb3_geogp.comparison.results import comparisons, load_results

#: (folder, algorithm, critic) of every group of runs pooled
SOURCES = (
    ("results/shrink_points/s0_9", "ppo", "laplacian"),
    ("results/compare", "ppo", "mlp"),
    ("results/replication_0_15/ppo_s10", "ppo", "laplacian"),
    ("results/replication_s10/ppo", "ppo", "mlp"),
    ("results/shrink_points/s150_candidate", "ppo", "laplacian"),
    ("results/shrink_points/s150_reference", "ppo", "mlp"),
)
#: The A2C groups by the default they measure.
A2C_SOURCES = {
    "0.16": (
        ("results/a2c_adaptation/default_s0_9", "a2c", "geodesic"),
        ("results/compare", "a2c", "mlp"),
        ("results/replication_0_15/a2c_s10", "a2c", "geodesic"),
        ("results/replication_0_15/a2c_s10", "a2c", "mlp"),
        ("results/fresh_0_12/a2c_default", "a2c", "geodesic"),
        ("results/replication_s10/a2c", "a2c", "mlp"),
    ),
    "0.17": (
        ("results/a2c_rare_refits/default_0_17_s0", "a2c", "geodesic"),
        ("results/compare", "a2c", "mlp"),
        ("results/a2c_rare_refits/default_0_17_s10", "a2c", "geodesic"),
        ("results/replication_0_15/a2c_s10", "a2c", "mlp"),
        ("results/a2c_rare_refits/candidate_s30", "a2c", "geodesic"),
        ("results/a2c_rare_refits/mlp_s30", "a2c", "mlp"),
    ),
    # 0.22's RBF default on the 40-seed table's A2C seeds (results/table40_rbf)
    "0.22": (
        ("results/a2c_rbf/rbf_s0", "a2c", "rbf"),
        ("results/compare", "a2c", "mlp"),
        ("results/table40_rbf/rbf_s10", "a2c", "rbf"),
        ("results/replication_0_15/a2c_s10", "a2c", "mlp"),
        ("results/table40_rbf/rbf_s30", "a2c", "rbf"),
        ("results/a2c_rare_refits/mlp_s30", "a2c", "mlp"),
        ("results/table40_rbf/rbf_s70", "a2c", "rbf"),
        ("results/table40/a2c_mlp_s70", "a2c", "mlp"),
    ),
}
#: Further seed sets of today's defaults, pooled with ``--add``.
ADDED_SOURCES = {
    "fresh40": (
        ("results/table40/ppo_default_s160", "ppo", "laplacian"),
        ("results/table40/ppo_mlp_s160", "ppo", "mlp"),
        ("results/table40/a2c_default_s70", "a2c", "geodesic"),
        ("results/table40/a2c_mlp_s70", "a2c", "mlp"),
    ),
    "ppo160": (
        ("results/table40/ppo_default_s160", "ppo", "laplacian"),
        ("results/table40/ppo_mlp_s160", "ppo", "mlp"),
    ),
    "a2c_s60": (
        ("results/a2c_capped_bonus/default_s60", "a2c", "geodesic"),
        ("results/a2c_capped_bonus/mlp_s60", "a2c", "mlp"),
    ),
}
PUBLISHED_FAMILY = 42


def pooled_runs(
    a2c: str = "0.16", added: tuple[str, ...] = (), only_added: bool = False
) -> list[dict[str, Any]]:
    """The runs of :data:`SOURCES` and of the A2C default ``a2c``'s :data:`A2C_SOURCES` (left
    out with ``only_added``) and of the :data:`ADDED_SOURCES` named in ``added``, each seed of
    a cell and critic once."""
    base = () if only_added else (*SOURCES, *A2C_SOURCES[a2c])
    sources = (*base, *(source for name in added for source in ADDED_SOURCES[name]))
    runs: dict[tuple[str, str, str, int], dict[str, Any]] = {}
    for folder, algo, critic in sources:
        for r in load_results(folder):
            s = r["spec"]
            if (s["algo"], s["critic"]) == (algo, critic):
                key = (s["env_id"], algo, critic, s["seed"])
                assert key not in runs, f"seed {key} twice"
                runs[key] = r
    return list(runs.values())


def mlp_rows(
    runs: list[dict[str, Any]], metric: str = "final_return"
) -> dict[tuple[str, str], dict[str, Any]]:
    """Default critic − MLP on ``metric`` by (env, algo), at the published family size."""
    return {
        (c["env"], c["algo"]): c
        for c in comparisons(runs, family_size=PUBLISHED_FAMILY)
        if c["metric"] == metric and c["b"] == "mlp"
    }


def against_baseline(
    runs: list[dict[str, Any]], baseline: list[dict[str, Any]], metric: str, family: int
) -> dict[tuple[str, str], dict[str, Any]]:
    """``runs`` − ``baseline`` (the same critic in another arm) on ``metric`` by (env, algo),
    family-wise over ``family`` comparisons."""
    return {
        (c["env"], c["algo"]): c
        for c in comparisons(runs, baseline=baseline, family_size=family)
        if c["metric"] == metric
    }


def plot(a2c: str, added: tuple[str, ...], path: str) -> None:
    """Each cell's difference on the 30 seeds, on the added seeds alone and pooled."""
    sets = {
        "30 seeds": mlp_rows(pooled_runs(a2c)),
        "added": mlp_rows(pooled_runs(a2c, added, only_added=True)),
        "pooled": mlp_rows(pooled_runs(a2c, added)),
    }
    cells = sorted(sets["30 seeds"], key=lambda k: (k[1], k[0]))
    rows = [
        {"env": env, "algo": algo, **{name: table.get((env, algo)) for name, table in sets.items()}}
        for env, algo in cells
    ]
    title = f"default GP critic − SB3's MLP critic, final return (+ {', '.join(added)})"
    plot_difference_panels(rows, list(sets), path, title, n_cols=7, panel_size=(2.2, 2.2))


def print_table(
    rows: dict[tuple[str, str], dict[str, Any]],
    metric: str = "final return",
    difference: str = "critic − MLP",
) -> None:
    """Rows like :func:`mlp_rows`'s (on ``metric``, of ``difference``) as a markdown table,
    then the verdicts' counts."""
    print(f"| env | algo | {difference}, {metric} | seeds | verdict (95 %) | family-wise |")
    print("|---|---|---|---|---|---|")
    counts = {"better": 0, "no difference": 0, "worse": 0}
    fw_counts = dict(counts)
    for c in sorted(rows.values(), key=lambda c: (c["algo"], c["env"])):
        diff = f"{c['diff']:+.1f} [{c['low']:+.1f}, {c['high']:+.1f}]"
        seeds = f"{c['n_a']} / {c['n_b']}"
        verdicts = f"{c['verdict']} | {c['fw_verdict']}"
        print(f"| `{c['env']}` | {c['algo']} | {diff} | {seeds} | {verdicts} |")
        counts[c["verdict"]] = counts.get(c["verdict"], 0) + 1
        fw_counts[c["fw_verdict"]] = fw_counts.get(c["fw_verdict"], 0) + 1
    print(f"\ncounts at 95 %: {counts}; family-wise: {fw_counts}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--a2c", choices=sorted(A2C_SOURCES), default="0.16")
    parser.add_argument("--add", choices=sorted(ADDED_SOURCES), action="append", default=[])
    parser.add_argument("--only-added", action="store_true")
    parser.add_argument("--plot", metavar="PNG", help="also draw the 30 seeds, added, pooled")
    args = parser.parse_args()
    if args.plot and not args.add:
        parser.error("--plot draws the added seeds beside the 30: name them with --add")
    print_table(mlp_rows(pooled_runs(args.a2c, tuple(args.add), args.only_added)))
    if args.plot:
        plot(args.a2c, tuple(args.add), args.plot)


if __name__ == "__main__":
    main()
