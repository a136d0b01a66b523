"""Figure of the mean advantage per A2C rollout (session 28): ``advantages.json``,
``advantages_rising.json`` and ``advantages_mlp.json`` of ``advantages.py`` -> ``advantages.png``.

    python results/a2c_level/plot_advantages.py
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).parent
STEPS = 30_000
#: Rollouts averaged per point of a curve.
WINDOW = 25
LABELS = {
    "none": "GP, 0.17 default (no trend)",
    "level": "GP, level",
    "rising_level": "GP, rising level",
    "mlp": "SB3 MLP critic",
}


def smoothed(values: list[float]) -> np.ndarray:
    return np.convolve(values, np.ones(WINDOW) / WINDOW, mode="valid")


def main() -> None:
    runs: dict[str, list[float]] = {}
    for name in ("advantages.json", "advantages_rising.json", "advantages_mlp.json"):
        runs.update(json.loads((HERE / name).read_text()))
    envs = sorted({key.split()[0] for key in runs})
    fig, axes = plt.subplots(1, len(envs), figsize=(5.2 * len(envs), 3.8))
    for ax, env in zip(np.atleast_1d(axes), envs, strict=True):
        for colour, trend in zip(("C0", "C1", "C2", "C3"), LABELS, strict=True):
            curves = [smoothed(v) for k, v in runs.items() if k.split()[:2] == [env, trend]]
            for i, curve in enumerate(curves):
                steps = np.linspace(0, STEPS, len(curve) + WINDOW)[WINDOW:]
                ax.plot(steps, curve, color=colour, lw=0.8, alpha=0.7,
                        label=f"{LABELS[trend]} ({len(curves)} seeds)" if i == 0 else None)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_title(f"A2C {env}")
        ax.set_xlabel("environment steps")
        ax.set_ylabel(f"mean advantage per rollout\n(mean of {WINDOW} rollouts)")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.suptitle("The critic's bias as A2C sees it: > 0 values below the returns, < 0 above")
    fig.tight_layout()
    fig.savefig(HERE / "advantages.png", dpi=110)


if __name__ == "__main__":
    main()
