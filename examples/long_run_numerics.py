"""Long-run numerics soak of SparseOnlineGP (issue 2, "Numerics").

Streams ``--points`` Pendulum-v1 transitions (``pendulum_rollouts`` in chunks with increasing
seeds, fed in batches of 2048 as a PPO rollout buffer would) into one
``SparseOnlineGP(max_basis=256)`` per kernel variant and, after every batch, checks:

* every entry of ``alpha``, ``P``, ``Q`` and of the predictions on a probe set is finite;
* ``P`` and ``Q`` are symmetric: ``max |M - M^T| / max |M| <= --sym-tol``;
* ``P`` and ``Q`` are positive semi-definite: smallest eigenvalue / largest absolute
  eigenvalue ``>= -(--eig-tol)``, or ``>= -100 eps`` of the state's dtype where that is looser
  (a float32 state's own rounding: ``-1.2e-5``);
* the predictive variances on the probe set (a held-out rollout plus random states, some far
  from the data) are ``>= 0`` (``predict`` clamps them, so the eigenvalue check on ``P`` is the
  one with teeth);
* ``n_basis <= max_basis``.

It tracks the out-of-sample MSE and explained variance on the held-out rollout and the
explained variance of each batch just absorbed (does the GP follow the stream?), prints a
summary (worst value of every check per variant, update time, additions and deletions),
writes JSON and a PNG, and exits with status 1 if any check failed or an update raised.

``--stream drift`` feeds a random walk that keeps moving into new regions; ``--stream onehot``
one-hot states of a random walk on a ring of 400 (discrete observations as SB3 encodes them,
more states than the basis holds, distances from the matrix product).

``--time-budget`` stops the stream after the batch during which the budget ran out; the
summary then says how many points every variant received.

Usage::

    python examples/long_run_numerics.py                       # 10^6 points per variant
    python examples/long_run_numerics.py --points 5000000 --time-budget 900 --threads 1
    python examples/long_run_numerics.py --points 20000 --out runs/soak
"""

from __future__ import annotations

import argparse
import json
import math
import operator
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import torch
from tqdm import tqdm

from sb3_geogp import CHEAP_ADAPTATION, Adaptation, SparseOnlineGP
from sb3_geogp.policies import DEFAULT_ADAPTATION, DEFAULT_FORGETTING, LAGGED_ADAPTATION
from sb3_geogp.toolbox.benchmarks import Variant, torch_threads
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg
from sb3_geogp.toolbox.streams import Rollout, drifting_stream, one_hot_stream, pendulum_stream
from sb3_geogp.toolbox.tables import format_table

#: The policy's PPO default critic with the cheaper adaptation preset (0.7).
CHEAP_DEFAULT = {"adapt": CHEAP_ADAPTATION, "novelty_tol": 0.1}
#: The policy's PPO default critic since 0.9: the 0.6 one with a moving level.
LEVEL_DEFAULT = {"adapt": True, "novelty_tol": 0.1, "trend": "level"}
#: The policy's PPO adaptation of 0.23-0.34, before 0.35's whole rollouts in the rebuild.
PRIOR_ADAPTATION = replace(
    DEFAULT_ADAPTATION, whole_batch=False, fit_spacing=None, follow_spread=False
)
#: The policy's PPO adaptation of 0.11-0.22, before 0.23's hyperprior.
WITHOUT_PRIOR = replace(PRIOR_ADAPTATION, prior_sd=None)
#: The policy's PPO default critic of 0.10: 0.9's with its rare refits, the summary folded.
RARE_DEFAULT = {**LEVEL_DEFAULT, "adapt": replace(WITHOUT_PRIOR, summary="fold")}
#: The policy's PPO default critic of 0.11-0.13: the summary from snapshots of the posterior.
SNAPSHOT_DEFAULT = {**LEVEL_DEFAULT, "adapt": WITHOUT_PRIOR}
#: The A2C default's adaptation (a refit every block) with snapshots (an option).
SNAPSHOT_ADAPT = {"adapt": Adaptation(summary="snapshot")}
#: The policy's PPO default critic of 0.15-0.22: 0.13's starting from forgetting 0.1 per 4,096
#: points (:data:`~sb3_geogp.policies.DEFAULT_FORGETTING`).
POINTS_DEFAULT = {**SNAPSHOT_DEFAULT, **DEFAULT_FORGETTING}
#: The policy's PPO default critic of 0.23-0.34: 0.15's with the lengthscale hyperprior.
PRIOR_DEFAULT = {**POINTS_DEFAULT, "adapt": PRIOR_ADAPTATION}
#: The policy's PPO default critic since 0.43 (since 0.35 a refit's rebuild takes the whole
#: batch; since 0.39 a block refits for its fit only 4,096 points after the last refit; since
#: 0.43 a refit widens the data-chosen lengthscales to the window's spread) with a
#: window of 256 points, so that every batch (2,048 points here, 384 in the quick test) is
#: larger than the window, as PPO's 4,096-point rollouts are larger than the default's 2,048.
WIDEN_DEFAULT = {**POINTS_DEFAULT, "adapt": replace(DEFAULT_ADAPTATION, window=256)}
#: The same as the policy's PPO default critic of 0.39-0.42, without the widening.
SPACED_DEFAULT = {
    **POINTS_DEFAULT,
    "adapt": replace(WIDEN_DEFAULT["adapt"], follow_spread=False),
}
#: The same as the policy's PPO default critic of 0.35-0.38, without the spacing either.
WHOLE_DEFAULT = {**POINTS_DEFAULT, "adapt": replace(SPACED_DEFAULT["adapt"], fit_spacing=None)}
#: The policy's PPO default critic of 0.14 (:data:`~sb3_geogp.policies.LAGGED_ADAPTATION`, an
#: option since 0.15): forgetting in the likelihood, chosen one batch ahead, from 0.1 per 4,096
#: points.
LAGGED_DEFAULT = {**POINTS_DEFAULT, "adapt": LAGGED_ADAPTATION}
#: The snapshot summary's variants (0.11), on both streams: 0.11-0.13's PPO default, the 0.15
#: and 0.23 defaults, 0.35's (its batches larger than its window), 0.39's and 0.43's in float64
#: and float32, and the A2C default's adaptation with snapshots;
#: and 0.14's default, whose lagged forgetting score refuses float32.
SNAPSHOT_VARIANTS = (
    Variant("laplacian rare snapshot n0.1 level", "laplacian", {}, SNAPSHOT_DEFAULT),
    Variant("geo laplace interp adapt snapshot", "geodesic", {}, SNAPSHOT_ADAPT),
    Variant("laplacian rare snapshot f0.1/4096 n0.1 level", "laplacian", {}, POINTS_DEFAULT),
    Variant(
        "laplacian rare snapshot f0.1/4096 n0.1 level float32",
        "laplacian",
        {},
        {**POINTS_DEFAULT, "dtype": torch.float32},
    ),
    Variant("laplacian rare snapshot lagged f0.1/4096 n0.1 level", "laplacian", {}, LAGGED_DEFAULT),
    Variant(
        "laplacian rare snapshot prior0.1 f0.1/4096 n0.1 level", "laplacian", {}, PRIOR_DEFAULT
    ),
    Variant(
        "laplacian rare snapshot prior0.1 f0.1/4096 n0.1 level float32",
        "laplacian",
        {},
        {**PRIOR_DEFAULT, "dtype": torch.float32},
    ),
    Variant(
        "laplacian rare snapshot prior0.1 whole window256 f0.1/4096 n0.1 level",
        "laplacian",
        {},
        WHOLE_DEFAULT,
    ),
    Variant(
        "laplacian rare snapshot prior0.1 whole window256 f0.1/4096 n0.1 level float32",
        "laplacian",
        {},
        {**WHOLE_DEFAULT, "dtype": torch.float32},
    ),
    *(
        Variant(
            f"laplacian {widen}spaced4096 whole window256 f0.1/4096 n0.1 level {dtype}",
            "laplacian",
            {},
            {**options, "dtype": getattr(torch, dtype)},
        )
        for widen, options in (("", SPACED_DEFAULT), ("widen ", WIDEN_DEFAULT))
        for dtype in ("float64", "float32")
    ),
)
VARIANTS = {
    "pendulum": (
        Variant("rbf", "rbf"),
        Variant(
            "geo laplace interp", "geodesic", {"profile": "laplacian", "attach": "interpolate"}
        ),
        Variant("geo laplace nearest", "geodesic", {"profile": "laplacian", "attach": "nearest"}),
        Variant("geo gaussian", "geodesic", {"profile": "gaussian"}),
        Variant("geo laplace interp f=0.9", "geodesic", {}, {"forgetting": 0.9}),
        # Every kernel that float32 allows (Kernel.supports_float32).
        Variant("geo laplace interp float32", "geodesic", {}, {"dtype": torch.float32}),
        Variant("laplacian float32", "laplacian", {}, {"dtype": torch.float32}),
        # The adaptive GP (issue 13): hyperparameters, targets and forgetting from the stream.
        Variant("rbf adapt", "rbf", {}, {"adapt": True}),
        Variant("geo laplace interp adapt", "geodesic", {}, {"adapt": True}),
        # The policy's default critic under PPO since 0.6, with the cheaper preset (0.7), with
        # the level (0.9's default) and with rare refits (0.10's).
        Variant("laplacian adapt n0.1", "laplacian", {}, {"adapt": True, "novelty_tol": 0.1}),
        Variant("laplacian cheap n0.1", "laplacian", {}, CHEAP_DEFAULT),
        Variant("laplacian adapt n0.1 level", "laplacian", {}, LEVEL_DEFAULT),
        Variant("laplacian rare n0.1 level", "laplacian", {}, RARE_DEFAULT),
        *SNAPSHOT_VARIANTS,
    ),
    # A full basis facing a stream that keeps moving away from it (issue 11, defect 2).
    "drift": (
        Variant("rbf", "rbf"),
        Variant("geo laplace interp", "geodesic"),
        Variant("geo laplace interp f=0.9", "geodesic", {}, {"forgetting": 0.9}),
        Variant("geo laplace interp adapt", "geodesic", {}, {"adapt": True}),
        Variant("laplacian adapt n0.1", "laplacian", {}, {"adapt": True, "novelty_tol": 0.1}),
        Variant("laplacian cheap n0.1", "laplacian", {}, CHEAP_DEFAULT),
        Variant("laplacian adapt n0.1 level", "laplacian", {}, LEVEL_DEFAULT),
        Variant("laplacian rare n0.1 level", "laplacian", {}, RARE_DEFAULT),
        *SNAPSHOT_VARIANTS,
    ),
    # Discrete observations one-hot (0.34): states repeat exactly, distances from the matrix
    # product (400 columns, more states than the basis holds).
    "onehot": (
        Variant("rbf", "rbf"),
        Variant("geo laplace interp adapt", "geodesic", {}, {"adapt": True}),
        Variant("rbf adapt", "rbf", {}, {"adapt": True}),
        Variant(
            "laplacian rare snapshot prior0.1 f0.1/4096 n0.1 level", "laplacian", {}, PRIOR_DEFAULT
        ),
    ),
}
STREAMS = {"pendulum": pendulum_stream, "drift": drifting_stream, "onehot": one_hot_stream}
#: Held-out rollout seed; the stream uses seeds 1, 2, ...
TEST_SEED = 0


@dataclass(frozen=True)
class Check:
    """One per-batch check: ``value`` must satisfy ``passes(value, limit)``.

    ``worse(a, b)`` tells whether ``a`` is worse than ``b`` (the summary keeps the worst).
    """

    key: str
    limit: float
    passes: Callable[[float, float], bool]
    worse: Callable[[float, float], bool]


#: Multiples of the state's machine epsilon that its eigenvalue checks allow at least.
EPS_FACTOR = 100


def make_checks(sym_tol: float, eig_tol: float, dtype: torch.dtype) -> tuple[Check, ...]:
    """The checks of every batch of a GP whose state is ``dtype``, with their limits."""
    eig_tol = max(eig_tol, EPS_FACTOR * torch.finfo(dtype).eps)
    at_most = (operator.le, operator.gt)
    at_least = (operator.ge, operator.lt)
    return (
        Check("nonfinite", 0.0, *at_most),
        Check("asym_P", sym_tol, *at_most),
        Check("asym_Q", sym_tol, *at_most),
        Check("min_eig_P", -eig_tol, *at_least),
        Check("min_eig_Q", -eig_tol, *at_least),
        Check("min_var", 0.0, *at_least),
        Check("basis_over", 0.0, *at_most),
    )


def relative_asymmetry(M: torch.Tensor) -> float:
    """``max |M - M^T| / max |M|`` (0 for an all-zero matrix)."""
    scale = float(M.abs().max()) if M.numel() else 0.0
    return float((M - M.T).abs().max()) / scale if scale > 0 else 0.0


def relative_min_eigenvalue(M: torch.Tensor) -> float:
    """Smallest eigenvalue of the symmetric part of ``M`` over its largest absolute one."""
    if M.numel() == 0:
        return 0.0
    eig = torch.linalg.eigvalsh(0.5 * (M + M.T))
    scale = float(eig.abs().max())
    return float(eig[0]) / scale if scale > 0 else 0.0


def inspect(gp: SparseOnlineGP, probe: torch.Tensor) -> dict[str, float]:
    """Values of every check for the current state of ``gp``."""
    m = gp.n_basis
    P, Q = gp.P[:m, :m], gp.Q[:m, :m]
    mean, var = gp.predict(probe)
    assert var is not None
    tensors = (gp.alpha[:m], P, Q, mean, var)
    return {
        "nonfinite": float(sum(int((~torch.isfinite(t)).sum()) for t in tensors)),
        "asym_P": relative_asymmetry(P),
        "asym_Q": relative_asymmetry(Q),
        "min_eig_P": relative_min_eigenvalue(P),
        "min_eig_Q": relative_min_eigenvalue(Q),
        "min_var": float(var.min()),
        "basis_over": float(m - gp.max_basis),
    }


@dataclass
class Soak:
    """One variant's model, its running worst values and its history."""

    variant: Variant
    gp: SparseOnlineGP
    checks: tuple[Check, ...]
    worst: dict[str, float] = field(default_factory=dict)
    history: dict[str, list[float]] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)
    points: int = 0
    update_s: float = 0.0
    check_s: float = 0.0
    stopped: bool = False

    def step(self, batch: Rollout, probe: torch.Tensor, test: Rollout) -> None:
        """Absorb ``batch``, run every check and record the out-of-sample error."""
        if self.stopped:
            return
        start = time.perf_counter()
        try:
            batch.feed(self.gp)
        except Exception as err:  # an engine error is a finding, not a crash of the soak
            self.failures.append(f"after {self.points} points: update raised {err!r}")
            self.stopped = True
            return
        elapsed = time.perf_counter() - start
        self.update_s += elapsed
        self.history.setdefault("batch_ms", []).append(1e3 * elapsed)
        self.points += len(batch)
        start = time.perf_counter()
        self.record(inspect(self.gp, probe), test, batch)
        self.check_s += time.perf_counter() - start

    def record(self, values: dict[str, float], test: Rollout, batch: Rollout) -> None:
        """Update worst values, failures and history with one batch's measurements."""
        for check in self.checks:
            value = values[check.key]
            if check.key not in self.worst or check.worse(value, self.worst[check.key]):
                self.worst[check.key] = value
            if not check.passes(value, check.limit):
                self.failures.append(f"after {self.points} points: {check.key} = {value:.3g}")
        mse = self._mse(test)
        row = {
            "points": float(self.points),
            "mse": mse,
            "explained_variance": 1.0 - mse / float(test.y.var()),
            # Whether the GP follows the stream: its fit of the batch it has just absorbed.
            "batch_ev": 1.0 - self._mse(batch) / float(batch.y.var()),
            "n_basis": float(self.gp.n_basis),
            "n_added": float(self.gp.n_added),
            "n_deleted": float(self.gp.n_deleted),
        }
        for key, value in row.items():
            self.history.setdefault(key, []).append(value)

    def _mse(self, data: Rollout) -> float:
        pred = self.gp.predict(data.x, return_var=False)[0].to(data.y.dtype)
        return float(((pred - data.y) ** 2).mean())

    def summary(self) -> dict[str, Any]:
        """Worst values, counters, time and pass/fail of this variant."""
        ev = self.history.get("explained_variance", [math.nan])
        batch_ev = self.history.get("batch_ev", [math.nan])
        batch_ms = self.history.get("batch_ms", [math.nan])
        return {
            "variant": self.variant.label,
            "points": self.points,
            "update_s": self.update_s,
            "us_per_point": 1e6 * self.update_s / max(self.points, 1),
            "median_batch_ms": float(statistics.median(batch_ms)),
            "max_batch_ms": max(batch_ms),
            "check_s": self.check_s,
            "n_basis": self.gp.n_basis,
            "n_added": int(self.gp.n_added),
            "n_deleted": int(self.gp.n_deleted),
            **{f"worst_{k}": v for k, v in self.worst.items()},
            "final_ev": ev[-1],
            "min_ev_2nd_half": min(ev[len(ev) // 2 :]),
            "median_batch_ev_2nd_half": statistics.median(batch_ev[len(batch_ev) // 2 :]),
            "passed": not self.failures,
            "n_failures": len(self.failures),
            "first_failures": self.failures[:5],
        }


def probe_states(test: Rollout, n_random: int, seed: int) -> torch.Tensor:
    """The held-out states plus ``n_random`` uniform pendulum states (|theta_dot| <= 8)."""
    gen = torch.Generator().manual_seed(seed)
    theta = (torch.rand(n_random, generator=gen, dtype=torch.float64) * 2 - 1) * math.pi
    vel = (torch.rand(n_random, generator=gen, dtype=torch.float64) * 2 - 1) * 8.0
    random = torch.stack([theta.cos(), theta.sin(), vel], dim=1)
    return torch.cat([test.x, random])


def plot(soaks: Sequence[Soak], path: Path) -> None:
    """Explained variance, cumulative deletions and time per batch against points streamed."""
    fig, (ax_ev, ax_del, ax_ms) = plt.subplots(1, 3, figsize=(17, 4.5))
    lowest = 1.0
    for soak in soaks:
        h = soak.history
        if not h:
            continue
        ax_ev.plot(h["points"], h["explained_variance"], label=soak.variant.label)
        ax_del.plot(h["points"], h["n_deleted"], label=soak.variant.label)
        ax_ms.plot(h["points"], h["batch_ms"], label=soak.variant.label, lw=0.8)
        lowest = min(lowest, *h["explained_variance"])
    ax_ev.set_ylim(max(lowest, -1.0) - 0.02, 1.01)
    ax_ev.set(
        xlabel="points streamed",
        ylabel="explained variance (held-out rollout)",
        title="out-of-sample fit (axis floored at -1)",
    )
    ax_del.set(xlabel="points streamed", ylabel="basis deletions (cumulative)", title="deletions")
    ax_ms.set(xlabel="points streamed", ylabel="update ms per batch (log)", title="time per batch")
    ax_ms.set_yscale("log")
    for ax in (ax_ev, ax_del, ax_ms):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


SUMMARY_COLUMNS = (
    "variant", "points", "update_s", "median_batch_ms", "max_batch_ms", "n_added", "n_deleted",
    "n_basis",
    "worst_asym_P", "worst_asym_Q", "worst_min_eig_P", "worst_min_eig_Q", "worst_min_var",
    "final_ev", "min_ev_2nd_half", "median_batch_ev_2nd_half", "passed",
)  # fmt: skip


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--points", type=count_arg, default=1_000_000, help="points per variant")
    parser.add_argument("--stream", choices=STREAMS, default="pendulum", help="data stream")
    parser.add_argument("--batch-size", type=int, default=2048)
    parser.add_argument("--max-basis", type=count_arg, default=256)
    parser.add_argument("--sym-tol", type=float, default=1e-10, help="relative asymmetry")
    parser.add_argument("--eig-tol", type=float, default=1e-9, help="relative eigenvalue")
    parser.add_argument("--threads", type=int, default=None, help="torch.set_num_threads")
    parser.add_argument(
        "--time-budget",
        type=float,
        default=None,
        help="stop after this many seconds (a whole batch)",
    )
    parser.add_argument(
        "--variants", nargs="+", default=None, metavar="LABEL", help="only these variants"
    )
    parser.add_argument("--out", type=Path, default=Path("runs/long_run_numerics"))
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> list[Soak]:
    """Stream the data through every variant, checking after every batch."""
    if args.stream == "pendulum":
        test = Rollout.pendulum(args.batch_size, TEST_SEED)
        probe = probe_states(test, 512, TEST_SEED)
    else:  # another walk's first batch: out of sample (drift: once the stream has moved on)
        test = next(STREAMS[args.stream](args.batch_size, args.batch_size, seed=TEST_SEED + 1))
        probe = test.x
    dim = test.x.shape[1]
    variants = [v for v in VARIANTS[args.stream] if not args.variants or v.label in args.variants]
    if not variants:
        raise SystemExit(f"--variants: none of {args.variants} is a variant of {args.stream!r}")
    gps = [v.build(dim, args.max_basis) for v in variants]
    soaks = [
        Soak(v, gp, make_checks(args.sym_tol, args.eig_tol, gp.P.dtype))
        for v, gp in zip(variants, gps, strict=True)
    ]
    deadline = time.perf_counter() + (args.time_budget or math.inf)
    with tqdm(total=args.points, desc="soak", unit="pt", unit_scale=True) as bar:
        for batch in STREAMS[args.stream](args.points, args.batch_size):
            for soak in soaks:
                soak.step(batch, probe, test)
            bar.update(len(batch))
            bar.set_postfix(failures=sum(len(s.failures) for s in soaks))
            if time.perf_counter() > deadline:
                print(f"\n--time-budget reached after {bar.n} points; stopping", flush=True)
                break
    return soaks


def write_results(
    soaks: Sequence[Soak], args: argparse.Namespace, total_s: float, record: dict[str, Any]
) -> bool:
    """Print the summary, write JSON and PNG; returns whether every check passed.

    ``record`` is the :func:`~sb3_geogp.toolbox.provenance.provenance` taken when the run
    started.
    """
    rows = [soak.summary() for soak in soaks]
    passed = all(row["passed"] for row in rows)
    print(format_table(rows, SUMMARY_COLUMNS))
    for row in rows:
        for failure in row["first_failures"]:
            print(f"FAILED {row['variant']}: {failure}")
    limits = {s.variant.label: {c.key: c.limit for c in s.checks} for s in soaks}
    print(f"limits: {limits}; total wall time {total_s:.1f} s")
    print(f"provenance at start: {record}")
    print("all checks passed" if passed else "SOME CHECKS FAILED")
    args.out.mkdir(parents=True, exist_ok=True)
    result = {
        "meta": {
            "points_requested": args.points,
            "points_streamed": max(s.points for s in soaks),
            "stream": args.stream,
            "batch_size": args.batch_size,
            "max_basis": args.max_basis,
            "limits": limits,
            "torch_version": torch.__version__,
            "torch_threads": torch.get_num_threads(),
            "total_s": total_s,
            "provenance": record,
            "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        },
        "all_passed": passed,
        "summary": rows,
        "history": {soak.variant.label: soak.history for soak in soaks},
    }
    (args.out / "long_run_numerics.json").write_text(json.dumps(result, indent=1))
    plot(soaks, args.out / "long_run_numerics.png")
    print(f"wrote {args.out / 'long_run_numerics.json'} and {args.out / 'long_run_numerics.png'}")
    return passed


def main(argv: Sequence[str] | None = None) -> int:
    """Run the soak; returns 0 if every check passed, 1 otherwise."""
    args = parse_args(argv)
    with torch_threads(args.threads):
        print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, {args.points} points")
        record, start = provenance(), time.perf_counter()
        soaks = run(args)
        passed = write_results(soaks, args, time.perf_counter() - start, record)
    return 0 if passed else 1


if __name__ == "__main__":
    raise SystemExit(main())
