"""``PLAN.md``: exact GPs with and without an additive kernel component on the batches the
drop-in PPO default's GP critic is fed on Acrobot-v1 (one call per core; STREAMS is where
the batches are kept, recorded there where missing as ``results/actor_features`` records them;
a folder of another version's streams replays that version's batches)::

    python results/additive_kernel/run.py --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/additive_kernel/a
    python results/additive_kernel/run.py --seeds 1 3 5 7 9 --streams STREAMS \\
        --out results/additive_kernel/b
    python results/additive_kernel/read.py > results/additive_kernel/read.md

Each predictor is an exact GP on the newest batch, inputs scaled by the batch's spreads,
targets standardised, with the kernel

.. math::  k(x, x') = s_f^2 \\exp(-\\|(x - x') / l\\|)
           + \\frac{s_a^2}{d} \\sum_i \\exp(-|x_i - x'_i| / a_i) + s_n^2 [x = x']

(``full``: no additive term; ``additive``: no full term), its hyperparameters at the optimum
of the exact log marginal likelihood of :data:`FIT_POINTS` random points by L-BFGS from fixed
starts, its posterior on every point of the batch.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import torch as th

from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
#: Session 67's study: its streams (the drop-in PPO default's Acrobot batches, with the actor
#: at each feed), its scoring and its 512 points per maximum-likelihood fit.
RECORDING = load_script(HERE.parent / "actor_features" / "run.py", "actor_features")
SCHEDULE, FIT_POINTS = RECORDING.SCHEDULE, RECORDING.FIT_POINTS
#: Each model's kernel terms.
MODELS = {"full": ("full",), "full+additive": ("full", "additive"), "additive": ("additive",)}
#: Box of every log hyperparameter: lengthscales (in the inputs' spreads), variances (of the
#: standardised targets).
LOG_BOUNDS = {"scale": (math.log(1e-3), math.log(1e3)), "var": (math.log(1e-6), math.log(1e2))}
JITTER = 1e-8


def kernel(a: th.Tensor, b: th.Tensor, p: dict[str, th.Tensor]) -> th.Tensor:
    """The covariance of ``a`` (n, d) with ``b`` (m, d) without noise, shape (n, m), of the
    terms present in ``p`` (``full``: ``log_l``, ``log_sf``; ``additive``: ``log_a``,
    ``log_sa``)."""
    k = th.zeros(a.shape[0], b.shape[0], dtype=a.dtype)
    if "log_l" in p:
        scale = p["log_l"].exp()  # one node, so that the gradients sum as they always did
        full = th.exp(-th.cdist(metric(a, scale, p), metric(b, scale, p)))
        if "mirror" in p:  # results/symmetric_kernel: the term made (partly) invariant
            weight = th.sigmoid(p["logit_w"]) if "logit_w" in p else 1.0
            mirrored = metric(b * p["mirror"], scale, p)
            full = full + weight * th.exp(-th.cdist(metric(a, scale, p), mirrored))
        k = k + p["log_sf"].exp() * full
    if "log_a" in p:
        scale = p["log_a"].exp()
        terms = th.zeros_like(k)
        for i in range(a.shape[1]):  # one dimension at a time: n x m x d would not fit
            terms = terms + th.exp(-(a[:, i, None] - b[None, :, i]).abs() / scale[i])
        k = k + p["log_sa"].exp() * terms / a.shape[1]
    return k


def metric(x: th.Tensor, scale: th.Tensor, p: dict[str, th.Tensor]) -> th.Tensor:
    """``x`` (n, d) in the full term's metric: divided by the lengthscales ``scale`` (d,),
    then, with ``shear`` in ``p`` (``results/metric_kernel``), mapped by
    ``I + tril(shear, -1)``, so that the distance is that of any positive-definite metric
    ``L^T L``, ``L`` lower triangular."""
    z = x / scale
    if "shear" not in p:
        return z
    eye = th.eye(x.shape[1], dtype=x.dtype)
    return z @ (eye + th.tril(p["shear"], diagonal=-1)).T


def negative_evidence(x: th.Tensor, y: th.Tensor, p: dict[str, th.Tensor]) -> th.Tensor:
    """Minus the exact log marginal likelihood of ``y`` (n,) at ``x`` (n, d)."""
    k = kernel(x, x, p) + (p["log_sn"].exp() + JITTER) * th.eye(x.shape[0], dtype=x.dtype)
    chol = th.linalg.cholesky(k)
    alpha = th.cholesky_solve(y[:, None], chol)[:, 0]
    half_logdet = chol.diagonal().log().sum()
    return 0.5 * y @ alpha + half_logdet + 0.5 * len(y) * math.log(2 * math.pi)


def clamped(p: dict[str, th.Tensor]) -> dict[str, th.Tensor]:
    """``p``'s log hyperparameters inside :data:`LOG_BOUNDS` (the optimiser works on the
    unclamped values)."""
    bounds = {k: LOG_BOUNDS["scale" if k in ("log_l", "log_a") else "var"] for k in p}
    return {k: v.clamp(*bounds[k]) if k.startswith("log_") else v for k, v in p.items()}


def fit(
    x: th.Tensor,
    y: th.Tensor,
    terms: tuple[str, ...],
    seed: int,
    mirror: th.Tensor | None = None,
) -> dict[str, th.Tensor]:
    """Maximum-likelihood hyperparameters of the kernel of ``terms`` on :data:`FIT_POINTS` of
    the points, drawn with ``seed``; starts: lengthscales 1, the variances shared equally.
    ``mirror`` (d,), signs: with ``"mirror"`` in ``terms`` the full term is summed over
    ``x'`` and its mirror image, by a weight of 1, or learned from a start of 1/2 with
    ``"weight"`` in ``terms`` (``results/symmetric_kernel``). With ``"shear"`` in ``terms``
    the full term's metric is learned whole (:func:`metric`), from the diagonal one."""
    d = x.shape[1]
    share = math.log(1.0 / len({"full", "additive"} & set(terms)))
    p: dict[str, th.Tensor] = {"log_sn": th.tensor(math.log(0.1), dtype=th.float64)}
    if "full" in terms:
        p |= {"log_l": th.zeros(d, dtype=th.float64), "log_sf": th.tensor(share).double()}
    if "additive" in terms:
        p |= {"log_a": th.zeros(d, dtype=th.float64), "log_sa": th.tensor(share).double()}
    if "weight" in terms:
        p["logit_w"] = th.zeros((), dtype=th.float64)
    if "shear" in terms:
        p["shear"] = th.zeros(d, d, dtype=th.float64)
    fixed = {"mirror": mirror} if "mirror" in terms and mirror is not None else {}
    for v in p.values():
        v.requires_grad_(True)
    rows = th.randperm(x.shape[0], generator=th.Generator().manual_seed(seed))[:FIT_POINTS]
    xs, ys = x[rows], y[rows]
    opt = th.optim.LBFGS(list(p.values()), max_iter=200, line_search_fn="strong_wolfe")

    def closure() -> th.Tensor:
        opt.zero_grad()
        loss = negative_evidence(xs, ys, clamped(p) | fixed)
        loss.backward()
        return loss

    opt.step(closure)
    return {k: v.detach() for k, v in clamped(p).items()} | fixed


def replay(
    batches: list[Any], terms: tuple[str, ...], mirror: th.Tensor | None = None
) -> dict[str, Any]:
    """Score every batch by the exact GP of ``terms`` (``mirror``: :func:`fit`'s) on the batch
    before it (``PLAN.md``)."""
    newest: list[tuple[th.Tensor, th.Tensor]] = []
    shares: list[float] = []
    weights: list[float] = []

    def predict(x_new: th.Tensor) -> th.Tensor:
        x, y = newest[0]
        spread = x.std(dim=0).where(x.std(dim=0) > 0, th.ones(()).double())
        mean, sd = y.mean(), y.std()
        xs, ys = x / spread, (y - mean) / sd
        p = fit(xs, ys, terms, seed=len(shares), mirror=mirror)
        if "logit_w" in p:
            weights.append(th.sigmoid(p["logit_w"]).item())
        parts = [p[k].exp().item() for k in ("log_sf", "log_sa") if k in p]
        shares.append(p["log_sa"].exp().item() / sum(parts) if "log_sa" in p else 0.0)
        k = kernel(xs, xs, p) + (p["log_sn"].exp() + JITTER) * th.eye(len(ys)).double()
        alpha = th.cholesky_solve(ys[:, None], th.linalg.cholesky(k))[:, 0]
        return mean + sd * (kernel(x_new.double() / spread, xs, p) @ alpha)

    def learn(x: th.Tensor, y: th.Tensor, starts: th.Tensor | None) -> None:
        newest[:] = [(x.double(), y.double())]

    extra = {"mirror_weight": weights} if "weight" in terms else {}
    return dict(additive_share=shares, **extra, **SCHEDULE._scored(batches, predict, learn))


def main() -> None:
    replays = {name: functools.partial(replay, terms=terms) for name, terms in MODELS.items()}
    settings = {"recorded": RECORDING.RECORDED, "fit_points": FIT_POINTS}
    RECORDING.run_replays(__doc__, replays, settings)


if __name__ == "__main__":
    main()
