"""Loading a script by path: executed once, registered, and refused under a taken name."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg, load_script


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


def test_help_shows_every_default_once() -> None:
    """An option without help shows its default as its help, one with help gets it appended,
    one whose help already says it is left alone; flags and required options show none."""
    parser = argparse.ArgumentParser(formatter_class=DefaultsHelpFormatter)
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1])
    parser.add_argument("--scale", type=float, default=1.5, help="budget factor")
    parser.add_argument("--out", default="runs", help="folder (default: runs, beside you)")
    parser.add_argument("--quick", action="store_true", help="tiny sizes")
    parser.add_argument("--ceiling", type=int, default=0)
    parser.add_argument("--runs", required=True, help="the runs")
    parser.add_argument("--trend", default="none", help="trend (the PPO default since 0.9: level)")
    parser.add_argument("--threads", default="1", help="threads, or 'default'")
    text = re.sub(r"\s+", " ", parser.format_help())
    assert "--seeds SEEDS [SEEDS ...] default: [0, 1]" in text
    assert "--scale SCALE budget factor (default: 1.5)" in text
    assert text.count("default: runs") == 1 and "--ceiling CEILING default: 0" in text
    assert "tiny sizes (default" not in text and "the runs (default" not in text
    # A help that names some other default still shows this option's own.
    assert "(the PPO default since 0.9: level) (default: none)" in text
    assert "threads, or 'default' (default: 1)" in text


def test_count_arg_takes_integers_from_one() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=count_arg)
    assert parser.parse_args(["--seeds", "3"]).seeds == 3
    for bad, why in (("0", "must be at least 1, got 0"), ("-5", "at least 1"), ("2.5", "integer")):
        with pytest.raises(SystemExit):
            parser.parse_args(["--seeds", bad])
        with pytest.raises(argparse.ArgumentTypeError, match=why):
            count_arg(bad)
