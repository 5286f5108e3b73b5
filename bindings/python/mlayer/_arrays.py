"""Borrowing numpy arrays as C pointers: strict about outputs, easy about inputs.

`ffi.from_buffer` refuses non-contiguous buffers but silently reinterprets a wrong dtype, so
every check happens here before a pointer crosses into C.
"""
from __future__ import annotations

import math

import numpy as np

from ._native import ffi
from .errors import InvalidArgumentError


def as_f64(arr, name: str, *, ndim: tuple[int, ...] | int | None = None,
           last: tuple[int, ...] | None = None) -> np.ndarray:
    """Convert an input once to a C-contiguous float64 array (no copy when it already is one).

    ndim: allowed numbers of dimensions; last: required trailing shape, e.g. (4,).
    """
    try:
        a = np.ascontiguousarray(arr, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentError(f"{name}: cannot convert to a float64 array ({e})") from None
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if a.ndim not in allowed:
            raise InvalidArgumentError(
                f"{name}: expected {' or '.join(map(str, allowed))} dimensions, got shape {a.shape}")
    if last is not None and a.shape[a.ndim - len(last):] != tuple(last):
        raise InvalidArgumentError(
            f"{name}: expected a trailing shape {tuple(last)}, got shape {a.shape}")
    return a


def check_out(arr: np.ndarray, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """An output array must be float64, C-contiguous, writable and of exactly this shape."""
    if not isinstance(arr, np.ndarray) or arr.dtype != np.float64 or arr.shape != tuple(shape) \
            or not arr.flags.c_contiguous or not arr.flags.writeable:
        raise InvalidArgumentError(
            f"{name}: need a writable C-contiguous float64 array of shape {tuple(shape)}")
    return arr


def ptr(arr: np.ndarray, ctype: str = "double *"):
    """A C pointer into a checked float64 C-contiguous array (the array must stay referenced)."""
    assert arr.dtype == np.float64 and arr.flags.c_contiguous
    if arr.size == 0:
        return ffi.NULL
    return ffi.cast(ctype, ffi.from_buffer(arr))


def ptr_out(arr: np.ndarray, ctype: str = "double *"):
    """Like ptr, for an output array (refuses read-only buffers)."""
    assert arr.dtype == np.float64 and arr.flags.c_contiguous
    if arr.size == 0:
        return ffi.NULL
    return ffi.cast(ctype, ffi.from_buffer(arr, require_writable=True))


def require_finite(a: np.ndarray, name: str) -> None:
    if not np.isfinite(a).all():
        raise InvalidArgumentError(f"{name}: contains NaN or infinite values")


def finite(v, name: str) -> float:
    """``float(v)``, or InvalidArgumentError naming ``name`` when v is not a finite number."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"{name} must be a number, got {v!r}") from None
    if not math.isfinite(f):
        raise InvalidArgumentError(f"{name} must be finite, got {v!r}")
    return f
