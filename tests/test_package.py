"""The package's layers: the engine imports and runs without stable-baselines3 or gymnasium."""

from __future__ import annotations

import subprocess
import sys
import textwrap

_ENGINE_WITHOUT_SB3 = textwrap.dedent(
    """
    import importlib.abc, sys

    class Refuse(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in ("stable_baselines3", "gymnasium"):
                raise ImportError(f"{name} is not installed here")
            return None

    sys.meta_path.insert(0, Refuse())
    import numpy as np
    import sb3_geogp
    from sb3_geogp import GeodesicKernel, RBFKernel, SparseOnlineGP

    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(300, 2))
    y = np.sin(3 * x).sum(1)
    for kernel in (GeodesicKernel(), RBFKernel()):
        gp = SparseOnlineGP(2, kernel=kernel, max_basis=32)
        gp.update(x, y)
        mean, var = gp.predict(x)
        resid = float(np.mean((mean.numpy() - y) ** 2) / np.var(y))
        assert resid < 0.1 and bool((var >= 0).all()), (type(kernel).__name__, resid)
    loaded = [m for m in sys.modules if m.split(".")[0] in ("stable_baselines3", "gymnasium")]
    assert not loaded, loaded
    try:
        sb3_geogp.GPActorCriticPolicy
    except ImportError as err:
        assert "is not installed here" in str(err)
    else:
        raise AssertionError("the SB3 adapter loaded without stable_baselines3")
    print("engine ok")
    """
)


def test_engine_works_where_stable_baselines3_cannot_be_imported() -> None:
    done = subprocess.run(
        [sys.executable, "-c", _ENGINE_WITHOUT_SB3], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "engine ok"


def test_adapter_and_envs_load_on_first_use() -> None:
    import sb3_geogp
    from sb3_geogp.callbacks import GPValueCallback
    from sb3_geogp.policies import GPActorCriticPolicy

    assert sb3_geogp.GPActorCriticPolicy is GPActorCriticPolicy
    assert sb3_geogp.GPValueCallback is GPValueCallback
    assert "sb3_geogp/PaperPendulum-v0" in sb3_geogp.envs.PAPER_PENDULUM_ID
    assert set(sb3_geogp.__all__) <= set(dir(sb3_geogp))


def test_package_is_typed_and_licensed() -> None:
    from importlib import metadata, resources

    assert (resources.files("sb3_geogp") / "py.typed").is_file()
    meta = metadata.metadata("sb3_geogp")
    assert meta["License-Expression"] == "MIT"
    assert any(name.endswith("LICENSE") for name in meta.get_all("License-File") or [])
