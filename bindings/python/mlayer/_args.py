"""Validation of scalar arguments, one meaning everywhere.

An integer argument (a count, a seed, a frame index, a thread count) is a Python ``int`` or a
NumPy integer: not a bool, and not a float even when it is whole (``kmeans(X, 3.0)`` raises,
as ``range(3.0)`` does), so a value computed by division is caught before it is truncated.
Every failure is an :class:`~mlayer.errors.InvalidArgumentError` that names the argument.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from .errors import InvalidArgumentError

__all__ = ["integer", "threads", "default_threads"]


def integer(v: Any, name: str, lo: int | None = None, hi: int | None = None) -> int:
    """``v`` as an int when it is an integer in ``[lo, hi]`` (either bound optional); else
    InvalidArgumentError: ``"{name} must be an integer >= lo, got v"``."""
    ok = isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
    if ok:
        v = int(v)
        ok = (lo is None or v >= lo) and (hi is None or v <= hi)
    if not ok:
        if lo is not None and hi is not None:
            bounds = f" in {lo} .. {hi}"
        elif lo is not None:
            bounds = f" >= {lo}"
        elif hi is not None:
            bounds = f" <= {hi}"
        else:
            bounds = ""
        raise InvalidArgumentError(f"{name} must be an integer{bounds}, got {v!r}")
    return v


def default_threads() -> int:
    """Threads used when none is asked for.

    Results do not depend on the thread count.

    Returns
    -------
    int
        The CPUs this process may run on, at most 64.
    """
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        n = os.cpu_count() or 1
    return max(1, min(64, n))


def threads(v: int | None, name: str = "threads") -> int:
    """A C function's thread count: None -> 0 (the library picks), else an integer >= 1."""
    return 0 if v is None else integer(v, name, 1)


def name_pairs(text: str, where: str, form: str, written: str) -> list[tuple[str, str]]:
    """``"A=B,C=D"`` as [("A", "B"), ("C", "D")], the names stripped: the one parser of the
    joint name pairs that mirror's pairs, retarget's map and the CLI take. An item without
    exactly one ``=`` or with an empty name: InvalidArgumentError ``"{where}: 'x' is not {form}
    ({written} A=B,C=D)"``."""
    out = []
    for item in text.split(","):
        parts = [p.strip() for p in item.split("=")]
        if len(parts) != 2 or not parts[0] or not parts[1]:
            raise InvalidArgumentError(f"{where}: {item.strip()!r} is not {form} ({written} "
                                       "A=B,C=D)")
        out.append((parts[0], parts[1]))
    return out


def name_pair_items(value: Any, where: str, a: str, b: str) -> list[tuple[str, str]]:
    """A mapping {a: b} or a sequence of (a, b) joint names as a list of pairs; anything else:
    InvalidArgumentError naming ``where``."""
    from collections.abc import Mapping
    items = value.items() if isinstance(value, Mapping) else value
    try:
        out = [tuple(p) for p in items]
    except TypeError:
        raise InvalidArgumentError(f"{where} must be 'auto', a mapping {{{a}: {b}}} or a "
                                   f"sequence of ({a}, {b}) names, got {value!r}") from None
    for p in out:
        if len(p) != 2 or not all(isinstance(n, str) for n in p):
            raise InvalidArgumentError(f"{where}: {p!r} is not a pair of joint names")
    return out
