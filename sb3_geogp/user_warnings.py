"""The package's warning category, and warnings that point at the user's own line.

``GPCriticWarning`` subclasses ``UserWarning``, so ``warnings.filterwarnings("ignore",
category=GPCriticWarning)`` silences ours without hiding anybody else's. A warning raised while
SB3 runs ``learn`` would by default point into SB3's ``callbacks.py``; :func:`warn_user` walks
the stack past sb3_geogp, Stable-Baselines3, sb3-contrib, rl-baselines3-zoo and torch frames
(torch's ``no_grad`` wraps the engine's methods) to the
first line of the user's code.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

#: Packages whose frames stand between a warning and the user's code.
_LIBRARIES = ("sb3_geogp", "stable_baselines3", "sb3_contrib", "rl_zoo3", "torch")


class GPCriticWarning(UserWarning):
    """A warning about how the GP critic is used (filter it by this category)."""


def warn_user(message: str) -> None:
    """Warn with :class:`GPCriticWarning`, attributed to the first frame outside the libraries."""
    # With the separator: a user's sb3_geogp_helpers.py beside the package is not the package.
    roots = tuple(
        str(Path(module.__file__).parent) + os.sep
        for name in _LIBRARIES
        if (module := sys.modules.get(name)) is not None and module.__file__ is not None
    )
    frame, level = sys._getframe(1), 2
    while frame.f_back is not None and frame.f_code.co_filename.startswith(roots):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, GPCriticWarning, stacklevel=level)
