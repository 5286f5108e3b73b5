"""The compiled cffi extension: `ffi` and `lib` for the rest of the package."""
from ._mlayer import ffi, lib  # noqa: F401

__all__ = ["ffi", "lib"]
