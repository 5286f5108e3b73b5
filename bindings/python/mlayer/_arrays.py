"""Borrowing numpy arrays as C pointers: strict about outputs, easy about inputs.

`ffi.from_buffer` refuses non-contiguous buffers but silently reinterprets a wrong dtype, so
every check happens here before a pointer crosses into C.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ._native import ffi
from .errors import InvalidArgumentError


def as_f64(arr: Any, name: str, *, ndim: tuple[int, ...] | int | None = None,
           last: tuple[int, ...] | None = None) -> NDArray[np.float64]:
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
                f"{name}: expected {' or '.join(map(str, allowed))} dimensions, got shape "
                f"{a.shape}")
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


def _c_layout(arr: Any) -> None:
    if not isinstance(arr, np.ndarray) or arr.dtype != np.float64 or not arr.flags.c_contiguous:
        raise TypeError("mlayer internal: a C pointer needs a C-contiguous float64 array, got "
                        f"{getattr(arr, 'dtype', type(arr).__name__)}")


def ptr(arr: NDArray[Any], ctype: str = "double *") -> Any:
    """A C pointer into a checked float64 C-contiguous array (the array must stay referenced)."""
    _c_layout(arr)
    if arr.size == 0:
        return ffi.NULL
    return ffi.cast(ctype, ffi.from_buffer(arr))


def ptr_out(arr: NDArray[Any], ctype: str = "double *") -> Any:
    """Like ptr, for an output array (refuses read-only buffers)."""
    _c_layout(arr)
    if arr.size == 0:
        return ffi.NULL
    return ffi.cast(ctype, ffi.from_buffer(arr, require_writable=True))


def require_finite(a: np.ndarray, name: str) -> None:
    if not np.isfinite(a).all():
        raise InvalidArgumentError(f"{name}: contains NaN or infinite values")


def number(v: Any, name: str) -> float:
    """``float(v)``, or InvalidArgumentError naming ``name`` when v is not a number. For values
    the C core checks itself (its message names the option by the same name)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"{name} must be a number, got {v!r}") from None


def finite(v: Any, name: str) -> float:
    """``float(v)``, or InvalidArgumentError naming ``name`` when v is not a finite number."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"{name} must be a number, got {v!r}") from None
    if not math.isfinite(f):
        raise InvalidArgumentError(f"{name} must be finite, got {v!r}")
    return f


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (MemAvailable of /proc/meminfo, else the
    free physical pages), None when the system does not say."""
    try:
        with open("/proc/meminfo", "rb") as f:
            for line in f:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        import os
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return None


def check_memory(n_bytes: float, what: str) -> None:
    """MemoryError naming ``what`` (the argument that sets the size) when an allocation of
    n_bytes would not fit in the memory available now; call it before allocating."""
    avail = available_memory()
    if avail is not None and n_bytes > avail:
        raise MemoryError(f"{what} needs about {n_bytes / 2**30:.3g} GiB, more than the "
                          f"{avail / 2**30:.3g} GiB of memory available; use a smaller value")
