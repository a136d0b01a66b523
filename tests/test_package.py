"""The package's layers: the engine imports and runs without stable-baselines3 or gymnasium."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tarfile
import textwrap
from pathlib import Path

import pytest

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
    # the engine's modules the docstrings name, for tab completion
    assert {"adaptation", "defaults", "kernels", "sparse_gp"} <= set(dir(sb3_geogp))


def test_package_is_typed_and_licensed() -> None:
    from importlib import metadata, resources

    assert (resources.files("sb3_geogp") / "py.typed").is_file()
    meta = metadata.metadata("sb3_geogp")
    assert meta["License-Expression"] == "MIT"
    assert any(name.endswith("LICENSE") for name in meta.get_all("License-File") or [])


_ROOT = Path(__file__).resolve().parents[1]


def test_readme_links_work_off_the_repository() -> None:
    """PyPI shows the README without the repository: a relative link would be broken there."""
    readme = (_ROOT / "README.md").read_text()
    targets = re.findall(r"\]\(([^)]+)\)", readme)
    assert targets, "the README's links were not found"
    relative = [t for t in targets if not t.startswith(("https://", "#"))]
    assert not relative, f"relative links in README.md: {relative}"


def test_source_distribution_ships_every_path_the_readme_names(tmp_path: Path) -> None:
    build_meta = pytest.importorskip("setuptools.build_meta")
    readme = (_ROOT / "README.md").read_text()
    named = set(re.findall(r"`((?:docs|examples)/[\w./-]+\.(?:md|py))`", readme))
    named |= set(re.findall(r"`python (examples/\S+\.py)", readme))
    assert "docs/method.md" in named and "docs/results.md" in named
    # A copy without build leftovers: setuptools reuses an existing egg-info's file list.
    source = tmp_path / "source"
    shutil.copytree(_ROOT, source, ignore=shutil.ignore_patterns("*.egg-info", ".*", "runs"))
    cwd = os.getcwd()
    os.chdir(source)
    try:
        archive = build_meta.build_sdist(str(tmp_path))
    finally:
        os.chdir(cwd)
    with tarfile.open(tmp_path / archive) as sdist:
        shipped = {name.split("/", 1)[1] for name in sdist.getnames() if "/" in name}
    missing = sorted(p for p in named if p not in shipped)
    assert not missing, f"named in README.md but not in the sdist: {missing}"
    assert all((_ROOT / p).is_file() for p in named)


def _heading_anchors(text: str) -> set[str]:
    """The anchors GitHub gives a markdown file's headings: lower case, punctuation but ``-``
    and ``_`` dropped, spaces as ``-``, a repeated one suffixed ``-1``, ``-2``..."""
    anchors: set[str] = set()
    seen: dict[str, int] = {}
    for line in text.splitlines():
        heading = re.match(r"#{1,6} (.*)", line)
        if heading is None:
            continue
        slug = re.sub(r"[^\w\- ]", "", heading.group(1).replace("`", "").strip().lower())
        slug = slug.replace(" ", "-")
        anchors.add(f"{slug}-{seen[slug]}" if slug in seen else slug)
        seen[slug] = seen.get(slug, 0) + 1
    return anchors


def test_links_to_sections_of_the_docs_resolve() -> None:
    """Every ``[...](#anchor)`` and ``[...](file.md#anchor)`` in README.md and docs/ names a
    heading of its file (results.md alone has some 130 such links across 8,000 lines)."""
    files = [_ROOT / "README.md", *sorted((_ROOT / "docs").glob("*.md"))]
    anchors = {f: _heading_anchors(f.read_text()) for f in files}
    broken = []
    for f in files:
        for target, anchor in re.findall(r"\]\(([\w./-]*\.md)?#([^)\s]+)\)", f.read_text()):
            linked = (f.parent / target).resolve() if target else f
            if linked in anchors and anchor not in anchors[linked]:
                broken.append(f"{f.name}: {target}#{anchor}")
    assert sum(len(a) for a in anchors.values()) > 100
    assert not broken, broken
