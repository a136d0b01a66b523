"""Exploratory (session 60, not adopted): run an example script with the adaptation's rebuild
giving each retained point the on-line update's FITC-like noise instead of DTC's.

The on-line update absorbs a projected point with noise ``sigma_n^2 + gamma_x``,
``gamma_x = k(x, x) - k_xz K_zz^-1 k_zx`` (docs/method.md, section 2.2); the rebuild after a
refit (``SparseOnlineGP._rebuild``) gives it ``sigma_n^2`` (DTC). Here every rebuild's window
noise ``sigma_n^2 / w`` becomes ``(sigma_n^2 + gamma_x) / w``, as forgetting tempers the whole
likelihood of a point on-line; the summary of older points and the hyperparameter fit (Titsias'
bound) are unchanged. Usage, from the repository root::

    python results/fitc_rebuild/fitc_rebuild.py examples/fixed_policy_check.py [its options]
    python results/fitc_rebuild/fitc_rebuild.py examples/critic_fit.py [its options]

Only in-process runs are patched: pass ``--workers 1`` to ``critic_fit.py``.
"""

from __future__ import annotations

import functools
import runpy
import sys
from typing import Any

from torch import Tensor

from sb3_geogp import sparse_gp
from sb3_geogp.adaptation import Projection, sparse_posterior

_dtc_rebuild = sparse_gp.SparseOnlineGP._rebuild


@functools.wraps(_dtc_rebuild)
def _fitc_rebuild(self: sparse_gp.SparseOnlineGP, *args: Any) -> tuple[Tensor, Tensor]:
    sigma2 = self.noise_var

    def fitc_posterior(*args: Any) -> tuple[Tensor, Tensor]:
        # As _rebuild calls sparse_posterior: (Kzz, Kxz, y, noise, variance, summary).
        Kzz, Kxz, y, noise, variance, summary = args
        projection = Projection(Kzz, Kxz, variance)
        gamma = (variance - projection.q_diag()).clamp_min(0)
        # noise is sigma_n^2 / w: scaling by (1 + gamma / sigma_n^2) gives (sigma_n^2 + gamma) / w.
        return projection.posterior(y, noise * (1 + gamma / sigma2), summary)

    sparse_gp.sparse_posterior = fitc_posterior
    try:
        return _dtc_rebuild(self, *args)
    finally:
        sparse_gp.sparse_posterior = sparse_posterior


if __name__ == "__main__":
    sparse_gp.SparseOnlineGP._rebuild = _fitc_rebuild  # type: ignore[method-assign]
    script, sys.argv = sys.argv[1], sys.argv[1:]
    runpy.run_path(script, run_name="__main__")
