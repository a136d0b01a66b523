"""Where the Laplacian critics' large noise variance comes from (``PLAN.md``, addendum 4)::

    python results/calibration/noise.py > results/calibration/noise.md

Each case feeds one GP of ``calibration.py``'s arms the fixed-policy stream, then compares, on
its retained window (standardised targets, forgetting weights): its noise variance; the
targets' true noise from fresh Monte Carlo returns; the noise minimising its own objective (the
collapsed bound with its basis vectors, lengthscales and signal variance held); the noise of the
exact GP's marginal likelihood with the same lengthscales and signal variance; and the exact
GP's noise with every hyperparameter fitted.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
from pathlib import Path
from typing import Any

import numpy as np
import torch
from scipy import optimize
from torch import Tensor
from tqdm import tqdm

from sb3_geogp.adaptation import Projection
from sb3_geogp.studies.pendulum.batch_check import feed_stream, stream
from sb3_geogp.studies.pendulum.ground_truth import mc_value_at
from sb3_geogp.studies.pendulum.task import Task
from sb3_geogp.toolbox.pools import worker_pool
from sb3_geogp.toolbox.scripts import load_script
from sb3_geogp.toolbox.tables import markdown_table

CALIBRATION = load_script(Path(__file__).with_name("calibration.py"), "calibration")
ARMS = ("laplacian, adaptive", "ppo drop-in")
SEEDS = (0, 1, 2, 3, 4)
CAPACITY = 100
#: Window states at which the targets' noise is measured, and fresh returns per state.
TRUTH_STATES, TRUTH_ROLLOUTS = 512, 200
#: Log noise variance searched over (standardised units).
LOG_NOISE_RANGE = (math.log(1e-6), math.log(10.0))
RATIOS = {
    "gp / truth": ("gp", "truth"),
    "vfe / gp": ("vfe", "gp"),
    "exact / vfe": ("exact", "vfe"),
    "exact_free / truth": ("exact_free", "truth"),
}


def laplacian(a: Tensor, b: Tensor, lengthscale: Tensor, variance: Tensor) -> Tensor:
    """``variance * exp(-||(a - b) / l||)``, shape (len(a), len(b)): written out here, not the
    engine's, so that the engine's covariance is checked against it."""
    # the direct formula: cdist's matrix-product shortcut loses ~1e-8 near zero distance
    distance = torch.cdist(
        a / lengthscale, b / lengthscale, compute_mode="donot_use_mm_for_euclid_dist"
    )
    return variance * torch.exp(-distance)


def exact_nlml(K: Tensor, y: Tensor, noise: Tensor) -> Tensor:
    """Negative log marginal likelihood per point of ``y : (n,)`` under ``N(0, K + diag
    noise)``; differentiable."""
    L = torch.linalg.cholesky(K + torch.diag(noise))
    c = torch.linalg.solve_triangular(L, y[:, None], upper=False)[:, 0]
    n = y.shape[0]
    return 0.5 * (c @ c + 2 * L.diagonal().log().sum() + n * math.log(2 * math.pi)) / n


def best_noise(objective: Any) -> float:
    """The noise variance minimising ``objective(noise: float) -> float`` (bounded search on
    its logarithm)."""
    found = optimize.minimize_scalar(
        lambda log_noise: objective(math.exp(log_noise)),
        bounds=LOG_NOISE_RANGE,
        method="bounded",
        options={"xatol": 1e-4},
    )
    return math.exp(found.x)


def exact_free(x: Tensor, y: Tensor, w: Tensor, start: np.ndarray) -> tuple[float, np.ndarray]:
    """The exact GP's noise variance and lengthscales with every hyperparameter fitted by
    L-BFGS-B from ``start = log([l_1, ..., l_d, variance, noise])``."""
    d = x.shape[1]

    def value_and_grad(v: np.ndarray) -> tuple[float, np.ndarray]:
        p = torch.tensor(v, dtype=torch.float64, requires_grad=True)
        ls, var, noise = p[:d].exp(), p[d].exp(), p[d + 1].exp()
        loss = exact_nlml(laplacian(x, x, ls, var), y, noise / w)
        loss.backward()
        assert p.grad is not None
        return float(loss.detach()), p.grad.numpy().copy()

    bounds = [(s - 5.0, s + 5.0) for s in start]
    bounds[-1] = LOG_NOISE_RANGE
    found = optimize.minimize(value_and_grad, start, jac=True, method="L-BFGS-B", bounds=bounds)
    return math.exp(found.x[-1]), np.exp(found.x[:d])


def run_case(arm: str, seed: int) -> dict[str, Any]:
    torch.set_num_threads(1)
    task, config = Task(), CALIBRATION.check_config()
    gp = feed_stream(
        CALIBRATION.new_critic(arm, task, CAPACITY, config),
        stream(task, config, seed),
        config.episodes_per_batch,
    )
    x, y, batch = gp.window.data()
    with torch.no_grad():
        w = gp._age_weights(batch, float(gp.block_forgetting)).to(y)
        yn = gp._standardised(x, y)
        ls, var = gp.kernel.lengthscale.detach().clone(), gp.kernel.variance.detach().clone()
        Kzz, Kxz = gp._basis_covariances(x)
        own = laplacian(x, gp.basis_inputs, ls, var)
        assert float((own - Kxz).abs().max()) <= 1e-10, "the engine's covariance differs"
        K = laplacian(x, x, ls, var)
        projection = Projection(Kzz, Kxz, float(var))
        kxx = var.expand(len(yn))
        vfe = best_noise(lambda s: float(projection.negative_bound(yn, s / w, kxx)))
        exact = best_noise(lambda s: float(exact_nlml(K, yn, s / w)))
        # added after the run (not in the plan): what the basis leaves unexplained of the prior,
        # the bound's trace term per point before its division by the noise
        trace = float((var - projection.q_diag()).clamp_min(0).mean())
    # The targets' noise: the variance of fresh returns about their mean, at evenly spaced
    # window states, in the GP's standardised units.
    rows = np.linspace(0, len(x) - 1, TRUTH_STATES).round().astype(int)
    states = x[rows].numpy()
    _, stderr = mc_value_at(task, states, TRUTH_ROLLOUTS, seed=20_000 + seed)
    truth = float(np.mean(stderr**2 * TRUTH_ROLLOUTS)) / float(gp.y_scale) ** 2
    start = np.log(np.r_[ls.numpy(), float(var), exact])
    free_noise, free_ls = exact_free(x, yn, w, start)
    return {
        "arm": arm,
        "seed": seed,
        "points": len(x),
        "min_weight": float(w.min()),
        "gp": float(gp.noise_var),
        "truth": truth,
        "vfe": vfe,
        "exact": exact,
        "exact_free": free_noise,
        "trace": trace,
        "lengthscale": ls.tolist(),
        "exact_free_lengthscale": free_ls.tolist(),
        "variance": float(var),
    }


def geometric(values: list[float]) -> str:
    """Geometric mean [min, max]."""
    v = np.array(values)
    return f"{np.exp(np.log(v).mean()):.3g} [{v.min():.3g}, {v.max():.3g}]"


def read(rows: list[dict[str, Any]]) -> str:
    by_arm = {
        arm: sorted((r for r in rows if r["arm"] == arm), key=lambda r: r["seed"]) for arm in ARMS
    }
    ratios = [
        [arm] + [geometric([r[a] / r[b] for r in cases]) for a, b in RATIOS.values()]
        for arm, cases in by_arm.items()
    ]
    noise = [
        [arm, str(r["seed"])]
        + [f"{r[k]:.4g}" for k in ("gp", "truth", "vfe", "exact", "exact_free", "trace")]
        + [
            ", ".join(f"{v:.3g}" for v in r["lengthscale"]),
            ", ".join(f"{v:.3g}" for v in r["exact_free_lengthscale"]),
            f"{r['min_weight']:.3g}",
        ]
        for arm, cases in by_arm.items()
        for r in cases
    ]
    return "\n".join(
        [
            f"## Where the noise comes from, {CAPACITY} basis vectors (PLAN.md, addendum 4)",
            "",
            "Ratios of noise variances on each GP's retained window after the whole stream:",
            "geometric mean over stream seeds 0-4 [min, max].",
            "",
            markdown_table(["arm", *RATIOS], ratios),
            "",
            "Per case (standardised units; `truth`: mean variance of",
            f"{TRUTH_ROLLOUTS} fresh returns at {TRUTH_STATES} window states; lengthscales",
            "(angle, angular velocity) of the GP and of the exact GP fitted freely; the",
            "smallest forgetting weight in the window; `trace`, added after the first run:",
            "the mean of `k(x, x) - q(x, x)` over the window, what the basis vectors leave",
            "unexplained of the prior variance at each point):",
            "",
            markdown_table(
                [
                    "arm",
                    "seed",
                    "gp",
                    "truth",
                    "vfe",
                    "exact",
                    "exact_free",
                    "trace",
                    "lengthscale, gp",
                    "lengthscale, exact_free",
                    "min weight",
                ],
                noise,
            ),
        ]
    )


def main() -> None:
    cases = [(arm, seed) for arm in ARMS for seed in SEEDS]
    rows = []
    with worker_pool(2) as pool:
        futures = [pool.submit(run_case, *case) for case in cases]
        for future in tqdm(cf.as_completed(futures), total=len(futures), unit="case"):
            rows.append(future.result())
    print(read(rows))


if __name__ == "__main__":
    main()
