"""Reproduction of the paper's pendulum experiment (its Figure 3) with controls.

For every seed the fixed policy generates training episodes (and separate validation
episodes) with discounted Monte Carlo returns (:func:`~sb3_geogp.studies.pendulum.task.
policy_episodes`). For every basis capacity ``max_basis`` each GP makes one on-line pass over
the training episodes (batches of ``episodes_per_batch`` episodes, with episode starts) and
is scored on the 60 x 60 grid against the Monte Carlo ground truth
(:func:`~sb3_geogp.studies.pendulum.ground_truth.mc_value`).

Models (:data:`KERNELS`, :data:`MODELS`):

* ``rbf``: :class:`~sb3_geogp.RBFKernel`, Gaussian profile on Euclidean distance (the
  paper's "standard GP");
* ``euclid_laplacian``: :class:`LaplacianKernel`, the geodesic kernel's Laplacian
  profile ``exp(-r)`` on Euclidean distance: control (1) for the profile;
* ``euclid_lap_shepard``: the same fitted GP, predicting by the geodesic kernel's Shepard
  interpolation of the basis-vector posterior means (the ``"shepard"`` prediction rule of
  :mod:`sb3_geogp.toolbox.shepard`): control (1) for the attachment rule as well. Only a
  gap between this model and ``geodesic`` is due to the graph distance;
* ``geodesic``: :class:`~sb3_geogp.GeodesicKernel` defaults (Laplacian profile, Shepard
  attachment, trajectory edges);
* variants: ``geo_paper`` (the paper literally: Gaussian profile, nearest-BV attachment,
  nearest-BV edges), ``geo_gaussian`` (Gaussian profile, Shepard attachment),
  ``geo_lap_nearest`` (Laplacian profile, nearest-BV attachment), ``geo_nn_edges``
  (Laplacian, Shepard, nearest-BV edges instead of trajectory edges);
* ``mlp``: SB3's default critic architecture (:mod:`~sb3_geogp.studies.pendulum.mlp_baseline`).

Hyperparameter settings (control (2)), for ``rbf``, ``euclid_laplacian``,
``euclid_lap_shepard`` and ``geodesic``:

* ``fixed``: one shared setting (:class:`GPSettings`), as in the paper;
* ``ml``: the fixed pass, then :meth:`~sb3_geogp.SparseOnlineGP.fit_hyperparameters`
  (marginal likelihood of the basis set), then a fresh pass over all data with the fitted
  lengthscales, signal and noise variances;
* ``val``: the lengthscale multiplier (of :attr:`ReproductionConfig.val_multipliers`) whose
  GP has the lowest squared error on the validation episodes' returns.

Metrics: ``mse`` over all grid cells; ``mse_jump`` / ``mse_smooth`` over the cells at
(resp. away from) the value's discontinuities (:func:`jump_cells`); ``nvar`` the normalised
variance (:func:`normalised_variance`).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import copy
import functools
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from sb3_geogp import GeodesicKernel, RBFKernel, SparseOnlineGP
from sb3_geogp.kernels import Kernel, LaplacianKernel
from sb3_geogp.studies.pendulum.ground_truth import (
    GridValue,
    TDResult,
    mc_value,
    mc_value_at,
    td_baseline,
)
from sb3_geogp.studies.pendulum.mlp_baseline import MLPSettings, fit_mlp
from sb3_geogp.studies.pendulum.task import EpisodeData, Task, policy_episodes
from sb3_geogp.toolbox.pools import worker_pool
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.shepard import PredictionRule, predict_mean, shepard_interpolate
from sb3_geogp.toolbox.stats import mean_ci
from sb3_geogp.toolbox.streams import fit_online

#: ``(lengthscale, variance) -> Kernel``.
KernelFactory = Callable[[list[float], float], Kernel]

#: Kernel name -> factory. One fitted GP per kernel.
KERNELS: dict[str, KernelFactory] = {
    "rbf": RBFKernel,
    "euclid_laplacian": LaplacianKernel,
    "geodesic": GeodesicKernel,
    "geo_paper": functools.partial(
        GeodesicKernel, profile="gaussian", attach="nearest", edges="nearest"
    ),
    "geo_gaussian": functools.partial(GeodesicKernel, profile="gaussian"),
    "geo_lap_nearest": functools.partial(GeodesicKernel, attach="nearest"),
    "geo_nn_edges": functools.partial(GeodesicKernel, edges="nearest"),
}

#: Model name -> (kernel name, prediction rule).
MODELS: dict[str, tuple[str, PredictionRule]] = {
    "rbf": ("rbf", "gp"),
    "euclid_laplacian": ("euclid_laplacian", "gp"),
    "euclid_lap_shepard": ("euclid_laplacian", "shepard"),
    "geodesic": ("geodesic", "gp"),
    "geo_paper": ("geo_paper", "gp"),
    "geo_gaussian": ("geo_gaussian", "gp"),
    "geo_lap_nearest": ("geo_lap_nearest", "gp"),
    "geo_nn_edges": ("geo_nn_edges", "gp"),
}

#: Models compared under all three hyperparameter settings.
CORE_MODELS = ("rbf", "euclid_laplacian", "euclid_lap_shepard", "geodesic")
SETTINGS = ("fixed", "ml", "val")
METRICS = ("mse", "mse_jump", "mse_smooth", "nvar", "n_basis", "seconds")


@dataclass(frozen=True)
class GPSettings:
    """The shared fixed hyperparameters (``fixed`` setting) and the on-line pass.

    Attributes
    ----------
    lengthscale : tuple of float
        ``(l_theta, l_omega)`` in rad and rad/s (about 1/20 and 1/16 of the box).
    variance : float
        Signal variance ``sigma_f^2`` (standardised targets).
    noise_var : float
        Observation-noise variance (standardised targets).
    novelty_tol : float
        Relative novelty for a point to become a basis vector (low, so that the capacity
        rather than the tolerance limits the basis).
    episodes_per_batch : int
        Episodes per :meth:`~sb3_geogp.SparseOnlineGP.update` call.
    """

    lengthscale: tuple[float, float] = (0.3, 1.0)
    variance: float = 1.0
    noise_var: float = 0.02
    novelty_tol: float = 0.01
    episodes_per_batch: int = 10


@dataclass(frozen=True)
class ReproductionConfig:
    """Everything that defines a run (the full run's defaults; :meth:`quick` for a smoke run).

    Attributes
    ----------
    max_basis : tuple of int
        Basis capacities swept.
    seeds : tuple of int
        One training and validation data set per seed.
    n_episodes, n_val_episodes : int
        Training and validation episodes (150 steps each) per seed.
    stride : int
        Every ``stride``-th state of an episode is a training (validation) state. Once the
        basis is full nearly every point displaces a basis vector at small ``max_basis``
        (about 1-2 ms each), so the stride bounds the cost; consecutive states of an episode
        are strongly correlated anyway.
    grid_n : int
        Cells per axis of the evaluation grid (the paper's 60).
    mc_rollouts : int
        Monte Carlo rollouts per grid cell for the reference value.
    td_episodes : int
        Episodes of the TD baseline (the paper's 800).
    gp : GPSettings
    val_multipliers : tuple of float
        Lengthscale multipliers tried by the ``val`` setting.
    ml_iters : int
        Adam steps of the marginal-likelihood fit.
    variants : tuple of str
        Geodesic variants (keys of :data:`MODELS`) run with the fixed setting.
    mlp : MLPSettings
    jump_fraction : float
        Fraction of grid cells called discontinuity cells (:func:`jump_cells`).
    oracle_rollouts : int
        MC rollouts per basis vector of the ``shepard_oracle`` row (:func:`oracle_shepard`,
        on the geodesic GP's basis); 0 skips it.
    workers : int
        Worker processes (each uses one torch thread).
    """

    max_basis: tuple[int, ...] = (10, 20, 40, 70, 100, 150, 200, 300)
    seeds: tuple[int, ...] = tuple(range(8))
    n_episodes: int = 80
    n_val_episodes: int = 20
    stride: int = 4
    grid_n: int = 60
    mc_rollouts: int = 100
    td_episodes: int = 800
    gp: GPSettings = field(default_factory=GPSettings)
    val_multipliers: tuple[float, ...] = (0.5, 1.0, 2.0, 4.0, 8.0)
    ml_iters: int = 60
    variants: tuple[str, ...] = ("geo_paper", "geo_gaussian", "geo_lap_nearest", "geo_nn_edges")
    mlp: MLPSettings = field(default_factory=MLPSettings)
    jump_fraction: float = 0.1
    oracle_rollouts: int = 32
    workers: int = 1

    @classmethod
    def quick(cls, workers: int = 1) -> ReproductionConfig:
        """A smoke configuration that runs in seconds (same code paths, tiny sizes)."""
        return cls(
            max_basis=(10, 40),
            seeds=(0, 1),
            n_episodes=12,
            n_val_episodes=4,
            grid_n=30,
            mc_rollouts=4,
            td_episodes=100,
            val_multipliers=(0.5, 1.0),
            ml_iters=20,
            variants=("geo_paper",),
            mlp=MLPSettings(epochs=5),
            oracle_rollouts=2,
            workers=workers,
        )


@dataclass
class GroundTruth:
    """Reference values on the grid.

    Attributes
    ----------
    states : ndarray, shape (n * n, 2)
        Cell centres.
    mc : GridValue
        Monte Carlo reference (with standard errors).
    td : TDResult
        The paper's tabular TD baseline.
    jump : ndarray of bool, shape (n * n,)
        Discontinuity cells (:func:`jump_cells`).
    """

    states: np.ndarray
    mc: GridValue
    td: TDResult
    jump: np.ndarray

    def summary(self) -> dict[str, float]:
        """Accuracy of the references: MC noise floor and the TD baseline's error."""
        err2 = (self.td.value - self.mc.value) ** 2
        seen = self.td.visits > 0
        return {
            "value_min": float(self.mc.value.min()),
            "value_max": float(self.mc.value.max()),
            "value_var": float(self.mc.value.var()),
            "mc_stderr_mean": float(self.mc.stderr.mean()),
            "mc_stderr_max": float(self.mc.stderr.max()),
            "mc_noise_floor_mse": float((self.mc.stderr**2).mean()),
            "td_coverage": self.td.coverage,
            "td_mse": float(err2.mean()),
            "td_mse_visited": float(err2[seen].mean()),
            "td_mse_jump": float(err2[self.jump].mean()),
            "td_mse_smooth": float(err2[~self.jump].mean()),
        }


def jump_cells(value: np.ndarray, n: int, fraction: float) -> np.ndarray:
    """The ``fraction`` of cells with the largest jump to a grid neighbour.

    The jump of a cell is ``max |V(c) - V(c')|`` over its 4 neighbours ``c'`` (periodic in
    ``theta``, not in ``omega``); the top ``fraction`` of cells by jump are flagged.

    Parameters
    ----------
    value : ndarray, shape (n * n,)
        Row-major, ``omega`` the slow index.
    n : int
    fraction : float

    Returns
    -------
    ndarray of bool, shape (n * n,)
    """
    v = value.reshape(n, n)
    d_theta = np.abs(v - np.roll(v, 1, axis=1))
    jump = np.maximum(d_theta, np.roll(d_theta, -1, axis=1))
    d_omega = np.abs(np.diff(v, axis=0))
    jump[1:] = np.maximum(jump[1:], d_omega)
    jump[:-1] = np.maximum(jump[:-1], d_omega)
    flat = jump.ravel()
    k = max(1, round(fraction * flat.size))
    mask = np.zeros(flat.size, dtype=bool)
    mask[np.argsort(flat)[-k:]] = True
    return mask


def compute_ground_truth(task: Task, config: ReproductionConfig) -> GroundTruth:
    """MC reference, TD baseline and discontinuity cells on the configured grid."""
    states, _, _ = task.grid(config.grid_n)
    mc = mc_value(task, config.grid_n, config.mc_rollouts)
    td = td_baseline(task, config.grid_n, config.td_episodes)
    return GroundTruth(states, mc, td, jump_cells(mc.value, config.grid_n, config.jump_fraction))


# ----------------------------------------------------------------------------------------------
# Fitting and predicting
# ----------------------------------------------------------------------------------------------
def fit_gp(
    kernel: str,
    data: EpisodeData,
    max_basis: int,
    settings: GPSettings,
    lengthscale: Sequence[float] | None = None,
    variance: float | None = None,
    noise_var: float | None = None,
) -> SparseOnlineGP:
    """One on-line pass of a :class:`~sb3_geogp.SparseOnlineGP` over the episodes.

    Parameters
    ----------
    kernel : str
        Key of :data:`KERNELS`.
    data : EpisodeData
    max_basis : int
    settings : GPSettings
        Defaults for the hyperparameters and the batching.
    lengthscale, variance, noise_var : optional
        Override the settings' hyperparameters.
    """
    ls = settings.lengthscale if lengthscale is None else lengthscale
    var = settings.variance if variance is None else variance
    return fit_online(
        KERNELS[kernel](list(ls), var),
        data.states,
        data.returns,
        data.episode_starts,
        max_basis=max_basis,
        noise_var=settings.noise_var if noise_var is None else noise_var,
        novelty_tol=settings.novelty_tol,
        episodes_per_batch=settings.episodes_per_batch,
    )


def oracle_shepard(
    gp: SparseOnlineGP, task: Task, x: np.ndarray, n_rollouts: int, seed: int
) -> np.ndarray:
    """The prediction rule's error floor: Shepard interpolation of the *true* BV values.

    The values at ``gp``'s basis vectors are estimated by Monte Carlo (``n_rollouts`` each)
    and interpolated to ``x`` exactly as the geodesic kernel interpolates its posterior
    means. Whatever a kernel does to the values at the basis vectors, a model that predicts by
    this rule from these basis vectors cannot beat this (up to MC noise).

    Returns
    -------
    ndarray, shape (n,)
    """
    values, _ = mc_value_at(task, gp.basis_inputs.numpy(), n_rollouts, seed)
    return shepard_interpolate(gp, torch.as_tensor(values), torch.as_tensor(x)).numpy()


def predict(
    gp: SparseOnlineGP, rule: PredictionRule, x: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and normalised variance of a fitted GP under a prediction rule.

    Returns
    -------
    mean : ndarray, shape (n,)
    nvar : ndarray, shape (n,)
        Posterior over prior variance of the latent value (:func:`normalised_variance`);
        NaN for the Shepard rule (it interpolates means only).
    """
    if rule == "shepard":
        return predict_mean(gp, x, rule), np.full(len(x), np.nan)
    mean, var = gp.predict(x)
    assert var is not None
    return mean.numpy(), normalised_variance(gp, var.numpy())


def normalised_variance(gp: SparseOnlineGP, var: np.ndarray) -> np.ndarray:
    """The paper's "normalised variance": posterior variance over prior variance.

    ``var(s) / k(s, s)``, both of the latent value in the same (target) units, with
    ``k(s, s) = sigma_f^2 y_scale^2`` for every kernel here: 1 where the data say nothing,
    0 where the value is known exactly. Averaged over the grid it measures how fast a
    model becomes confident, independent of its signal variance.

    Parameters
    ----------
    gp : SparseOnlineGP
    var : ndarray, shape (n,)
        ``gp.predict(x)[1]``.
    """
    prior = float(gp.kernel.variance) * float(gp.y_scale) ** 2
    return var / prior


def _scores(pred: np.ndarray, nvar: np.ndarray, truth: GroundTruth) -> dict[str, float]:
    err2 = (pred - truth.mc.value) ** 2
    return {
        "mse": float(err2.mean()),
        "mse_jump": float(err2[truth.jump].mean()),
        "mse_smooth": float(err2[~truth.jump].mean()),
        "nvar": float(np.mean(nvar)),
    }


def _val_error(gp: SparseOnlineGP, rule: PredictionRule, val: EpisodeData) -> float:
    pred = predict_mean(gp, val.states, rule)
    return float(np.mean((pred - val.returns) ** 2))


# ----------------------------------------------------------------------------------------------
# One job = one seed and one capacity
# ----------------------------------------------------------------------------------------------
def seed_data(task: Task, config: ReproductionConfig, seed: int) -> tuple[EpisodeData, EpisodeData]:
    """Training and validation episodes of ``seed`` (independent streams)."""
    train = policy_episodes(task, config.n_episodes, seed=10_000 + seed, stride=config.stride)
    val = policy_episodes(task, config.n_val_episodes, seed=20_000 + seed, stride=config.stride)
    return train, val


def _timed(fit: Callable[[], SparseOnlineGP]) -> tuple[SparseOnlineGP | None, float, str]:
    """Run a fit; a numerical failure gives ``(None, seconds, message)`` instead of raising."""
    start = time.perf_counter()
    try:
        gp, error = fit(), ""
    except (torch.linalg.LinAlgError, FloatingPointError) as err:
        gp, error = None, f"{type(err).__name__}: {err}".splitlines()[0][:200]
    return gp, time.perf_counter() - start, error


def run_capacity(
    task: Task, config: ReproductionConfig, truth: GroundTruth, seed: int, max_basis: int
) -> list[dict[str, Any]]:
    """Fit and score every model and setting at one seed and capacity.

    A fit that fails numerically (the engine raises ``LinAlgError`` or
    ``FloatingPointError``) is recorded with NaN metrics and its message in ``error``.

    Returns
    -------
    list of dict
        One row per (model, setting) with the :data:`METRICS` and the hyperparameters used.
    """
    train, val = seed_data(task, config, seed)
    s = config.gp
    rows: list[dict[str, Any]] = []

    def record(
        model: str,
        setting: str,
        gp: SparseOnlineGP | None,
        seconds: float,
        error: str = "",
        **extra: Any,
    ) -> None:
        row: dict[str, Any] = {
            "seed": seed,
            "max_basis": max_basis,
            "model": model,
            "setting": setting,
        }
        if gp is None:
            row.update(
                dict.fromkeys(("mse", "mse_jump", "mse_smooth", "nvar", "n_basis"), math.nan)
            )
        else:
            mean, nvar = predict(gp, MODELS[model][1], truth.states)
            row.update(_scores(mean, nvar, truth))
            row["n_basis"] = gp.n_basis
        row["seconds"] = seconds
        if gp is not None:
            ls = gp.lengthscale.tolist()
            row.update(
                lengthscale_theta=ls[0],
                lengthscale_omega=ls[1],
                variance=float(gp.kernel.variance),
                noise_var=float(gp.noise_var),
            )
        rows.append({**row, **extra, "error": error})

    all_models = (*CORE_MODELS, *config.variants)
    core_kernels = {MODELS[m][0] for m in CORE_MODELS}
    for kernel in sorted({MODELS[m][0] for m in all_models}):
        models = [m for m in all_models if MODELS[m][0] == kernel]
        gp, seconds, error = _timed(functools.partial(fit_gp, kernel, train, max_basis, s))
        for model in models:
            record(model, "fixed", gp, seconds, error)
        if kernel == "geodesic" and gp is not None and config.oracle_rollouts >= 2:
            start = time.perf_counter()
            pred = oracle_shepard(
                gp, task, truth.states, config.oracle_rollouts, seed=30_000 + seed
            )
            row = {"seed": seed, "max_basis": max_basis, "model": "shepard_oracle"}
            row.update(setting="fixed", **_scores(pred, np.full(len(pred), np.nan), truth))
            row.update(n_basis=gp.n_basis, seconds=time.perf_counter() - start, error="")
            rows.append(row)
        if kernel not in core_kernels:
            continue
        # Marginal likelihood on the basis set, then a fresh pass with the fitted values.
        ml_gp, ml_seconds, ml_error = None, 0.0, error or "fewer than 2 basis vectors"
        if gp is not None and gp.n_basis >= 2:
            ml_gp, ml_seconds, ml_error = _timed(
                functools.partial(_ml_refit, kernel, gp, train, max_basis, config)
            )
        for model in models:
            record(model, "ml", ml_gp, seconds + ml_seconds, ml_error)
        # Held-out validation over lengthscale multipliers (the fixed fit is multiplier 1).
        candidates: dict[float, SparseOnlineGP] = {}
        val_seconds = seconds
        for mult in config.val_multipliers:
            if mult == 1.0:
                cand: SparseOnlineGP | None = gp
            else:
                ls = [mult * v for v in s.lengthscale]
                cand, sec, _ = _timed(functools.partial(fit_gp, kernel, train, max_basis, s, ls))
                val_seconds += sec
            if cand is not None:
                candidates[mult] = cand
        for model in models:
            rule = MODELS[model][1]
            errors = {mult: _val_error(cand, rule, val) for mult, cand in candidates.items()}
            if not errors:
                record(model, "val", None, val_seconds, "every candidate failed")
                continue
            best = min(errors, key=errors.__getitem__)
            record(model, "val", candidates[best], val_seconds, val_multiplier=best)
    return rows


def _ml_refit(
    kernel: str, gp: SparseOnlineGP, train: EpisodeData, max_basis: int, config: ReproductionConfig
) -> SparseOnlineGP:
    """Marginal-likelihood hyperparameters from ``gp``'s basis set, then a fresh pass with them."""
    probe = copy.deepcopy(gp)
    fitted = probe.fit_hyperparameters(n_iter=config.ml_iters)
    lengthscale = probe.lengthscale.tolist()  # per dimension, the geodesic kernel's too (ard)
    return fit_gp(
        kernel,
        train,
        max_basis,
        config.gp,
        lengthscale=lengthscale,
        variance=fitted["variance"],
        noise_var=fitted["noise_var"],
    )


def run_mlp(
    task: Task, config: ReproductionConfig, truth: GroundTruth, seed: int
) -> list[dict[str, Any]]:
    """Train and score the MLP baseline of one seed (independent of ``max_basis``)."""
    train, val = seed_data(task, config, seed)
    start = time.perf_counter()
    scale = np.array([math.pi, task.speed_limit])
    model = fit_mlp(train.states, train.returns, val.states, val.returns, scale, config.mlp, seed)
    seconds = time.perf_counter() - start
    pred = model.predict(truth.states)
    row: dict[str, Any] = {"seed": seed, "max_basis": None, "model": "mlp", "setting": "fixed"}
    row.update(_scores(pred, np.full(len(pred), np.nan), truth))
    row.update({"n_basis": None, "seconds": seconds})
    return [row]


# ----------------------------------------------------------------------------------------------
# The whole sweep
# ----------------------------------------------------------------------------------------------
@dataclass
class ReproductionResult:
    """Rows of :func:`run_capacity` and :func:`run_mlp`, the ground truth and the config.

    ``provenance`` is :func:`~sb3_geogp.toolbox.provenance.provenance` taken when the run
    started.
    """

    rows: list[dict[str, Any]]
    truth: GroundTruth
    config: ReproductionConfig
    task: Task = field(default_factory=Task)
    provenance: dict[str, Any] = field(default_factory=dict)

    def values(self, model: str, setting: str, metric: str) -> np.ndarray:
        """Metric per capacity and seed, shape (len(max_basis), len(seeds)) (NaN if absent)."""
        cfg = self.config
        out = np.full((len(cfg.max_basis), len(cfg.seeds)), np.nan)
        for row in self.rows:
            if row["model"] == model and row["setting"] == setting and row["max_basis"] is not None:
                i = cfg.max_basis.index(row["max_basis"])
                out[i, cfg.seeds.index(row["seed"])] = row[metric]
        return out

    def mlp_values(self, metric: str) -> np.ndarray:
        """The MLP's metric per seed, shape (len(seeds),)."""
        by_seed = {r["seed"]: r[metric] for r in self.rows if r["model"] == "mlp"}
        return np.array([by_seed.get(s, np.nan) for s in self.config.seeds], dtype=np.float64)


_WORKER: dict[str, Any] = {}


def _init_worker(task: Task, config: ReproductionConfig, truth: GroundTruth) -> None:
    torch.set_num_threads(1)
    _WORKER.update(task=task, config=config, truth=truth)


def _run_job(job: tuple[str, int, int]) -> list[dict[str, Any]]:
    kind, seed, max_basis = job
    task, config, truth = _WORKER["task"], _WORKER["config"], _WORKER["truth"]
    if kind == "mlp":
        return run_mlp(task, config, truth, seed)
    return run_capacity(task, config, truth, seed, max_basis)


def run_reproduction(
    config: ReproductionConfig,
    task: Task | None = None,
    truth: GroundTruth | None = None,
    progress: Callable[[Iterable[Any], int], Iterable[Any]] | None = None,
) -> ReproductionResult:
    """Run every model, setting, capacity and seed; score against the MC ground truth.

    Parameters
    ----------
    config : ReproductionConfig
    task : Task, optional
        Default :class:`~sb3_geogp.studies.pendulum.task.Task`.
    truth : GroundTruth, optional
        Computed with :func:`compute_ground_truth` if not given.
    progress : callable, optional
        ``progress(iterable, total)`` wraps the stream of finished jobs (e.g. tqdm).

    Returns
    -------
    ReproductionResult
    """
    task = task or Task()
    record = provenance()  # before the run: the engine files may change meanwhile
    truth = truth or compute_ground_truth(task, config)
    jobs = [("mlp", seed, 0) for seed in config.seeds]
    jobs += [
        ("gp", seed, m) for m in sorted(config.max_basis, reverse=True) for seed in config.seeds
    ]
    rows: list[dict[str, Any]] = []
    results: Iterable[list[dict[str, Any]]]
    with contextlib.ExitStack() as stack:
        if config.workers > 1:
            # Spawned workers that Ctrl-C stops at once (a forked multiprocessing.Pool hung).
            pool = stack.enter_context(
                worker_pool(config.workers, _init_worker, (task, config, truth))
            )
            futures = [pool.submit(_run_job, job) for job in jobs]
            results = (f.result() for f in cf.as_completed(futures))
        else:
            stack.callback(torch.set_num_threads, torch.get_num_threads())
            _init_worker(task, config, truth)
            results = map(_run_job, jobs)
        for part in progress(results, len(jobs)) if progress else results:
            rows.extend(part)
    return ReproductionResult(rows, truth, config, task, record)


# ----------------------------------------------------------------------------------------------
# For the tables and figures
# ----------------------------------------------------------------------------------------------
def paired_log_ratio(
    result: ReproductionResult, model: str, reference: str, setting: str, metric: str = "mse"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geometric-mean error ratio ``model / reference`` over seeds, with a paired 95% CI.

    Returns
    -------
    ratio, low, high : ndarray, shape (len(max_basis),)
        ``exp`` of the mean per-seed log ratio and of its Student-t interval.
    """
    logs = np.log(result.values(model, setting, metric) / result.values(reference, setting, metric))
    mean, half = mean_ci(logs, nan_policy="omit")
    return np.exp(mean), np.exp(mean - half), np.exp(mean + half)


def example_fits(
    task: Task, config: ReproductionConfig, max_basis: int, seed: int = 0
) -> dict[str, SparseOnlineGP]:
    """GPs of the figures: ``rbf``, ``euclid_lap_shepard`` and ``geodesic`` (fixed setting).

    Returns
    -------
    dict
        Model name -> GP fitted to the training episodes of ``seed``.
    """
    train, _ = seed_data(task, config, seed)
    euclid = fit_gp("euclid_laplacian", train, max_basis, config.gp)
    return {
        "rbf": fit_gp("rbf", train, max_basis, config.gp),
        "euclid_lap_shepard": euclid,
        "geodesic": fit_gp("geodesic", train, max_basis, config.gp),
    }
