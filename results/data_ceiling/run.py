"""``PLAN.md``: off-line regressors of other classes on Acrobot-v1's batches, against the
on-line GP critic and SB3's MLP critic replayed on the same batches (one call per core;
STREAMS as ``results/symmetric_kernel``'s)::

    python results/data_ceiling/run.py --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/data_ceiling/a
    python results/data_ceiling/run.py --seeds 1 3 5 7 9 --streams STREAMS \\
        --out results/data_ceiling/b
    python results/data_ceiling/read.py --plot results/data_ceiling/read.png \\
        > results/data_ceiling/read.md

Needs scikit-learn (the ``bench`` or ``dev`` extra), for its gradient-boosted trees.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from sklearn.ensemble import HistGradientBoostingRegressor

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
RECORDING = load_script(HERE.parent / "actor_features" / "run.py", "actor_features")
SCHEDULE, ENV = RECORDING.SCHEDULE, RECORDING.ENV
#: ``PLAN.md``'s MLP training.
EPOCHS, PATIENCE, MINIBATCH, LR, HELD_OUT = 200, 10, 256, 1e-3, 0.1
#: A regressor: fitted on ``(x, y)``, it returns the prediction at new points.
Fit = Callable[[np.ndarray, np.ndarray, int], Callable[[np.ndarray], np.ndarray]]


def fit_gbt(x: np.ndarray, y: np.ndarray, seed: int) -> Callable[[np.ndarray], np.ndarray]:
    """scikit-learn's gradient-boosted trees with their defaults."""
    return HistGradientBoostingRegressor(random_state=0).fit(x, y).predict


def fit_mlp(
    x: np.ndarray,
    y: np.ndarray,
    seed: int,
    width: int = 64,
    activation: type[th.nn.Module] = th.nn.Tanh,
) -> Callable[[np.ndarray], np.ndarray]:
    """An MLP like SB3's critic (two hidden layers of ``width``, 64-64 tanh by default) trained
    to convergence, early-stopped on a held-out tenth (``PLAN.md``)."""
    gen = th.Generator().manual_seed(seed)
    th.manual_seed(seed)
    x_mean, x_sd = x.mean(0), np.where(x.std(0) > 0, x.std(0), 1.0)
    y_mean, y_sd = y.mean(), y.std()
    xs = th.as_tensor((x - x_mean) / x_sd, dtype=th.float32)
    ys = th.as_tensor((y - y_mean) / y_sd, dtype=th.float32)
    order = th.randperm(len(ys), generator=gen)
    cut = int(HELD_OUT * len(ys))
    held, train = order[:cut], order[cut:]
    net = th.nn.Sequential(
        th.nn.Linear(x.shape[1], width), activation(), th.nn.Linear(width, width), activation(),
        th.nn.Linear(width, 1),
    )  # fmt: skip
    opt = th.optim.Adam(net.parameters(), lr=LR)
    best, best_state, waited = float("inf"), copy.deepcopy(net.state_dict()), 0
    for _ in range(EPOCHS):
        for rows in train[th.randperm(len(train), generator=gen)].split(MINIBATCH):
            opt.zero_grad()
            th.nn.functional.mse_loss(net(xs[rows])[:, 0], ys[rows]).backward()
            opt.step()
        with th.no_grad():
            loss = float(th.nn.functional.mse_loss(net(xs[held])[:, 0], ys[held]))
        if loss < best:
            best, best_state, waited = loss, copy.deepcopy(net.state_dict()), 0
        elif (waited := waited + 1) >= PATIENCE:
            break
    net.load_state_dict(best_state)

    def predict(z: np.ndarray) -> np.ndarray:
        with th.no_grad():
            out = net(th.as_tensor((z - x_mean) / x_sd, dtype=th.float32))[:, 0].numpy()
        return y_mean + y_sd * out.astype(np.float64)

    return predict


def replay_offline(
    batches: list[Any], seed: int, fit: Fit, every: bool, tail_only: bool = False
) -> dict[str, Any]:
    """Score every batch by ``fit`` on the batches before it (``every``) or on the newest,
    seeded by the run's ``seed`` and the batch; with ``tail_only``, only the batches of the
    tail score (:func:`tail_batches`), the others NaN."""
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    learnt = [0]
    scored = tail_batches(batches) if tail_only else range(len(batches))

    def predict(x: th.Tensor) -> th.Tensor:
        if learnt[0] not in scored:
            return th.full((x.shape[0],), float("nan"), dtype=th.float64)
        xs, ys = (np.concatenate(parts) for parts in zip(*kept, strict=True))
        return th.as_tensor(fit(xs, ys, 1000 * seed + learnt[0])(x.double().numpy()))

    def learn(x: th.Tensor, y: th.Tensor, starts: th.Tensor | None) -> None:
        kept.append((x.double().numpy(), y.double().numpy()))
        learnt[0] += 1
        if not every:
            del kept[:-1]

    scores = SCHEDULE._scored(batches, predict, learn)
    # JSON has no NaN: the batches left unfitted are null
    explained = [None if np.isnan(v) else v for v in scores["explained_variance"]]
    return {**scores, "explained_variance": explained}


def tail_batches(batches: list[Any]) -> list[int]:
    """Indices of the batches whose scores make up the tail score (``adaptation_schedule``'s
    last :data:`LAST` of the scored batches)."""
    scored = [i for i, (x, _, _) in enumerate(batches) if i > 0 and x.shape[0] > 1]
    return scored[int(np.floor((1 - SCHEDULE.LAST) * len(scored))) :]


def replays(tail_only: bool = False) -> dict[str, Callable[[list[Any], int], dict[str, Any]]]:
    """``PLAN.md``'s predictors, called with a run's batches and seed; the off-line ones
    fitted for the tail score's batches alone where ``tail_only``."""
    offline = functools.partial(replay_offline, tail_only=tail_only)
    return {
        "online": lambda b, seed: SCHEDULE.replay(ENV, seed, b, RECORDING.RECORDED),
        "mlp_ppo": lambda b, seed: SCHEDULE.replay_mlp(ENV, seed, b),
        "gbt_newest": functools.partial(offline, fit=fit_gbt, every=False),
        "gbt_all": functools.partial(offline, fit=fit_gbt, every=True),
        "mlp_all": functools.partial(offline, fit=fit_mlp, every=True),
    }


SETTINGS = {"recorded": RECORDING.RECORDED, "mlp": [EPOCHS, PATIENCE, MINIBATCH, LR, HELD_OUT]}


def main() -> None:
    RECORDING.run_replays(__doc__, replays(), SETTINGS, seeded=True)


if __name__ == "__main__":
    main()
