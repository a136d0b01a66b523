"""The actor's observation normalisation: ``VecNormalize``'s ``norm_obs`` for the actor alone.

SB3's MLP critic is usually tuned in ``VecNormalize``, which normalises the observations every
network sees by running statistics. The GP critic cannot follow moving units: its basis
vectors stay where they were fed. :class:`ActorObservationNormalizer` normalises the actor's
inputs alone, so the actor gets what ``VecNormalize`` gives it while the critic keeps raw
observations, and changes its statistics only between rollouts, so that PPO's probability
ratios compare the actor's outputs under the statistics the rollout was collected with.
"""

from __future__ import annotations

import numpy as np
import torch as th
from stable_baselines3.common.running_mean_std import RunningMeanStd
from torch import nn

#: ``VecNormalize``'s defaults (``clip_obs``, ``epsilon``).
CLIP_OBS = 10.0
EPSILON = 1e-8


class ActorObservationNormalizer(nn.Module):
    r"""Running-statistics normalisation of the actor's inputs, changed only when published.

    .. math::

        y = \operatorname{clip}\Big(\frac{x - \mu}{\sqrt{\sigma^2 + \epsilon}}, -c, c\Big)

    with :math:`\mu, \sigma^2` the mean and variance of every input observed until the last
    :meth:`publish`, computed as ``VecNormalize`` computes them (SB3's ``RunningMeanStd``,
    starting from mean 0, variance 1 and a count of 1e-4), :math:`c` = ``clip_obs`` and
    :math:`\epsilon` = ``epsilon`` (``VecNormalize``'s defaults). Before the first
    :meth:`publish` it is that clip of :math:`x / \sqrt{1 + \epsilon}`.

    Parameters
    ----------
    dim : int
        Input features.
    clip_obs : float
        :math:`c > 0`.
    epsilon : float
        :math:`\epsilon > 0`.

    Notes
    -----
    The statistics are buffers (``mean``, ``var``: published; ``running_mean``,
    ``running_var``, ``running_count``: observed), so they are saved and loaded with the
    policy's state. It has no parameters: the optimiser and the actor's initialisation do
    not see it.
    """

    mean: th.Tensor
    var: th.Tensor
    running_mean: th.Tensor
    running_var: th.Tensor
    running_count: th.Tensor

    def __init__(self, dim: int, clip_obs: float = CLIP_OBS, epsilon: float = EPSILON) -> None:
        super().__init__()
        if not clip_obs > 0 or not epsilon > 0:
            raise ValueError(
                f"clip_obs and epsilon must be positive, got clip_obs={clip_obs!r}, "
                f"epsilon={epsilon!r}"
            )
        self.dim = int(dim)
        self.clip_obs = float(clip_obs)
        self.epsilon = float(epsilon)
        start = RunningMeanStd(shape=(self.dim,))
        for name, value in (("mean", start.mean), ("var", start.var)):
            self.register_buffer(name, th.tensor(value, dtype=th.float64))
            self.register_buffer(f"running_{name}", th.tensor(value, dtype=th.float64))
        self.register_buffer("running_count", th.tensor(start.count, dtype=th.float64))

    def forward(self, x: th.Tensor) -> th.Tensor:
        """Normalise ``x``, shape (N, dim), by the published statistics, in ``x``'s dtype."""
        scaled = (x.to(self.mean.dtype) - self.mean) / th.sqrt(self.var + self.epsilon)
        return scaled.clamp(-self.clip_obs, self.clip_obs).to(x.dtype)

    def observe(self, x: np.ndarray) -> None:
        """Add inputs, shape (N, dim), to the running statistics (not yet to the published).

        Raises
        ------
        ValueError
            If ``x`` is not (N, dim) or holds NaN or inf; the statistics are then unchanged.
        """
        x = np.asarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.dim:
            raise ValueError(f"expected inputs of shape (N, {self.dim}), got {x.shape}")
        if not np.isfinite(x).all():
            raise ValueError("the actor's inputs hold NaN or inf; nothing was observed")
        if len(x) == 0:
            return
        stats = RunningMeanStd(shape=(self.dim,))
        stats.mean = self.running_mean.cpu().numpy().copy()
        stats.var = self.running_var.cpu().numpy().copy()
        stats.count = float(self.running_count)
        stats.update(x)
        self.running_mean.copy_(th.as_tensor(stats.mean))
        self.running_var.copy_(th.as_tensor(stats.var))
        self.running_count.fill_(stats.count)

    def publish(self) -> None:
        """Normalise by the running statistics from now on."""
        self.mean.copy_(self.running_mean)
        self.var.copy_(self.running_var)

    def extra_repr(self) -> str:
        return f"dim={self.dim}, clip_obs={self.clip_obs}, epsilon={self.epsilon}"
