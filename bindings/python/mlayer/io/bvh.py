"""BVH files: read them into a :class:`~mlayer.Motion`, write a Motion back.

Parsing and formatting run in the C core (``mlr_bvh_read_memory``, ``mlr_bvh_write_file``).
The reader accepts LF/CRLF/CR line ends, tabs, 0 to 6 channels per joint in any order, position
channels on any joint (they replace the joint's OFFSET) and a different Euler order on every
joint. A file that does not parse raises :class:`~mlayer.ParseError` with ``path``, ``line`` and
``column`` set and a message such as ``"walk.bvh:12: expected '{' after the joint name"``;
a file that cannot be opened raises the usual :class:`OSError` subclass
(``FileNotFoundError``, ``PermissionError``, ...).

The writer keeps the hierarchy, End Sites, channel layout and Euler orders; it writes enough
digits that reading the file back gives the same motion (rotations within about 1e-8 rad) and
replaces the destination atomically (a temporary file in the same directory, then a rename).
"""
from __future__ import annotations

import contextlib
import contextvars
import os
import warnings
from collections.abc import Iterator
from typing import Any

from .._args import threads as _c_threads
from .._native import ffi, lib
from ..errors import InvalidArgumentError, ParseError, ParseWarning, check
from ..model.motion import MAX_FRAME_TIME, MIN_FRAME_TIME, Motion
from ..model.trimming import _read as trimmed_read, frames_arg
from ..model.units import units_arg
from ..model.up_axis import axis_name, default_up

__all__ = ["read_bvh", "write_bvh", "read_bvh_string", "write_bvh_string", "strict_reading"]


# The default of strict=None: False, unless inside strict_reading() (the CLI's --strict).
_STRICT = contextvars.ContextVar("mlayer_bvh_strict", default=False)
# The length unit of clips read with units=None: None, unless inside reading_units().
_UNITS: contextvars.ContextVar[str | None] = contextvars.ContextVar("mlayer_bvh_units",
                                                                  default=None)

_WARNING_KINDS = {1: "extra_frames", 2: "missing_frames", 3: "trailing_data",
                  4: "no_final_newline", 5: "truncated"}


@contextlib.contextmanager
def strict_reading(strict: bool = True) -> Iterator[None]:
    """A context in which the readers' ``strict=None`` means ``strict``.

    Within the block, :func:`read_bvh` / :func:`read_bvh_string` with ``strict=None`` read
    strictly (or leniently with ``strict_reading(False)``); the CLI's ``--strict`` uses it.

    Parameters
    ----------
    strict : bool, optional
        What ``strict=None`` means within the block.

    Yields
    ------
    None
        Nothing; the setting ends with the block.
    """
    token = _STRICT.set(bool(strict))
    try:
        yield
    finally:
        _STRICT.reset(token)


def _options(strict: bool | None, keep_truncated: bool, where: str) -> tuple[Any, int]:
    """The C options (and how many) for the strict / keep_truncated keywords."""
    if strict is None:
        strict = _STRICT.get()
    for name, v in (("strict", strict), ("keep_truncated", keep_truncated)):
        if not isinstance(v, bool):
            raise InvalidArgumentError(f"{where}: {name} must be True or False, got {v!r}")
    if strict and keep_truncated:
        raise InvalidArgumentError(f"{where}: keep_truncated=True needs strict=False")
    opts = ffi.new("mlr_bvh_read_option[1]")
    opts[0].key = lib.MLR_BVH_OPT_STRICT if strict else lib.MLR_BVH_OPT_KEEP_TRUNCATED
    opts[0].value = 1.0
    return opts, 1 if (strict or keep_truncated) else 0


def _warn(w: Any, name: str) -> None:
    """One ParseWarning per C warning (file and line in the message)."""
    kept = min(int(w.count), len(w.first))
    for i in range(kept):
        x = w.first[i]
        line = int(x.line) or None
        msg = ffi.string(x.message).decode("utf-8", errors="replace")
        where = f"{name}:{line}: " if line else f"{name}: "
        warnings.warn(ParseWarning(where + msg, path=name, line=line,
                                   column=int(x.column) or None,
                                   kind=_WARNING_KINDS.get(int(x.code), str(int(x.code)))),
                      stacklevel=3)
    if int(w.count) > kept:
        warnings.warn(ParseWarning(f"{name}: {int(w.count) - kept} more warnings", path=name),
                      stacklevel=3)


def _parse(data: bytes, name: str, threads: int, strict: bool | None,
           keep_truncated: bool) -> Motion:
    opts, n_opts = _options(strict, keep_truncated, "mlayer.read_bvh_string")
    out = ffi.new("mlr_motion **")
    diag = ffi.new("mlr_diag *")
    w = ffi.new("mlr_bvh_warnings *")
    buf = ffi.from_buffer(data)
    try:
        code = lib.mlr_bvh_read_memory_opts(buf, len(buf), threads, opts, n_opts, ffi.NULL, out,
                                            w, diag)
    finally:
        ffi.release(buf)
    m = _motion_or_raise(code, out, diag, name)
    _warn(w, name)
    return m


def _motion_or_raise(code: int, out: Any, diag: Any, name: str) -> Motion:
    """The Motion a C reader returned, or the exception for its status."""
    if code == lib.MLR_E_PARSE:
        line = int(diag.line)
        reason = ffi.string(diag.message).decode("utf-8", errors="replace")
        e = ParseError(f"{name}:{line}: {reason}" if line else f"{name}: {reason}", code,
                       path=name, line=line or None)
        e.column = int(diag.column) or None
        e.reason = reason
        raise e
    check(code, f"mlayer.read_bvh({name})", diag)
    m = Motion._adopt_c(out[0])  # the frames stay in the C block: no copy
    if not m.frame_time >= MIN_FRAME_TIME:
        raise ParseError(f"{name}: Frame Time {m.frame_time:g} s is below {MIN_FRAME_TIME:g} s "
                         "(over a million frames per second): not a frame time", path=name)
    if m.frame_time > MAX_FRAME_TIME:
        raise ParseError(f"{name}: Frame Time {m.frame_time:g} s is above {MAX_FRAME_TIME:g} s: "
                         "not a frame time", path=name)
    return m


def read_bvh(path: str | bytes | os.PathLike[str] | os.PathLike[bytes], *,
             strict: bool | None = None, keep_truncated: bool = False,
             threads: int | None = None, up: str | None = None, trim: str | int | None = None,
             units: str | None = None) -> Motion:
    """Read a BVH file.

    ``strict=False`` (the default) reads the usual deviations of files from the wild and
    issues a :class:`~mlayer.ParseWarning` (``file:line: reason``) for each: more frame lines
    than ``Frames:`` declares (all are read), up to 3 fewer, data after the frames (ignored),
    no line end after the last frame. A truncated file (more frames missing, or the last line
    cut) still raises ParseError unless ``keep_truncated=True``, which keeps its complete
    frames with a warning. ``strict=True`` raises ParseError for every deviation, as earlier
    versions did.

    Parameters
    ----------
    path : str, bytes or os.PathLike
        The file.
    strict : bool, optional
        None means False unless inside :func:`strict_reading`.
    keep_truncated : bool, optional
        Keep the complete frames of a truncated file (needs ``strict=False``).
    threads : int, optional
        How many threads parse the frame lines (the result is the same for every count);
        None (default) picks one per 512 KiB of frames, at most the machine's processors and
        8, so small files use one. The file is read into memory first, a large one (1 MiB or
        more) by the same threads, each its share (not memory-mapped: a file truncated by
        another process while it is parsed must not crash this one).
    up : {"x", "y", "z"}, optional
        The clip's up axis, kept as :attr:`Motion.up_axis`; None (the default, unless inside
        :func:`mlayer.model.up_axis.reading_up`) detects it from the motion.
    trim : "auto" or int, optional
        ``"auto"`` drops the T-pose and blend frames a converter put at the start
        (:func:`mlayer.lead_in`; the CMU conversions have them), an int N the first N frames;
        None (the default, unless inside :func:`mlayer.model.trimming.reading_trim`, the CLI's
        ``--trim``) keeps every frame.
    units : {"m", "cm", "mm", "in", "ft"}, optional
        The clip's length unit, kept as :attr:`Motion.units`; None (the default, unless the
        CLI's ``--units`` says otherwise) leaves it to the body height's suggestion.

    Returns
    -------
    Motion
        The clip.

    Raises
    ------
    mlayer.ParseError
        (with ``path``, ``line``, ``column``) When the file is not valid BVH.
    OSError
        When it cannot be read (``FileNotFoundError``, ``PermissionError``, ...).
    MemoryError
        When it does not fit in memory.

    Examples
    --------
    >>> import mlayer
    >>> m = mlayer.read_bvh(mlayer.data.sample_path())
    >>> m.n_joints
    31
    """
    n_threads = _c_threads(threads)
    path = os.fspath(path)
    name = path if isinstance(path, str) else os.fsdecode(path)
    bpath = os.fsencode(path)
    if b"\0" in bpath:
        raise ValueError(f"mlayer.read_bvh: embedded null byte in the path {name!r}")
    opts, n_opts = _options(strict, keep_truncated, "mlayer.read_bvh")
    up_given = _up_arg(up, "mlayer.read_bvh")
    units = _units_arg(units, "mlayer.read_bvh")
    trim = frames_arg(trim, "mlayer.read_bvh")
    out = ffi.new("mlr_motion **")
    diag = ffi.new("mlr_diag *")
    w = ffi.new("mlr_bvh_warnings *")
    # the C reader reads the file itself (a large one on the parsing threads, each its share)
    code = lib.mlr_bvh_read_file_opts(bpath, n_threads, opts, n_opts, ffi.NULL, out, w, diag)
    if code == lib.MLR_E_IO:
        # the OSError subclass that fits (FileNotFoundError, PermissionError, IsADirectoryError,
        # ...) comes from Python's own open and read; if those work now, the C reason stands
        with open(path, "rb") as f:
            f.read(1)
    m = _motion_or_raise(code, out, diag, name)
    _warn(w, name)
    m.up_axis, m.units = up_given, units
    return trimmed_read(m, trim, name)


def _units_arg(units: str | None, where: str) -> str | None:
    """The length unit a read clip gets: units, or the CLI's --units (reading_units), or None."""
    units = units_arg(units, where)
    return _UNITS.get() if units is None else units


@contextlib.contextmanager
def reading_units(units: str | None) -> Iterator[None]:
    """Within the block, clips read with ``units=None`` get this length unit (the CLI's
    ``--units``)."""
    token = _UNITS.set(units_arg(units, "--units"))
    try:
        yield
    finally:
        _UNITS.reset(token)


def _up_arg(up: str | None, where: str) -> str | None:
    """The up axis a read clip gets: up, or the CLI's --up (reading_up), or None (detect)."""
    up = axis_name(up, where)
    return default_up() if up is None else up


def read_bvh_string(text: str | bytes, name: str = "<string>", *, strict: bool | None = None,
                    keep_truncated: bool = False, threads: int | None = None,
                    up: str | None = None, trim: str | int | None = None,
                    units: str | None = None) -> Motion:
    """Parse BVH text.

    Parameters
    ----------
    text : str or bytes
        The text of a BVH file.
    name : str, optional
        Stands for the path in error and warning messages.
    strict, keep_truncated, threads, up, trim, units
        As for :func:`read_bvh`.

    Returns
    -------
    Motion
        The clip.

    Raises
    ------
    mlayer.ParseError
        When the text is not valid BVH.
    """
    n_threads = _c_threads(threads)
    up_given = _up_arg(up, "mlayer.read_bvh_string")
    units = _units_arg(units, "mlayer.read_bvh_string")
    trim = frames_arg(trim, "mlayer.read_bvh_string")
    if isinstance(text, str):
        text = text.encode("utf-8", errors="surrogateescape")
    m = _parse(text, name, n_threads, strict, keep_truncated)
    m.up_axis, m.units = up_given, units
    return trimmed_read(m, trim, name)


def write_bvh(motion: Motion, path: str | bytes | os.PathLike[str] | os.PathLike[bytes]
              ) -> None:
    """Write a motion as BVH, atomically.

    The old file, if any, stays intact when writing fails.

    Parameters
    ----------
    motion : Motion
        The motion.
    path : str, bytes or os.PathLike
        The destination.

    Raises
    ------
    mlayer.MlayerIOError
        (an OSError) When the file cannot be written.
    mlayer.InvalidArgumentError
        When the motion holds non-finite values.
    TypeError
        When ``motion`` is not a Motion.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"write_bvh: expected a mlayer.Motion, got {type(motion).__name__}")
    path = os.fspath(path)
    bpath = path if isinstance(path, bytes) else os.fsencode(path)
    diag = ffi.new("mlr_diag *")
    with motion._handle() as h:
        code = lib.mlr_bvh_write_file(h, bpath, diag)
        check(code, f"mlayer.write_bvh({os.fsdecode(path)})", diag)


def write_bvh_string(motion: Motion) -> str:
    """The BVH text of a motion.

    Parameters
    ----------
    motion : Motion
        The motion.

    Returns
    -------
    str
        The text, with LF line ends.

    Raises
    ------
    TypeError
        When ``motion`` is not a Motion.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"write_bvh_string: expected a mlayer.Motion, got {type(motion).__name__}")
    with motion._handle() as h:
        n = ffi.new("size_t *")
        # one pass into a buffer sized for the usual text (a value takes at most 16 bytes with
        # its blank when it has no exponent); a second, exact one only when that falls short
        sk = motion.skeleton
        cap = 4096 + 160 * (sk.n_joints + sk.n_end_sites) + 16 * sk.n_channels * motion.n_frames
        buf = ffi.new("char[]", cap)
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_bvh_write_memory(h, buf, cap, n, diag)
        if code == lib.MLR_E_OVERFLOW:
            buf = ffi.new("char[]", max(int(n[0]), 1))
            code = lib.mlr_bvh_write_memory(h, buf, int(n[0]), n, diag)
        check(code, "mlayer.write_bvh_string", diag)
        return ffi.unpack(buf, int(n[0])).decode("utf-8", errors="surrogateescape")
