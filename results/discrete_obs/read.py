"""``PLAN.md``'s reading of the discrete-observation screen: each GP critic − SB3's MLP critic
per task, family-wise over those 4 comparisons (Bonferroni), and the geodesic and Laplacian
critics against each other as a secondary reading (its 95 % verdict only; the comparison's pair
is Laplacian − geodesic, the plan's geodesic − Laplacian with the sign turned)::

    python results/discrete_obs/read.py > results/discrete_obs/read.md
    python results/discrete_obs/read.py --rerun > results/discrete_obs/rerun.md
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from sb3_geogp.comparison.report import comparisons_markdown, summary_markdown
from sb3_geogp.comparison.results import comparisons, load_sweeps, summary_rows

HERE = Path(__file__).resolve().parent
#: The pairs PLAN.md reads; the first two make the family of its primary reading.
PAIRS = (("laplacian", "mlp"), ("geodesic", "mlp"), ("laplacian", "geodesic"))


def read(results: list[dict[str, Any]]) -> None:
    rows = [r for r in comparisons(results, family_size=4) if (r["a"], r["b"]) in PAIRS]
    print(summary_markdown(summary_rows(results)))
    print(comparisons_markdown(rows))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--rerun",
        action="store_true",
        help="Taxi-v4's GP critics re-run with 0.34's distances (runs_taxi_0_34), against the "
        "MLP critic's runs of the screen, which no engine change touches",
    )
    args = parser.parse_args()
    results = load_sweeps([HERE / "runs"])
    print("# GP critics on discrete observations: PPO, FrozenLake-v1 and Taxi-v4 (session 66)\n")
    print("Fresh PPO seeds 693-702, 100,000 steps, SB3's PPO defaults with 4 envs (`ppo.yml`).")
    print("Family-wise: Bonferroni over the 4 comparisons GP − MLP (PLAN.md); Laplacian −")
    print("geodesic is secondary, read at 95 % only.\n")
    if args.rerun:
        print("**Taxi-v4 re-run**: the GP critics with the engine of `3928ede0` (distances by")
        print("the matrix product from 32 dimensions), the MLP critic's runs of the screen.\n")
        taxi = [r for r in results if r["spec"]["env_id"] == "Taxi-v4"]
        results = [r for r in taxi if r["spec"]["critic"] == "mlp"]
        results += load_sweeps([HERE / "runs_taxi_0_34"])
    read(results)


if __name__ == "__main__":
    main()
