"""Validation of options: one message for a misspelt option, a saved state built with other
options, or a count that is not a positive integer, whichever class checks it."""

from __future__ import annotations

import difflib
import numbers
from collections.abc import Collection, Iterable
from typing import Any

import numpy as np
import torch


def positive_int(name: str, value: Any) -> int:
    """``value`` as an ``int`` if it is an integer (Python's or NumPy's, not a ``bool``) of at
    least 1; else ``ValueError`` naming ``name``."""
    return _int_at_least(name, value, 1, "a positive integer")


def non_negative_int(name: str, value: Any) -> int:
    """``value`` as an ``int`` if it is an integer (Python's or NumPy's, not a ``bool``) of at
    least 0; else ``ValueError`` naming ``name``."""
    return _int_at_least(name, value, 0, "a non-negative integer")


def _int_at_least(name: str, value: Any, minimum: int, kind: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be {kind}, got {value!r} ({type(value).__name__})")
    if value < minimum:
        raise ValueError(f"{name} must be {kind}, got {value}")
    return int(value)


def check_number(name: str, value: Any) -> None:
    """Refuse, by a ``TypeError`` naming ``name``, a ``value`` that is not a real number (a 0-d
    tensor or array counts) or is a ``bool`` (``True`` is no variance of 1)."""
    scalar = isinstance(value, torch.Tensor | np.ndarray) and value.ndim == 0
    scalar = scalar and value.dtype not in (torch.bool, np.bool_)
    if isinstance(value, bool | np.bool_) or not (isinstance(value, numbers.Real) or scalar):
        raise TypeError(f"{name} must be a number, got {value!r} ({type(value).__name__})")


def non_negative_number(name: str, value: Any) -> float:
    """``value`` as a ``float`` if it is a finite real number of at least 0 (:func:`check_number`
    says what counts); else ``TypeError`` or ``ValueError`` naming ``name``."""
    check_number(name, value)
    if not (value >= 0 and np.isfinite(float(value))):
        raise ValueError(f"{name} must be a non-negative finite number, got {value}")
    return float(value)


def check_same_options(
    what: str,
    saved: Any,
    current: dict[str, Any],
    ignore: Collection[str] = (),
    first: str | None = None,
) -> None:
    """Raise ``ValueError`` naming the first option in which ``saved`` differs from ``current``
    (options in ``ignore`` are stored but free to differ; ``first``, the one that says what
    the object is, is compared before the others, whose names it decides)."""
    if not isinstance(saved, dict):
        raise ValueError(f"the saved {what} options are not a dict: {saved!r}")
    keys = sorted((set(saved) | set(current)) - set(ignore))
    for key in sorted(keys, key=lambda k: k != first):
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
