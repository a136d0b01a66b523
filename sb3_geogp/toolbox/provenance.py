"""Which code made a result: the git commit and whether the checkout differed from it, one
hash of the whole engine, package versions, and the machine: the CPU kernels torch chose, the
CPU's model and flags (a run is bit-reproducible only where they agree).

The engine hash covers every source file of the GP engine together (:data:`ENGINE_FILES`), so
a result names the engine it measured in one string; a refactor that moves code between
engine files changes it once, and the commit says which refactor.
"""

from __future__ import annotations

import hashlib
import platform
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import torch

import sb3_geogp

#: The engine's source files, as glob patterns relative to the package (whichever exist).
ENGINE_FILES = (
    "kernels.py",
    "kernels/*.py",
    "graph.py",
    "sparse_gp.py",
    "trends.py",
    "posterior_cache.py",
    "rollback.py",
    "saved_state.py",
    "adaptation.py",
    "defaults.py",
    "targets.py",
)

_PACKAGE = Path(sb3_geogp.__file__).resolve().parent
#: Packages whose versions are recorded where they are loaded.
_IF_LOADED = ("stable_baselines3", "gymnasium")


def engine_files() -> list[str]:
    """The engine's source files present in this installation, relative to the package, sorted."""
    found = {p for pattern in ENGINE_FILES for p in _PACKAGE.glob(pattern) if p.is_file()}
    return sorted(p.relative_to(_PACKAGE).as_posix() for p in found)


def engine_sha256() -> str:
    """SHA-256 over the engine's source files (:func:`engine_files`), names and contents.

    Each file contributes its relative path and byte length before its bytes, so that no two
    different sets of files hash alike.
    """
    digest = hashlib.sha256()
    for name in engine_files():
        content = (_PACKAGE / name).read_bytes()
        digest.update(f"{name}\0{len(content)}\0".encode())
        digest.update(content)
    return digest.hexdigest()


def _git(*args: str) -> str | None:
    """``git`` run where the package's source lives: its output, or ``None`` where it fails,
    where git is not installed, or where the package is not tracked by the repository found
    (e.g. installed into a virtual environment inside some other checkout)."""

    def run(*command: str) -> str | None:
        try:
            done = subprocess.run(
                ["git", "-C", str(_PACKAGE), *command],
                capture_output=True,
                text=True,
                timeout=10,
                check=False,
            )
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    if run("ls-files", "--error-unmatch", "__init__.py") is None:
        return None
    return run(*args)


def git_commit() -> str | None:
    """The commit checked out where the package's source lives; ``None`` outside a git checkout
    (or where the package is not tracked by the repository found, or git is missing)."""
    return _git("rev-parse", "HEAD")


def git_dirty() -> bool | None:
    """Whether the checkout's tracked files differ from :func:`git_commit` (a result made with
    uncommitted changes is not that commit's); ``None`` where there is no commit to compare."""
    status = _git("status", "--porcelain", "--untracked-files=no")
    return None if status is None else status != ""


def package_versions(*modules: ModuleType) -> dict[str, str]:
    """Python's version and ``__version__`` of torch, numpy, sb3_geogp, ``modules``, and of
    stable_baselines3 and gymnasium wherever the process has imported them (a run that trains
    with them has; the toolbox itself imports neither).

    Parameters
    ----------
    *modules : module
        Further imported packages to record (e.g. ``sb3_contrib``), keyed by their module name.
    """
    versions = {"python": platform.python_version()}
    loaded = [sys.modules[name] for name in _IF_LOADED if name in sys.modules]
    for module in (torch, *loaded, *modules, np, sb3_geogp):
        versions[module.__name__] = str(module.__version__)
    return versions


def cpu(cpuinfo: str | None = None) -> dict[str, str | None]:
    """The CPU's model name and a digest of its feature flags, from ``/proc/cpuinfo``.

    Runs stored in sessions 41-42 did not reproduce bit for bit in session 43 although torch's
    capability (``"AVX512"``), its threads, the versions and the commit all matched
    (docs/results.md, "Limits of this comparison"). Another CPU model is such a cause: in
    session 69 a run's own commit, re-run on an AMD EPYC machine, did not give the run its
    Intel Xeon machine had stored (same capability, threads and versions), and MKL's code path
    alone changed a run on one machine (docs/results.md, "The table's stored PPO
    MountainCarContinuous runs"). These two fields tell such machines apart.

    Parameters
    ----------
    cpuinfo : str, optional
        The text of ``/proc/cpuinfo``; by default read from the file where it exists (Linux).

    Returns
    -------
    dict
        ``cpu_model`` (the first processor's ``model name``, else :func:`platform.processor`,
        else None) and ``cpu_flags_sha256`` (the first 12 hex digits of the SHA-256 of its
        sorted, space-joined ``flags``; None where there are none).
    """
    if cpuinfo is None:
        path = Path("/proc/cpuinfo")
        cpuinfo = path.read_text() if path.is_file() else ""
    first: dict[str, str] = {}
    for line in cpuinfo.split("\n\n", 1)[0].splitlines():
        key, sep, value = line.partition(":")
        if sep:
            first.setdefault(key.strip(), value.strip())
    flags = " ".join(sorted(first.get("flags", "").split()))
    return {
        "cpu_model": first.get("model name") or platform.processor() or None,
        "cpu_flags_sha256": hashlib.sha256(flags.encode()).hexdigest()[:12] if flags else None,
    }


def machine() -> dict[str, Any]:
    """The facts of this machine that decide a run's last bits.

    The same code and versions draw different runs from one seed on CPUs where torch
    dispatches to other vector kernels (e.g. AVX2 against AVX512; docs/results.md, "Limits of
    this comparison"), on CPUs of one capability but another model, and its thread count can
    change the order of a reduction.

    Returns
    -------
    dict
        ``arch`` (``platform.machine()``), ``torch_cpu_capability`` (the kernels torch
        dispatches to, e.g. ``"AVX512"``), ``torch_threads``, and :func:`cpu`'s
        ``cpu_model`` and ``cpu_flags_sha256``.
    """
    return {
        "arch": platform.machine(),
        "torch_cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "torch_threads": torch.get_num_threads(),
        **cpu(),
    }


def provenance(*modules: ModuleType) -> dict[str, Any]:
    """Everything above as one JSON-compatible record.

    Parameters
    ----------
    *modules : module
        As :func:`package_versions`.

    Returns
    -------
    dict
        ``git_commit`` (str or None), ``git_dirty`` (bool or None), ``engine_sha256``,
        ``engine_files``, ``versions`` and ``machine`` (:func:`machine`).
    """
    return {
        "git_commit": git_commit(),
        "git_dirty": git_dirty(),
        "engine_sha256": engine_sha256(),
        "engine_files": engine_files(),
        "versions": package_versions(*modules),
        "machine": machine(),
    }
