"""What the standalone scripts (``examples/*.py``, ``results/*/table.py``) and the command
line share: importing a script as a module, and ``--help`` that shows every default.

The scripts are not a package, and several share a file name (``table.py``, ``read.py``), so
a reading that reuses another reading, or a test that calls a script's functions, loads the
file by path under a name of its own.
"""

from __future__ import annotations

import argparse
import copy
import importlib.util
import sys
from pathlib import Path
from types import ModuleType


def count_arg(text: str) -> int:
    """An ``argparse`` type: an integer of at least 1 (a budget, a number of seeds, workers or
    grid points), refused in argparse's one line otherwise (0 is no "unset")."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def load_script(path: str | Path, name: str) -> ModuleType:
    """Execute the script at ``path`` as the module ``name`` and return it.

    The module is registered in :data:`sys.modules` under ``name`` before it runs, as an
    import would, so that its dataclasses and pickled objects resolve through it; a second
    call with the same ``name`` returns the module already loaded.

    Parameters
    ----------
    path : str or Path
        The script's file.
    name : str
        The module name to give it; unique among loaded modules (two scripts named
        ``table.py`` need two names).

    Returns
    -------
    ModuleType
        The executed module.

    Raises
    ------
    FileNotFoundError
        If ``path`` is not a file.
    ValueError
        If ``name`` is already the name of a module loaded from another file.
    """
    path = Path(path).resolve()
    if not path.is_file():
        raise FileNotFoundError(f"no script at {path}: pass the path of a .py file")
    loaded = sys.modules.get(name)
    if loaded is not None:
        if Path(getattr(loaded, "__file__", "") or "").resolve() != path:
            raise ValueError(
                f"module name {name!r} is already taken by {loaded!r}; give {path} another name"
            )
        return loaded
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None  # a .py path always has a loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]  # a failed import leaves no half-run module behind
        raise
    return module


#: How a help text states its option's own default.
_SAYS_DEFAULT = ("%(default)", "(default", "default:")


class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """``--help`` with every option's default: appended to its help unless the help already
    says its default, and as the whole help of an option that has none (not for flags,
    required options or options without a default)."""

    @staticmethod
    def _has_default(action: argparse.Action) -> bool:
        # identity, not ==: a default of 0 is shown (0 == False)
        unset = action.default is None or action.default is False
        unset = unset or action.default is argparse.SUPPRESS
        return bool(action.option_strings) and not action.required and not unset

    def _format_action(self, action: argparse.Action) -> str:
        if action.help is None and self._has_default(action):
            action = copy.copy(action)
            action.help = "default: %(default)s"
        return super()._format_action(action)

    def _get_help_string(self, action: argparse.Action) -> str | None:
        # Only a help that states its own default is left as it is: one that mentions another
        # default ("the PPO default since 0.9: level") still gets this option's.
        says_default = any(m in (action.help or "") for m in _SAYS_DEFAULT)
        if says_default or not self._has_default(action):
            return action.help
        return super()._get_help_string(action)
