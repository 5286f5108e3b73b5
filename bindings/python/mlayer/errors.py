"""Exceptions and the single choke point that turns C status codes into them.

Every exception derives from :class:`Error` and also from the matching builtin, so
``except ValueError`` keeps working. Positive statuses (usable result, with a caveat) become
:class:`MlayerWarning` warnings.
"""
from __future__ import annotations

import os
import warnings
from typing import Any

from ._native import ffi, lib


def _name(code: int) -> str:
    return ffi.string(lib.mlr_status_name(code)).decode()


def _text(code: int) -> str:
    return ffi.string(lib.mlr_status_string(code)).decode()


class Error(Exception):
    """Base class of every mlayer error.

    Parameters
    ----------
    message : str
        The error text.
    code : int, optional
        The C status (an ``mlr_status``; 0, the default, when raised in Python).
    """

    def __init__(self, message: str, code: int = 0) -> None:
        super().__init__(message)
        self.code = code

    @property
    def status_name(self) -> str:
        """The C name of :attr:`code` (e.g. ``"MLR_E_INVALID_ARG"``), ``""`` when it is 0."""
        return _name(self.code) if self.code else ""


class InvalidArgumentError(Error, ValueError):
    """An argument is out of range, of the wrong shape, or not finite."""


class SingularMatrixError(Error, ArithmeticError):
    """The linear system has no unique solution for the given observations."""


class ParseError(Error, ValueError):
    """A file could not be parsed; ``path`` and ``line`` say where.

    Parameters
    ----------
    message : str
        The error text.
    code : int, optional
        The C status (0 when raised in Python).
    path : str or os.PathLike, optional
        The file.
    line : int, optional
        The line (1-based) where parsing failed.
    """

    #: set by the BVH readers: the column (1-based) and the reason without the place
    column: int | None
    reason: str

    def __init__(self, message: str, code: int = 0, path: str | os.PathLike[str] | None = None,
                 line: int | None = None) -> None:
        super().__init__(message, code)
        self.path = path
        self.line = line


class MlayerIOError(Error, OSError):
    """Reading or writing a file failed."""


class UnsupportedError(Error, NotImplementedError):
    """Not available in this build (e.g. mlayer built without CHOLMOD) or for this object."""


class MissingDependencyError(Error, ImportError):
    """A feature needs an optional dependency that is not installed.

    Raised by ``mlayer._optional.require`` before any work; an ImportError, so
    ``except ImportError`` keeps working.

    Parameters
    ----------
    message : str
        One line naming the feature and the extra that installs it
        (``... pip install 'mlayer[plot]'``).
    module : str, optional
        The module that could not be imported (also set as ImportError's ``name``).
    extra : str, optional
        The mlayer extra that installs it.
    feature : str, optional
        What needed it.
    """
    name: str | None
    module: str
    extra: str
    feature: str

    def __init__(self, message: str, module: str = "", extra: str = "",
                 feature: str = "") -> None:
        super().__init__(message)
        self.name = module  # ImportError's attribute: the module that was not found
        self.module, self.extra, self.feature = module, extra, feature


class MlayerWarning(UserWarning):
    """A result is usable but deserves attention (e.g. an ill-conditioned system)."""


class ParseWarning(MlayerWarning):
    """A BVH file was read although it deviates from the format.

    For instance extra or missing frame lines, data after the frames, no final line end, or a
    truncated file kept on request. The arguments are kept as attributes of the same names.

    Parameters
    ----------
    message : str
        The warning text; it starts with ``file:line:``.
    path : str or os.PathLike, optional
        The file.
    line, column : int, optional
        Where in the file (1-based).
    kind : str, optional
        The C warning code's name, e.g. ``"extra_frames"``.
    """
    path: str | os.PathLike[str] | None
    line: int | None
    column: int | None
    kind: str | None

    def __init__(self, message: str, path: str | os.PathLike[str] | None = None,
                 line: int | None = None, column: int | None = None,
                 kind: str | None = None) -> None:
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


def check(code: int, where: str, diag: Any = None) -> int:
    """Raise for a negative status, warn for a positive one, return the code otherwise.

    Parameters
    ----------
    code : int
        An ``mlr_status`` returned by the C library.
    where : str
        What was called; the message starts with it.
    diag : cffi ``mlr_diag *``, optional
        Its message, when not empty, is appended to the error's.

    Returns
    -------
    int
        ``code`` (0 or a positive status, after a :class:`MlayerWarning` for the latter).

    Raises
    ------
    MemoryError
        For ``MLR_E_NO_MEMORY``.
    Error
        For any other negative status: the subclass of :class:`Error` that matches it
        (:class:`InvalidArgumentError`, :class:`SingularMatrixError`, :class:`ParseError`,
        :class:`MlayerIOError`, :class:`UnsupportedError`), or :class:`Error` itself.
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
