"""sb3_geogp.toolbox.provenance: what the engine hash covers, and the machine it records."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from sb3_geogp.toolbox.provenance import engine_files

# The package root and the warning helper change no number the engine computes.
_NOT_NUMERICS = {"__init__.py", "kernels/__init__.py", "user_warnings.py"}


def test_engine_hash_covers_every_module_the_engine_loads() -> None:
    code = (
        "import sys, sb3_geogp\n"
        "for name, m in sys.modules.items():\n"
        "    if name.startswith('sb3_geogp') and getattr(m, '__file__', None):\n"
        "        print(m.__file__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = {path.split("sb3_geogp/", 1)[1] for path in out.stdout.split()}
    assert "sparse_gp.py" in loaded and "adaptation.py" in loaded
    assert loaded - _NOT_NUMERICS <= set(engine_files())


def test_the_record_names_the_cpu_kernels_torch_was_made_to_use() -> None:
    # torch reads ATEN_CPU_CAPABILITY once at start-up, hence a fresh interpreter.
    code = (
        "import json\n"
        "from sb3_geogp.toolbox.provenance import provenance\n"
        "print(json.dumps(provenance()))\n"
    )
    env = {**os.environ, "ATEN_CPU_CAPABILITY": "default", "OMP_NUM_THREADS": "1"}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    record = json.loads(out.stdout)
    assert record["machine"]["torch_cpu_capability"] == "DEFAULT"
    assert record["machine"]["torch_threads"] == 1
