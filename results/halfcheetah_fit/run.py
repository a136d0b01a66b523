"""``PLAN.md``: the batches PPO's default GP critic is fed on HalfCheetah-v5, and how well the
critic and off-line regressors predict each before learning it::

    python results/halfcheetah_fit/run.py --seeds 1143 1144 1145 --out results/halfcheetah_fit/runs

One JSON per seed in ``--out`` (a finished seed is skipped on a re-run). Needs scikit-learn
(the ``bench`` or ``dev`` extra).
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from sklearn.ensemble import HistGradientBoostingRegressor
from tqdm.auto import tqdm

from sb3_geogp.comparison.command import add_arguments, config_from_args
from sb3_geogp.comparison.run import _critic_timers, build_model, write_json_atomic
from sb3_geogp.studies.exact_gp import exact_gp
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
PROTOCOL = [
    "--algos", "ppo", "--hyperparams", f"ppo={HERE.parent / 'heldout2' / 'ppo.yml'}",
    "--timesteps", "50000", "--mlp-normalize", "--gp-actor-normalize",
    "--envs", "HalfCheetah-v5", "--critics", "laplacian",
]  # fmt: skip
#: ``PLAN.md``'s settings: the tail's share, the newest batches' window, the exact GP's fit
#: points.
LAST, NEWEST, FIT_POINTS = 0.2, 2, 256
Predict = Callable[[np.ndarray], np.ndarray]


def record(seed: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray | None]]:
    """Train the run of ``seed``; every fed batch ``(x, y)`` with the critic's prediction of
    ``y`` before it (``None`` before it has a basis)."""
    args = add_arguments(argparse.ArgumentParser()).parse_args(
        [*PROTOCOL, "--seeds", "1", "--first-seed", str(seed), "--out", "unused"]
    )
    spec = config_from_args(args).specs()[0]
    threads = th.get_num_threads()
    th.set_num_threads(1)
    model = build_model(spec)
    callback, _ = _critic_timers(model, spec)
    gp = model.policy.gp
    absorb, batches = gp.update, []

    def recorded(x: Any, y: Any, *rest: Any, **kw: Any) -> None:
        x64, y64 = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        before = gp.predict(th.as_tensor(x64), return_var=False)[0].cpu().numpy()
        batches.append((x64, y64, before if gp.n_basis else None))
        absorb(x, y, *rest, **kw)

    gp.update = recorded
    try:
        model.learn(spec.total_timesteps, callback=callback)
    finally:
        th.set_num_threads(threads)
        model.get_env().close()
    return batches


#: The zoo's critic shape for this task (256-256 ReLU), trained to convergence as session 70's
#: off-line MLPs were (``results/data_ceiling``: Adam 1e-3, minibatch 256, early-stopped on a
#: held-out tenth, patience 10).
DATA_CEILING = load_script(HERE.parent / "data_ceiling" / "run.py", "data_ceiling")
fit_mlp = functools.partial(DATA_CEILING.fit_mlp, width=256, activation=th.nn.ReLU)


def fit_ridge(x: np.ndarray, y: np.ndarray, seed: int) -> Predict:
    """A ridge line on standardised inputs (penalty 1e-3 per point)."""
    x_mean, x_sd = x.mean(0), np.where(x.std(0) > 0, x.std(0), 1.0)
    a = np.c_[(x - x_mean) / x_sd, np.ones(len(x))]
    w = np.linalg.solve(a.T @ a + 1e-3 * len(x) * np.eye(a.shape[1]), a.T @ y)
    return lambda z: np.c_[(z - x_mean) / x_sd, np.ones(len(z))] @ w


def fit_gbt(x: np.ndarray, y: np.ndarray, seed: int) -> Predict:
    """scikit-learn's gradient-boosted trees with their defaults."""
    return HistGradientBoostingRegressor(random_state=0).fit(x, y).predict


def fit_exact(x: np.ndarray, y: np.ndarray, seed: int) -> Predict:
    """An exact Laplacian GP, maximum-likelihood hyperparameters (``PLAN.md``)."""
    return exact_gp(x, y, "laplacian", fit_points=FIT_POINTS, seed=seed).predict


#: Each off-line predictor: its fit and how many of the newest batches it learns (None: all).
OFFLINE: dict[str, tuple[Callable[[np.ndarray, np.ndarray, int], Predict], int | None]] = {
    "exact_gp": (fit_exact, NEWEST),
    "mlp_newest": (fit_mlp, NEWEST),
    "mlp_all": (fit_mlp, None),
    "gbt_newest": (fit_gbt, NEWEST),
    "gbt_all": (fit_gbt, None),
    "ridge_newest": (fit_ridge, NEWEST),
    "ridge_all": (fit_ridge, None),
}


def explained_variance(y: np.ndarray, f: np.ndarray) -> float:
    return float(1 - np.var(y - f) / np.var(y))


def stacked(
    batches: list[tuple[np.ndarray, np.ndarray, np.ndarray | None]], k: int, newest: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """The inputs and targets of the ``newest`` batches before batch ``k`` (None: all)."""
    window = batches[0 if newest is None else max(0, k - newest) : k]
    return np.concatenate([b[0] for b in window]), np.concatenate([b[1] for b in window])


def score(batches: list[tuple[np.ndarray, np.ndarray, np.ndarray | None]], seed: int) -> dict:
    """Every predictor's explained variance on each tail batch, learnt from those before it."""
    scored = [k for k, (_, _, before) in enumerate(batches) if before is not None]
    tail = scored[int(np.floor((1 - LAST) * len(scored))) :]
    out: dict[str, Any] = {"batches": tail, "online": [], **{name: [] for name in OFFLINE}}
    for k in tqdm(tail, desc=f"seed {seed}", leave=False):
        x_new, y_new, before = batches[k]
        out["online"].append(explained_variance(y_new, before))
        # One stack per window (the newest batches, or all), shared by its predictors.
        windows = {n: stacked(batches, k, n) for n in {newest for _, newest in OFFLINE.values()}}
        for name, (fit, newest) in OFFLINE.items():
            x, y = windows[newest]
            out[name].append(explained_variance(y_new, fit(x, y, 1000 * seed + k)(x_new)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", required=True)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for seed in tqdm(args.seeds, desc="seeds"):
        path = args.out / f"s{seed}.json"
        if path.exists():
            continue
        batches = record(seed)
        result = dict(
            seed=seed,
            n_batches=len(batches),
            batch_points=[len(b[1]) for b in batches],
            scores=score(batches, seed),
            settings=dict(
                protocol=PROTOCOL,
                last=LAST,
                newest=NEWEST,
                fit_points=FIT_POINTS,
                mlp=DATA_CEILING.SETTINGS["mlp"],
            ),
            provenance=provenance(),
        )
        write_json_atomic(path, result)


if __name__ == "__main__":
    main()
