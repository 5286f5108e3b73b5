"""Atomic output files: write to a temporary file beside the target, rename on success.

A failed or interrupted writer leaves the target as it was (absent or the old version) and no
temporary file behind, so a half-written output can never be mistaken for a result.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
import threading

_UMASK_LOCK = threading.Lock()


def umask() -> int:
    """The process's umask, without changing it for other threads where the system says it
    (Linux: /proc/self/status); else by setting and restoring it under a lock."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_output(path, suffix: str | None = None):
    """Context manager yielding a temporary path in the target's directory.

    Write the whole output to the yielded path; when the block ends without an exception the
    temporary file replaces ``path`` (``os.replace``, atomic on POSIX). ``suffix`` is the
    temporary file's extension (default: the target's), for writers that pick the format by
    extension (matplotlib, Pillow, numpy).

    The file gets the mode a plain ``open`` would give it (0666 less the umask: 0644 under
    umask 022), not the 0600 of ``mkstemp``, so outputs written this way read like the BVH
    files the C writer creates.
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
        os.chmod(tmp, 0o666 & ~umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
