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
