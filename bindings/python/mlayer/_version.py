"""The package's version, in a module of its own so that any module can import it without
importing the package (``mlayer/__init__.py`` imports every subject)."""
from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version as _dist_version

from ._native import ffi as _ffi, lib as _lib

__all__ = ["__version__", "library_version"]


def library_version() -> str:
    """Version of the C library that is actually loaded.

    Returns
    -------
    str
        E.g. ``"0.2.0"`` (``mlr_version_string``).
    """
    return _ffi.string(_lib.mlr_version_string()).decode()


try:
    __version__ = _dist_version("mlayer")
except PackageNotFoundError:  # running from a build tree
    __version__ = library_version()
