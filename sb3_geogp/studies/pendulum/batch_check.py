"""Fixed-policy value estimation: the on-line adaptive GP against a batch sparse GP (issue 13).

On the paper pendulum (:mod:`~sb3_geogp.studies.pendulum.task`), per seed, kernel and basis
capacity ``max_basis``:

1. **On-line.** One pass of a :class:`~sb3_geogp.SparseOnlineGP` with ``adapt=True``
   (:class:`~sb3_geogp.adaptation.Adaptation`'s defaults) over the whole stream of episodes,
   a few dozen episodes per :meth:`~sb3_geogp.SparseOnlineGP.update` as a critic sees
   rollouts; for context, the same pass without adaptation.
2. **Batch** (:func:`batch_sparse_gp`). A sparse GP on *all* the stream's points at once, with
   the adaptive GP's final basis vectors as inducing points and hyperparameters maximising
   the collapsed variational bound (Titsias 2009, the DTC / VFE marginal likelihood) of all
   the data, by L-BFGS; prediction by the DTC posterior mean.
3. **Score.** Mean squared error of each against the Monte Carlo value on the evaluation grid
   (:func:`~sb3_geogp.studies.pendulum.ground_truth.mc_value`), and the ratio
   ``MSE(on-line) / MSE(batch)`` per seed; summaries are geometric means over seeds with
   Student-t intervals of the mean log ratio.

The batch GP is the reference an on-line sparse GP can at best reach with the same basis: same
inducing inputs, same covariance function (the on-line GP's kernel, through
:meth:`~sb3_geogp.kernels.Kernel.correlation_fn`; for the geodesic kernel that is the on-line
GP's basis-vector tree with its Shepard attachment), but every point seen at once and the
hyperparameters at the optimum of the bound on all of them. The on-line GP instead keeps only
its last ``Adaptation.window`` points in its posterior after each adaptation and takes a few
Adam steps per block.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import torch
from scipy import optimize
from torch import Tensor

from sb3_geogp.adaptation import Adaptation, Projection
from sb3_geogp.kernels import Kernel, KernelName
from sb3_geogp.sparse_gp import SparseOnlineGP
from sb3_geogp.studies.pendulum.ground_truth import GridValue, mc_value
from sb3_geogp.studies.pendulum.task import EpisodeData, Task, policy_episodes
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.streams import episode_batches
from sb3_geogp.toolbox.tables import estimate_cell, markdown_table

#: The on-line GPs of a row: with adaptation (the subject) and without (context).
ONLINE = ("adaptive", "default")
#: Bounds of the batch fit's log-parameters: lengthscale factors (relative to the on-line
#: GP's final lengthscales), signal and noise variance (standardised targets).
FACTOR_BOUNDS = (1e-3, 1e3)
VARIANCE_BOUNDS = (1e-3, 1e3)
NOISE_BOUNDS = (1e-6, 10.0)


@dataclass(frozen=True)
class Hyper:
    """Hyperparameters of :func:`batch_sparse_gp` (a start, or the optimum).

    Attributes
    ----------
    factor : tuple of float
        Lengthscale factors relative to the kernel's lengthscales (one per dimension, or one
        for all with ``GeodesicKernel(ard=False)``: ``correlation_fn``'s ``n_factors``).
    variance : float
        Signal variance, standardised targets.
    noise_var : float
        Noise variance, standardised targets.
    """

    factor: tuple[float, ...] = (1.0,)
    variance: float = 1.0
    noise_var: float = 0.05


@dataclass
class BatchFit:
    """A fitted batch sparse GP (:func:`batch_sparse_gp`).

    Attributes
    ----------
    mean : ndarray, shape (n_eval,)
        Posterior mean at the evaluation inputs, in target units.
    hyper : Hyper
        The hyperparameters found (the best start's optimum).
    lengthscale : ndarray, shape (d,)
        The kernel's lengthscales times the fitted factors, input units.
    bound : float
        Negative collapsed bound per point at ``hyper`` (standardised targets); the negative
        log marginal likelihood per point when every point is an inducing point.
    evaluations : int
        Bound evaluations over all starts.
    converged : bool
        Whether L-BFGS reported convergence for the best start.
    """

    mean: np.ndarray
    hyper: Hyper
    lengthscale: np.ndarray
    bound: float
    evaluations: int
    converged: bool


def batch_sparse_gp(
    kernel: Kernel,
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray | Tensor,
    x_eval: np.ndarray,
    starts: Sequence[Hyper] = (Hyper(),),
    max_iter: int = 200,
    jitter: float = 1e-6,
) -> BatchFit:
    """Batch DTC / VFE sparse GP on all of ``(x, y)`` with inducing inputs ``z``.

    Targets are standardised by their mean and standard deviation. From each start, L-BFGS-B
    (scipy, gradients by torch) minimises the negative collapsed bound per point
    (:meth:`~sb3_geogp.adaptation.Projection.negative_bound`, ``k(x, x) = sigma_f^2`` on the
    diagonal) over the log lengthscale factors, the log signal and the log noise variance,
    within :data:`FACTOR_BOUNDS`, :data:`VARIANCE_BOUNDS`, :data:`NOISE_BOUNDS`. The best
    optimum gives the posterior (:meth:`~sb3_geogp.adaptation.Projection.posterior`).

    Parameters
    ----------
    kernel : Kernel
        Only its :meth:`~sb3_geogp.kernels.Kernel.correlation_fn` is used (and its
        lengthscales, the reference of the factors); it is not changed. For the geodesic
        kernel ``z`` must be its GP's basis inputs, in order (its tree is over them).
    x : ndarray, shape (n, d)
    y : ndarray, shape (n,)
    z : ndarray or Tensor, shape (m, d)
        Inducing inputs.
    x_eval : ndarray, shape (n_eval, d)
        Where to predict.
    starts : sequence of Hyper
        Starting points (each ``factor`` of ``n_factors`` entries, or one for all).
    max_iter : int
        L-BFGS iterations per start; 0 evaluates the bound and the posterior at the first
        start.
    jitter : float
        Added to the diagonal of the inducing points' correlation matrix (relative to the
        signal variance), so that close inducing points keep the objective smooth.

    Returns
    -------
    BatchFit
    """
    xt, zt = torch.as_tensor(x, dtype=torch.float64), torch.as_tensor(z, dtype=torch.float64)
    yt = torch.as_tensor(y, dtype=torch.float64)
    y_mean, y_std = float(yt.mean()), float(yt.std())
    yn = (yt - y_mean) / y_std
    n_f, correlations = kernel.correlation_fn(xt, zt)
    _, eval_correlations = kernel.correlation_fn(torch.as_tensor(x_eval, dtype=torch.float64), zt)
    eye = torch.eye(zt.shape[0], dtype=torch.float64)
    ones = torch.ones_like(yn)

    def projection(p: Tensor) -> Projection:
        R_xz, R_zz = correlations(p[:n_f])
        var = p[n_f].exp()
        return Projection(var * (R_zz + jitter * eye), var * R_xz, float(var.detach()))

    def negative_bound(p: Tensor) -> Tensor:
        var = p[n_f].exp()
        return projection(p).negative_bound(yn, p[n_f + 1].exp() * ones, var * ones)

    def value_and_grad(v: np.ndarray) -> tuple[float, np.ndarray]:
        p = torch.tensor(v, dtype=torch.float64, requires_grad=True)
        loss = negative_bound(p)
        (grad,) = torch.autograd.grad(loss, p)
        return float(loss.detach()), grad.numpy()

    limits = [FACTOR_BOUNDS] * n_f + [VARIANCE_BOUNDS, NOISE_BOUNDS]
    bounds = [(math.log(lo), math.log(hi)) for lo, hi in limits]

    def start_vector(start: Hyper) -> np.ndarray:
        factor = np.broadcast_to(np.asarray(start.factor, dtype=np.float64), (n_f,))
        v0 = np.concatenate([np.log(factor), np.log([start.variance, start.noise_var])])
        return np.clip(v0, *np.transpose(bounds))

    if max_iter == 0:
        v0 = start_vector(starts[0])
        optima, evaluations = [(value_and_grad(v0)[0], v0, True)], 1
    else:
        options = {"maxiter": max_iter}
        results = [
            optimize.minimize(
                value_and_grad,
                start_vector(s),
                jac=True,
                method="L-BFGS-B",
                bounds=bounds,
                options=options,
            )
            for s in starts
        ]
        optima = [(float(r.fun), r.x, bool(r.success)) for r in results]
        evaluations = sum(int(r.nfev) for r in results)
    bound, v, converged = min(optima, key=lambda optimum: optimum[0])
    p = torch.as_tensor(v, dtype=torch.float64)
    with torch.no_grad():
        proj = projection(p)
        alpha, _ = proj.posterior(yn, p[n_f + 1].exp() * ones)
        R_ez, _ = eval_correlations(p[:n_f])
        mean = (p[n_f].exp() * R_ez @ alpha) * y_std + y_mean
    factor = np.exp(v[:n_f])
    return BatchFit(
        mean=mean.numpy(),
        hyper=Hyper(tuple(factor.tolist()), float(np.exp(v[n_f])), float(np.exp(v[n_f + 1]))),
        lengthscale=kernel.lengthscale.numpy() * factor,
        bound=bound,
        evaluations=evaluations,
        converged=converged,
    )


@dataclass(frozen=True)
class CheckConfig:
    """What defines a run of the check (the full run's defaults; :meth:`quick` for a smoke run).

    Attributes
    ----------
    max_basis : tuple of int
        Basis capacities swept.
    seeds : tuple of int
        One data stream per seed (episodes seeded ``10000 + seed``, as the reproduction's
        training episodes).
    kernels : tuple of {"rbf", "geodesic", "laplacian"}
        Kernels by name, library defaults otherwise (the Euclidean Laplacian kernel is the
        comparison's option ``critic="laplacian"``).
    n_episodes : int
        Episodes of the fixed policy per stream (150 steps each, uniform starts).
    stride : int
        Every ``stride``-th state of an episode is a data point (the reproduction's 4).
    episodes_per_batch : int
        Episodes per :meth:`~sb3_geogp.SparseOnlineGP.update` call (40 x 38 = 1520 points,
        a rollout-sized batch).
    adaptation : Adaptation
        Settings of the adaptive on-line GP (the defaults: window 2048, a block of 1024).
    trend : {"none", "level", "constant", "linear"}
        The adaptive on-line GP's ``trend`` (:class:`~sb3_geogp.SparseOnlineGP`; the policy's
        PPO default since 0.9 is ``"level"``); the default on-line GP has none.
    forgetting : float
        The adaptive on-line GP's ``forgetting`` before its adaptation first chooses one (the
        policy's PPO default since 0.14: 0.1); the default on-line GP has none.
    forgetting_points : int or None
        What the adaptive on-line GP's forgetting is per (``SparseOnlineGP``'s
        ``forgetting_points``; the policy's PPO default since 0.14: 4,096 points).
    novelty_tol : float
        Relative novelty of a new basis vector: low, so that ``max_basis`` rather than the
        tolerance limits the basis (the library default, a quarter lengthscale, fills only
        20-90 basis vectors here).
    grid_n : int
        Cells per axis of the evaluation grid.
    mc_rollouts : int
        Monte Carlo rollouts per grid cell for the reference value.
    batch_iters : int
        L-BFGS iterations per start of the batch fit.
    """

    max_basis: tuple[int, ...] = (20, 50, 100, 200)
    seeds: tuple[int, ...] = tuple(range(5))
    kernels: tuple[KernelName, ...] = ("rbf", "geodesic")
    n_episodes: int = 800
    stride: int = 4
    episodes_per_batch: int = 40
    adaptation: Adaptation = field(default_factory=Adaptation)
    trend: str = "none"
    forgetting: float = 1.0
    forgetting_points: int | None = None
    novelty_tol: float = 1e-3
    grid_n: int = 60
    mc_rollouts: int = 100
    batch_iters: int = 200

    @classmethod
    def quick(cls) -> CheckConfig:
        """A smoke configuration (same code paths, tiny sizes)."""
        return cls(
            max_basis=(10, 20),
            seeds=(0,),
            n_episodes=16,
            episodes_per_batch=4,
            adaptation=Adaptation(window=256),
            grid_n=10,
            mc_rollouts=4,
            batch_iters=20,
        )


@dataclass
class CheckResult:
    """Rows of :func:`run_check` (one per kernel, seed and capacity) and their context.

    ``provenance`` is :func:`~sb3_geogp.toolbox.provenance.provenance`, recorded by the caller.
    """

    rows: list[dict[str, Any]]
    config: CheckConfig
    truth: GridValue
    provenance: dict[str, Any] = field(default_factory=dict)

    def values(self, kernel: str, metric: str) -> np.ndarray:
        """Metric per capacity and seed, shape (len(max_basis), len(seeds)) (NaN if absent)."""
        cfg = self.config
        out = np.full((len(cfg.max_basis), len(cfg.seeds)), np.nan)
        for row in self.rows:
            if row["kernel"] == kernel:
                out[cfg.max_basis.index(row["max_basis"]), cfg.seeds.index(row["seed"])] = row[
                    metric
                ]
        return out

    def ratio(self, kernel: str, online: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Geometric mean of ``MSE(on-line) / MSE(batch)`` over seeds, with its 95% interval.

        Returns
        -------
        ratio, low, high : ndarray, shape (len(max_basis),)
            ``exp`` of the mean per-seed log ratio and of its Student-t interval (NaN with
            fewer than 2 seeds).
        """
        mean, half = mean_ci(np.log(self.values(kernel, f"ratio_{online}")), nan_policy="omit")
        return np.exp(mean), np.exp(mean - half), np.exp(mean + half)

    def summary(self) -> list[dict[str, Any]]:
        """Per kernel and capacity: mean and 95% half-width of every MSE and the ratios."""
        out = []
        for kernel in self.config.kernels:
            stats = {
                name: mean_ci(self.values(kernel, f"mse_{name}"), nan_policy="omit")
                for name in (*ONLINE, "batch", "batch_online_hyper")
            }
            ratios = {online: self.ratio(kernel, online) for online in ONLINE}
            n_basis = {
                name: np.nanmean(self.values(kernel, key), axis=1)
                for name, key in (("adaptive", "n_basis"), ("default", "n_basis_default"))
            }
            for i, m in enumerate(self.config.max_basis):
                row: dict[str, Any] = {"kernel": kernel, "max_basis": m}
                for name, counts in n_basis.items():
                    row[f"n_basis_{name}_mean"] = float(counts[i])
                for name, (mean, half) in stats.items():
                    row[f"mse_{name}"] = [float(mean[i]), float(half[i])]
                for online, (r, lo, hi) in ratios.items():
                    row[f"ratio_{online}"] = [float(r[i]), float(lo[i]), float(hi[i])]
                out.append(row)
        return out

    def table(self) -> str:
        """Markdown table of the summary (intervals only from 5 seeds on): mean basis sizes,
        MSE mean ± 95% half-width, ratio geometric mean [95% interval]."""
        n = len(self.config.seeds)
        rows = []
        for s in self.summary():
            counts = f"{s['n_basis_adaptive_mean']:.0f} / {s['n_basis_default_mean']:.0f}"
            cells = [s["kernel"], str(s["max_basis"]), counts]
            for name in (*ONLINE, "batch", "batch_online_hyper"):
                mean, half = s[f"mse_{name}"]
                cells.append(estimate_cell(f"{mean:.2f}", f"± {half:.2f}", n))
            for online in ONLINE:
                r, lo, hi = s[f"ratio_{online}"]
                cells.append(estimate_cell(f"{r:.2f}", f"[{lo:.2f}, {hi:.2f}]", n))
            rows.append(cells)
        header = [
            "kernel",
            "max BV",
            "BVs adaptive / default",
            "MSE on-line adaptive",
            "MSE on-line default",
            "MSE batch",
            "MSE batch at on-line hyperparameters",
            "adaptive / batch",
            "default / batch",
        ]
        return markdown_table(header, rows, align="llrrrrrrr")

    def to_json(self) -> dict[str, Any]:
        """JSON-compatible record: provenance, configuration, data size, rows and summary."""
        return {
            "provenance": self.provenance,
            "config": asdict(self.config),
            "n_points": sorted({row["n_points"] for row in self.rows}),
            "truth": {
                "grid_n": self.truth.n,
                "value_var": float(self.truth.value.var()),
                "mc_noise_floor_mse": float(np.mean(self.truth.stderr**2)),
            },
            "rows": self.rows,
            "summary": self.summary(),
        }


def stream(task: Task, config: CheckConfig, seed: int) -> EpisodeData:
    """The data stream of ``seed``: episodes of the fixed policy with completed returns."""
    return policy_episodes(task, config.n_episodes, seed=10_000 + seed, stride=config.stride)


def online_gp(
    task: Task,
    kernel: KernelName,
    data: EpisodeData,
    max_basis: int,
    config: CheckConfig,
    adapt: bool,
) -> SparseOnlineGP:
    """One on-line pass over ``data`` in batches of whole episodes, with their starts, by the
    GP of :func:`new_online_gp`."""
    gp = new_online_gp(task, kernel, data.states.shape[1], max_basis, config, adapt)
    return feed_stream(gp, data, config.episodes_per_batch)


def new_online_gp(
    task: Task,
    kernel: KernelName,
    input_dim: int,
    max_basis: int,
    config: CheckConfig,
    adapt: bool,
) -> SparseOnlineGP:
    """The check's on-line GP, not yet fed.

    The GP has the library's defaults but ``novelty_tol`` (and ``config.adaptation``,
    ``config.trend`` and ``config``'s forgetting where ``adapt``), and knows the observation
    bounds (as the SB3 critic does), from which it takes its starting lengthscales.
    """
    high = np.array([math.pi, task.params.max_speed])
    return SparseOnlineGP(
        input_dim,
        kernel=kernel,
        max_basis=max_basis,
        novelty_tol=config.novelty_tol,
        input_bounds=(-high, high),
        adapt=config.adaptation if adapt else None,
        trend=config.trend if adapt else "none",
        forgetting=config.forgetting if adapt else 1.0,
        forgetting_points=config.forgetting_points if adapt else None,
    )


def feed_stream(gp: SparseOnlineGP, data: EpisodeData, episodes_per_batch: int) -> SparseOnlineGP:
    """Feed ``gp`` the stream ``data`` in batches of ``episodes_per_batch`` whole episodes,
    with their starts, as the check does; returns ``gp``."""
    for rows in episode_batches(data.episode_starts, episodes_per_batch):
        gp.update(data.states[rows], data.returns[rows], episode_starts=data.episode_starts[rows])
    return gp


def online_hyper(gp: SparseOnlineGP, n_factors: int, y_std: float) -> Hyper:
    """``gp``'s final hyperparameters in the batch fit's terms: factor 1 on its lengthscales,
    variances rescaled from its target scale to ``y_std``."""
    rescale = (float(gp.y_scale) / y_std) ** 2
    return Hyper(
        (1.0,) * n_factors,
        float(gp.kernel.variance) * rescale,
        float(gp.noise_var) * rescale,
    )


def run_case(
    task: Task,
    config: CheckConfig,
    truth: GridValue,
    kernel: KernelName,
    seed: int,
    max_basis: int,
) -> dict[str, Any]:
    """The on-line GPs and the batch GP of one kernel, seed and capacity, scored.

    The batch fit starts from the adaptive GP's final hyperparameters and from the library's
    starting ones (lengthscales from the bounds, signal variance 1, noise 0.05) and keeps the
    better optimum. ``mse_batch_online_hyper`` is the batch posterior on all data at the
    adaptive GP's final hyperparameters, unfitted: it differs from the adaptive GP in the data
    its posterior holds (all points, not the window), from the batch GP in the
    hyperparameters only.

    Returns
    -------
    dict
        The row: ``kernel``, ``seed``, ``max_basis``, ``n_basis`` (of the adaptive GP; the
        batch GP's inducing points), ``n_basis_default``, ``mse_<model>`` for
        ``adaptive``, ``default``, ``batch``, ``batch_online_hyper``, ``ratio_adaptive``,
        ``ratio_default`` (each over ``mse_batch``), the batch fit's ``batch_bound``,
        ``batch_online_hyper_bound``, hyperparameters, evaluations and convergence, the
        adaptive GP's final hyperparameters (variances in the batch's target scale) and
        ``seconds``.
    """
    start = time.perf_counter()
    data = stream(task, config, seed)
    states, _, _ = task.grid(truth.n)
    gps = {
        name: online_gp(task, kernel, data, max_basis, config, adapt=name == "adaptive")
        for name in ONLINE
    }
    gp = gps["adaptive"]
    z = gp.basis_inputs.clone()
    n_factors, _ = gp.kernel.correlation_fn(z[:1], z)
    y_std = float(np.std(data.returns, ddof=1))
    library_start = Hyper(tuple((gp.ls_start / gp.lengthscale)[:n_factors].tolist()))
    at_online = online_hyper(gp, n_factors, y_std)
    fits = {
        "batch": batch_sparse_gp(
            gp.kernel,
            data.states,
            data.returns,
            z,
            states,
            starts=(at_online, library_start),
            max_iter=config.batch_iters,
        ),
        "batch_online_hyper": batch_sparse_gp(
            gp.kernel, data.states, data.returns, z, states, starts=(at_online,), max_iter=0
        ),
    }
    mse = {
        name: _mse(g.predict(states, return_var=False)[0].numpy(), truth) for name, g in gps.items()
    }
    mse.update({name: _mse(fit.mean, truth) for name, fit in fits.items()})
    batch = fits["batch"]
    return {
        "kernel": kernel,
        "seed": seed,
        "max_basis": max_basis,
        "n_points": len(data.returns),
        "n_basis": gp.n_basis,
        "n_basis_default": gps["default"].n_basis,
        **{f"mse_{name}": value for name, value in mse.items()},
        **{f"ratio_{name}": mse[name] / mse["batch"] for name in ONLINE},
        "batch_bound": batch.bound,
        "batch_online_hyper_bound": fits["batch_online_hyper"].bound,
        "batch_lengthscale": batch.lengthscale.tolist(),
        "batch_variance": batch.hyper.variance,
        "batch_noise_var": batch.hyper.noise_var,
        "batch_evaluations": batch.evaluations,
        "batch_converged": batch.converged,
        "adaptive_lengthscale": gp.lengthscale.tolist(),
        "adaptive_variance": at_online.variance,
        "adaptive_noise_var": at_online.noise_var,
        "seconds": time.perf_counter() - start,
    }


def _mse(pred: np.ndarray, truth: GridValue) -> float:
    return float(np.mean((pred - truth.value) ** 2))


def run_check(
    config: CheckConfig,
    task: Task | None = None,
    truth: GridValue | None = None,
    progress: Callable[[Iterable[Any], int], Iterable[Any]] | None = None,
) -> CheckResult:
    """Every kernel, seed and capacity of ``config`` (:func:`run_case`), in one thread.

    Parameters
    ----------
    config : CheckConfig
    task : Task, optional
        Default :class:`~sb3_geogp.studies.pendulum.task.Task`.
    truth : GridValue, optional
        The Monte Carlo reference on ``config.grid_n`` cells per axis; computed with
        :func:`~sb3_geogp.studies.pendulum.ground_truth.mc_value` if not given.
    progress : callable, optional
        ``progress(iterable, total)`` wraps the stream of cases (e.g. tqdm).

    Returns
    -------
    CheckResult
    """
    task = task or Task()
    truth = truth or mc_value(task, config.grid_n, config.mc_rollouts)
    # Largest capacities first: a progress bar's rate then over- rather than under-promises.
    cases = [
        (kernel, seed, m)
        for m in sorted(config.max_basis, reverse=True)
        for kernel in config.kernels
        for seed in config.seeds
    ]
    wrapped = progress(cases, len(cases)) if progress else cases
    # One thread, as the engine's own calls: the batch fit's products are too small to gain
    # from more on a shared machine, and the check's cost is then that of one core.
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        rows = [run_case(task, config, truth, *case) for case in wrapped]
    finally:
        torch.set_num_threads(threads)
    return CheckResult(rows, config, truth)
