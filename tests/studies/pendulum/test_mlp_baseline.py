"""The MLP baseline: SB3's default critic shape, fits a smooth function, early stopping."""

from __future__ import annotations

import numpy as np
from torch import nn

from sb3_geogp.studies.pendulum.mlp_baseline import MLPSettings, MLPValue, fit_mlp


def test_architecture_is_sb3_default_critic() -> None:
    model = MLPValue(np.ones(2), (64, 64), 0.0, 1.0)
    layers = list(model.net)
    assert [type(m) for m in layers] == [nn.Linear, nn.Tanh, nn.Linear, nn.Tanh, nn.Linear]
    assert [m.out_features for m in layers if isinstance(m, nn.Linear)] == [64, 64, 1]


def test_fits_a_smooth_function_in_target_units() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(2000, 2))
    y = 10.0 + 5.0 * np.sin(2 * x[:, 0]) * x[:, 1]
    xv = rng.uniform(-1, 1, size=(200, 2))
    yv = 10.0 + 5.0 * np.sin(2 * xv[:, 0]) * xv[:, 1]
    model = fit_mlp(x, y, xv, yv, np.ones(2), MLPSettings(epochs=60), seed=0)
    err = np.mean((model.predict(xv) - yv) ** 2)
    assert err < 0.05 * yv.var()


def test_keeps_the_best_validation_epoch() -> None:
    # Validation targets unrelated to training: the kept weights are those of the epoch
    # with the lowest validation error, so more epochs can never make it worse.
    rng = np.random.default_rng(1)
    x, y = rng.normal(size=(300, 2)), rng.normal(size=300)
    xv, yv = rng.normal(size=(100, 2)), rng.normal(size=100)
    errors = []
    for epochs in (1, 20):
        model = fit_mlp(x, y, xv, yv, np.ones(2), MLPSettings(epochs=epochs), seed=3)
        errors.append(np.mean((model.predict(xv) - yv) ** 2))
    assert errors[1] <= errors[0] + 1e-9
