"""sb3_geogp.toolbox.provenance: what the engine hash covers, and the machine it records."""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

import sb3_geogp.toolbox.provenance as provenance_module
from sb3_geogp.toolbox.provenance import cpu, engine_files, git_commit, git_dirty

# The package root, the warning helper and the option checks change no number the engine
# computes.
_NOT_NUMERICS = {"__init__.py", "kernels/__init__.py", "user_warnings.py", "options.py"}


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
    assert record["machine"]["cpu_model"] == cpu()["cpu_model"]


_CPUINFO = """processor\t: 0
vendor_id\t: GenuineIntel
model name\t: Example CPU @ 2.00GHz
flags\t\t: sse2 avx512f avx2 fpu

processor\t: 1
model name\t: Another CPU
flags\t\t: fpu
"""


def test_cpu_reads_the_first_processor_and_digests_its_sorted_flags() -> None:
    record = cpu(_CPUINFO)
    assert record["cpu_model"] == "Example CPU @ 2.00GHz"
    expected = hashlib.sha256(b"avx2 avx512f fpu sse2").hexdigest()[:12]
    assert record["cpu_flags_sha256"] == expected
    # The same flags in another order are the same machine; one flag more is not.
    reordered = _CPUINFO.replace("sse2 avx512f avx2 fpu", "fpu avx2 sse2 avx512f")
    assert cpu(reordered)["cpu_flags_sha256"] == expected
    added = _CPUINFO.replace("sse2 avx512f avx2 fpu", "sse2 avx512f avx2 fpu amx_tile")
    assert cpu(added)["cpu_flags_sha256"] != expected


def test_cpu_without_cpuinfo_names_no_flags() -> None:
    record = cpu("")
    assert record["cpu_flags_sha256"] is None
    assert record["cpu_model"] == (platform.processor() or None)


def test_git_dirty_is_gits_own_status_of_the_tracked_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A package in a fresh repository: clean once committed, dirty after a tracked file is
    edited (an untracked file does not count), clean again once committed; outside a
    repository neither the commit nor the status is known."""
    package = tmp_path / "repo" / "pkg"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("x = 1\n")
    monkeypatch.setattr(provenance_module, "_PACKAGE", package)

    def git(*args: str) -> None:
        identity = ["-c", "user.name=t", "-c", "user.email=t@t"]
        subprocess.run(["git", "-C", str(package), *identity, *args], check=True,
                       capture_output=True)  # fmt: skip

    assert (git_commit(), git_dirty()) == (None, None)
    git("init", "-q")
    git("add", "__init__.py")
    git("commit", "-qm", "first")
    assert git_commit() is not None and git_dirty() is False
    (package / "notes.txt").write_text("untracked\n")
    assert git_dirty() is False
    (package / "__init__.py").write_text("x = 2\n")
    assert git_dirty() is True
    git("commit", "-qam", "second")
    assert git_dirty() is False and provenance_module.provenance()["git_dirty"] is False


def test_versions_name_stable_baselines3_and_gymnasium_once_loaded() -> None:
    import gymnasium
    import stable_baselines3

    versions = provenance_module.package_versions()
    assert versions["stable_baselines3"] == stable_baselines3.__version__
    assert versions["gymnasium"] == gymnasium.__version__
