"""Atomic output files: write to a temporary file beside the target, rename on success.

A failed or interrupted writer leaves the target as it was (absent or the old version) and no
temporary file behind, so a half-written output can never be mistaken for a result.
"""
from __future__ import annotations

import contextlib
import os
import tempfile


@contextlib.contextmanager
def atomic_output(path, suffix: str | None = None):
    """Context manager yielding a temporary path in the target's directory.

    Write the whole output to the yielded path; when the block ends without an exception the
    temporary file replaces ``path`` (``os.replace``, atomic on POSIX). ``suffix`` is the
    temporary file's extension (default: the target's), for writers that pick the format by
    extension (matplotlib, Pillow, numpy).
    """
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if suffix is None:
        suffix = os.path.splitext(path)[1]
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=suffix + ".tmp"
                               if not suffix else suffix, dir=directory)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
