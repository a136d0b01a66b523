"""The neural baseline: an MLP value regressor of SB3's default critic size.

SB3's ``ActorCriticPolicy`` builds its value network as two hidden layers of 64 tanh units
followed by a linear output (``net_arch=dict(vf=[64, 64])``, ``activation_fn=nn.Tanh``).
:func:`fit_mlp` trains that architecture by mini-batch Adam on the squared error to the same
Monte Carlo returns the GPs see, keeping the weights of the epoch with the lowest error on
held-out validation episodes (early stopping: the MLP's only tuned quantity).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn


@dataclass(frozen=True)
class MLPSettings:
    """Training settings of the MLP baseline.

    Attributes
    ----------
    hidden : tuple of int
        Hidden layer widths (SB3 default critic: (64, 64)).
    epochs : int
        Passes over the training states.
    batch_size : int
    lr : float
        Adam step size (SB3's PPO default, 3e-4, is slow here; 1e-3 is used).
    """

    hidden: tuple[int, ...] = (64, 64)
    epochs: int = 150
    batch_size: int = 256
    lr: float = 1e-3


class MLPValue(nn.Module):
    """Tanh MLP on inputs divided by ``input_scale``, output in target units.

    Parameters
    ----------
    input_scale : sequence of float, length d
        Inputs are divided by it (e.g. the half-widths of the state box).
    hidden : tuple of int
    y_mean, y_scale : float
        Target standardisation (the network fits ``(y - y_mean) / y_scale``).
    """

    input_scale: torch.Tensor

    def __init__(
        self, input_scale: np.ndarray, hidden: tuple[int, ...], y_mean: float, y_scale: float
    ) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        width = len(input_scale)
        for h in hidden:
            layers += [nn.Linear(width, h), nn.Tanh()]
            width = h
        layers.append(nn.Linear(width, 1))
        self.net = nn.Sequential(*layers)
        self.register_buffer("input_scale", torch.as_tensor(input_scale, dtype=torch.float32))
        self.y_mean, self.y_scale = float(y_mean), float(y_scale)

    def standardised(self, x: torch.Tensor) -> torch.Tensor:
        """Standardised prediction for ``x : (n, d)``, shape (n,)."""
        return self.net(x / self.input_scale)[:, 0]

    @torch.no_grad()
    def predict(self, x: np.ndarray) -> np.ndarray:
        """Value at ``x : (n, d)`` in target units, shape (n,)."""
        xt = torch.as_tensor(x, dtype=torch.float32)
        return (self.standardised(xt) * self.y_scale + self.y_mean).numpy().astype(np.float64)


def fit_mlp(
    x: np.ndarray,
    y: np.ndarray,
    x_val: np.ndarray,
    y_val: np.ndarray,
    input_scale: np.ndarray,
    settings: MLPSettings,
    seed: int,
) -> MLPValue:
    """Train :class:`MLPValue` on ``(x, y)``; keep the epoch best on ``(x_val, y_val)``.

    Parameters
    ----------
    x : ndarray, shape (n, d)
    y : ndarray, shape (n,)
    x_val : ndarray, shape (n_val, d)
    y_val : ndarray, shape (n_val,)
    input_scale : ndarray, shape (d,)
    settings : MLPSettings
    seed : int
        Seeds the initialisation and the mini-batch order.

    Returns
    -------
    MLPValue
    """
    torch.manual_seed(seed)
    y_mean, y_scale = float(y.mean()), float(y.std()) or 1.0
    model = MLPValue(input_scale, settings.hidden, y_mean, y_scale)
    xt = torch.as_tensor(x, dtype=torch.float32)
    yt = torch.as_tensor((y - y_mean) / y_scale, dtype=torch.float32)
    xv = torch.as_tensor(x_val, dtype=torch.float32)
    yv = torch.as_tensor((y_val - y_mean) / y_scale, dtype=torch.float32)
    opt = torch.optim.Adam(model.parameters(), lr=settings.lr)
    gen = torch.Generator().manual_seed(seed)
    best, best_state = float("inf"), copy.deepcopy(model.state_dict())
    for _ in range(settings.epochs):
        for idx in torch.randperm(len(xt), generator=gen).split(settings.batch_size):
            opt.zero_grad()
            loss = ((model.standardised(xt[idx]) - yt[idx]) ** 2).mean()
            loss.backward()
            opt.step()
        with torch.no_grad():
            val = float(((model.standardised(xv) - yv) ** 2).mean())
        if val < best:
            best, best_state = val, copy.deepcopy(model.state_dict())
    model.load_state_dict(best_state)
    return model
