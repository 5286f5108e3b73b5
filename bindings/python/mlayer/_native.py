"""The compiled cffi extension: `ffi` and `lib` for the rest of the package.

The extension has no type stubs: both are typed ``Any`` here, the one place (the C functions'
signatures are checked by the C compiler against the cdef, not by mypy).
"""
from typing import Any

from ._mlayer import ffi as _ffi, lib as _lib

ffi: Any = _ffi
lib: Any = _lib

__all__ = ["ffi", "lib"]
