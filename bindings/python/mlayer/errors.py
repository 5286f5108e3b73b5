"""Exceptions and the single choke point that turns C status codes into them.

Every exception derives from :class:`Error` and also from the matching builtin, so
``except ValueError`` keeps working. Positive statuses (usable result, with a caveat) become
:class:`MlayerWarning` warnings.
"""
from __future__ import annotations

import warnings

from ._native import ffi, lib


def _name(code: int) -> str:
    return ffi.string(lib.mlr_status_name(code)).decode()


def _text(code: int) -> str:
    return ffi.string(lib.mlr_status_string(code)).decode()


class Error(Exception):
    """Base class of every mlayer error. ``code`` is the C status (0 when raised in Python)."""

    def __init__(self, message: str, code: int = 0):
        super().__init__(message)
        self.code = code

    @property
    def status_name(self) -> str:
        return _name(self.code) if self.code else ""


class InvalidArgumentError(Error, ValueError):
    """An argument is out of range, of the wrong shape, or not finite."""


class SingularMatrixError(Error, ArithmeticError):
    """The linear system has no unique solution for the given observations."""


class ParseError(Error, ValueError):
    """A file could not be parsed; ``path`` and ``line`` say where."""

    def __init__(self, message: str, code: int = 0, path=None, line: int | None = None):
        super().__init__(message, code)
        self.path = path
        self.line = line


class MlayerIOError(Error, OSError):
    """Reading or writing a file failed."""


class UnsupportedError(Error, NotImplementedError):
    """Not available in this build (e.g. mlayer built without CHOLMOD) or for this object."""


class MissingDependencyError(Error, ImportError):
    """A feature needs an optional dependency that is not installed. The message is one line
    naming the feature and the extra that installs it (``... pip install 'mlayer[plot]'``);
    ``module`` is the module that could not be imported, ``extra`` the package extra, and
    ``feature`` what needed it. Raised by :func:`mlayer._optional.require` before any work; an
    ImportError, so ``except ImportError`` keeps working."""

    def __init__(self, message: str, module: str = "", extra: str = "", feature: str = ""):
        super().__init__(message)
        self.name = module  # ImportError's attribute: the module that was not found
        self.module, self.extra, self.feature = module, extra, feature


class MlayerWarning(UserWarning):
    """A result is usable but deserves attention (e.g. an ill-conditioned system)."""


class ParseWarning(MlayerWarning):
    """A BVH file was read although it deviates from the format (extra or missing frame lines,
    data after the frames, no final line end, a truncated file kept on request). The message
    starts with ``file:line:``; ``path``, ``line``, ``column`` and ``kind`` (the C warning
    code's name, e.g. ``"extra_frames"``) are set as attributes."""

    def __init__(self, message: str, path=None, line: int | None = None,
                 column: int | None = None, kind: str | None = None):
        super().__init__(message)
        self.path, self.line, self.column, self.kind = path, line, column, kind


_BY_CODE = {
    lib.MLR_E_INVALID_ARG: InvalidArgumentError,
    lib.MLR_E_OVERFLOW: InvalidArgumentError,
    lib.MLR_E_SINGULAR: SingularMatrixError,
    lib.MLR_E_PARSE: ParseError,
    lib.MLR_E_IO: MlayerIOError,
    lib.MLR_E_UNSUPPORTED: UnsupportedError,
}


def check(code: int, where: str, diag=None) -> int:
    """Raise for a negative status, warn for a positive one, return the code otherwise.

    ``diag`` is an optional ``mlr_diag *`` whose message is appended to the error.
    """
    if code < 0:
        if code == lib.MLR_E_NO_MEMORY:
            raise MemoryError(f"{where}: {_text(code)} [{_name(code)}]")
        detail = ""
        if diag is not None and diag.message[0] != b"\0":
            detail = ": " + ffi.string(diag.message).decode(errors="replace")
        cls = _BY_CODE.get(code, Error)
        raise cls(f"{where}: {_text(code)}{detail} [{_name(code)}]", code)
    if code > 0:
        warnings.warn(f"{where}: {_text(code)} [{_name(code)}]", MlayerWarning, stacklevel=3)
    return code


__all__ = ["Error", "InvalidArgumentError", "SingularMatrixError", "ParseError",
           "MlayerIOError", "UnsupportedError", "MissingDependencyError", "MlayerWarning", "check"]
