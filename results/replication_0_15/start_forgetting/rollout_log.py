"""Per rollout of PPO Acrobot-v1: what the 0.15 default GP critic and 0.13's (``forgetting=1.0``)
choose and how they fit (exploratory, session 26).

    python results/replication_0_15/start_forgetting/rollout_log.py 12 15 \
        > results/replication_0_15/start_forgetting/rollout_log.txt

Reuses ``examples/acrobot_stall.py`` (the comparison's PPO settings, 30,000 steps) and adds, per
rollout, the forgetting in effect after the GP's adaptation (``lam``: what it applies to the next
rollout), the out-of-sample explained variance and NLPD of the rollout before it was absorbed,
the target units and the level of the trend.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "examples"))

import acrobot_stall as stall

stall.CRITICS.clear()
stall.CRITICS.update({"0.15": ("laplacian", {}), "0.13": ("laplacian", {"forgetting": 1.0})})
_record = stall.RolloutRecorder._on_rollout_end


def _on_rollout_end(self: stall.RolloutRecorder) -> None:
    _record(self)
    gp = self.model.policy.gp  # type: ignore[union-attr]
    stats = gp.last_stats
    self.rows[-1].update(
        n_batches=int(gp.n_batches),
        lam=float(gp.block_forgetting),
        ev=stats.get("explained_variance", float("nan")),
        nlpd=stats.get("nlpd", float("nan")),
        scale=float(gp.y_scale),
        mean=float(gp.y_mean),
        level=float(gp.trend_coef[-1]),
    )


stall.RolloutRecorder._on_rollout_end = _on_rollout_end  # type: ignore[method-assign]
ROW = (
    "  t={timesteps:6d} ended={ended:3d} goals={goals:3d} corr={corr:+.2f} nb={n_batches:3d} "
    "lam={lam:.3f} ev={ev:+.2f} nlpd={nlpd:.2f} scale={scale:.1f} mean={mean:.1f} "
    "level={level:.1f}"
)
for label in stall.CRITICS:
    for seed in map(int, sys.argv[1:]):
        print(label, seed)
        for row in stall.run(label, seed, 30_000):
            print(ROW.format(**row))
        sys.stdout.flush()
