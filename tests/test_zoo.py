"""rl-baselines3-zoo: the shipped yaml files train with our policy and callback (tiny budget).

Needs the optional ``rl_zoo3`` package; skipped without it.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from stable_baselines3 import A2C, PPO

from sb3_geogp import GPActorCriticPolicy, LaplacianKernel, RBFKernel

pytest.importorskip("rl_zoo3")

ZOO_DIR = Path(__file__).resolve().parents[1] / "examples" / "zoo"


@pytest.mark.parametrize(
    ("algo", "n_timesteps"),
    [
        ("ppo", 500),  # one rollout: 4 envs x 1024 steps, then 10 epochs
        ("a2c", 128),  # two rollouts: 8 envs x 8 steps
    ],
)
def test_zoo_train_with_gp_critic(algo: str, n_timesteps: int, tmp_path: Path) -> None:
    config = ZOO_DIR / f"{algo}_geogp.yml"
    log_folder = tmp_path / "logs"
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", algo, "--env", "Pendulum-v1"]
    cmd += ["-conf", str(config), "-n", str(n_timesteps), "--eval-freq", "-1"]
    cmd += ["-f", str(log_folder), "--seed", "1", "--num-threads", "1"]
    env = dict(os.environ, OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    proc = subprocess.run(
        cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300, check=False
    )
    assert proc.returncode == 0, f"{' '.join(cmd)}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"

    saved = sorted(log_folder.glob(f"{algo}/Pendulum-v1_*/Pendulum-v1.zip"))
    assert len(saved) == 1, proc.stdout[-3000:]
    model = {"ppo": PPO, "a2c": A2C}[algo].load(saved[0], device="cpu")
    policy = model.policy
    assert isinstance(policy, GPActorCriticPolicy)
    # As the config gives them (model.save keeps the algorithm's policy_kwargs): no forgetting,
    # so the critic starts from the policy's default; the default kernel under PPO is the
    # Laplacian one, the A2C config names the RBF one (A2C's default since 0.22).
    expected: dict[str, Any] = {"max_basis": 256}
    if algo == "a2c":
        expected.update(kernel="rbf")
    assert policy.gp_kwargs == expected
    kernel = {"ppo": LaplacianKernel, "a2c": RBFKernel}[algo]
    assert isinstance(policy.gp.kernel, kernel)
    assert "forgetting=1.0" not in proc.stderr  # no warning that A2C's GP forgets nothing
    assert policy.gp.n_basis > 0  # GPValueCallback fed the critic
