"""The toolbox and the studies import where stable-baselines3 cannot be imported."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

_WITHOUT_SB3 = textwrap.dedent(
    """
    import importlib, importlib.abc, pkgutil, sys

    class Refuse(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] == "stable_baselines3":
                raise ImportError(f"{name} is not installed here")
            return None

    sys.meta_path.insert(0, Refuse())
    import sb3_geogp.studies
    import sb3_geogp.toolbox

    for package in (sb3_geogp.toolbox, sb3_geogp.studies):
        for module in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            importlib.import_module(module.name)
    loaded = [m for m in sys.modules if m.split(".")[0] == "stable_baselines3"]
    assert not loaded, loaded
    print("ok")
    """
)


def test_toolbox_and_studies_need_no_stable_baselines3() -> None:
    pytest.importorskip("matplotlib")  # the studies' plots
    done = subprocess.run(
        [sys.executable, "-c", _WITHOUT_SB3], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"
