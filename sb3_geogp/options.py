"""Validation of options: one message for a misspelt option, a saved state built with other
options, or a count that is not a positive integer, whichever class checks it."""

from __future__ import annotations

import difflib
from collections.abc import Collection, Iterable
from typing import Any

import numpy as np


def positive_int(name: str, value: Any) -> int:
    """``value`` as an ``int`` if it is an integer (Python's or NumPy's, not a ``bool``) of at
    least 1; else ``ValueError`` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(
            f"{name} must be a positive integer, got {value!r} ({type(value).__name__})"
        )
    if value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value}")
    return int(value)


def check_same_options(
    what: str, saved: Any, current: dict[str, Any], ignore: Collection[str] = ()
) -> None:
    """Raise ``ValueError`` naming the first option in which ``saved`` differs from ``current``
    (options in ``ignore`` are stored but free to differ)."""
    if not isinstance(saved, dict):
        raise ValueError(f"the saved {what} options are not a dict: {saved!r}")
    for key in sorted((set(saved) | set(current)) - set(ignore)):
        if saved.get(key) != current.get(key):
            raise ValueError(
                f"the state was saved with {what} option {key}={saved.get(key)!r}, but this "
                f"{what} has {key}={current.get(key)!r}; build it with the same options to load "
                "the state"
            )


def unknown_option(what: str, given: Iterable[str], accepted: Collection[str]) -> str | None:
    """The first of ``given`` not in ``accepted``, as a message naming the closest accepted
    name and the whole list (Python's own ``TypeError`` names neither); ``None`` if all are
    accepted."""
    unknown = [name for name in given if name not in accepted]
    if not unknown:
        return None
    close = difflib.get_close_matches(unknown[0], accepted, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return (
        f"unknown option {unknown[0]!r} of {what}{hint}; the options are: "
        f"{', '.join(sorted(accepted))}"
    )
