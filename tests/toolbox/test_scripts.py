"""Loading a script by path: executed once, registered, and refused under a taken name."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from sb3_geogp.toolbox.scripts import load_script


@pytest.fixture
def script(tmp_path: Path) -> Path:
    path = tmp_path / "table.py"
    # A dataclass resolves its annotations through sys.modules[__module__]: it fails unless
    # the module is registered before it runs, as an import would register it.
    path.write_text(
        "from __future__ import annotations\n"
        "import dataclasses\n"
        "RUNS = []\n"
        "RUNS.append(1)\n"
        "@dataclasses.dataclass\n"
        "class Row:\n"
        "    x: int\n"
    )
    return path


@pytest.fixture(autouse=True)
def _unregister() -> Iterator[None]:
    yield
    for name in [n for n in sys.modules if n.startswith("_t_")]:
        del sys.modules[name]


def test_loads_registers_and_returns_the_same_module_twice(script: Path) -> None:
    module = load_script(script, "_t_table")
    assert module.Row(3).x == 3 and module.RUNS == [1]
    assert sys.modules["_t_table"] is module
    again = load_script(str(script), "_t_table")
    assert again is module and again.RUNS == [1]  # not executed a second time


def test_two_scripts_of_one_file_name_load_under_two_names(tmp_path: Path) -> None:
    for folder, value in (("a", 1), ("b", 2)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "table.py").write_text(f"VALUE = {value}\n")
    a = load_script(tmp_path / "a" / "table.py", "_t_a")
    b = load_script(tmp_path / "b" / "table.py", "_t_b")
    assert (a.VALUE, b.VALUE) == (1, 2)
    with pytest.raises(ValueError, match="already taken"):
        load_script(tmp_path / "b" / "table.py", "_t_a")
    assert sys.modules["_t_a"] is a
    with pytest.raises(ValueError, match="already taken"):
        load_script(tmp_path / "a" / "table.py", "json")  # never shadows a real module


def test_missing_file_and_failing_script_leave_nothing_registered(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no script"):
        load_script(tmp_path / "absent.py", "_t_absent")
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('boom')\n")
    with pytest.raises(RuntimeError, match="boom"):
        load_script(broken, "_t_broken")
    assert "_t_absent" not in sys.modules and "_t_broken" not in sys.modules
