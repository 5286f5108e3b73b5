"""Atomic output files: write to a temporary file beside the target, rename on success.

A failed or interrupted writer leaves the target as it was (absent or the old version) and no
temporary file behind, so a half-written output can never be mistaken for a result. A writer
that is killed leaves its temporary: :func:`stale_temporaries` finds them.

The temporaries are named by the rule of the C writer (``mlr_bvh_write_file`` in
``include/mlayer/mlr_bvh.h``, where the rule is written down): the temporary of
``DIR/NAME`` is ``DIR/.NAME.tmp-HHHHHHHHHHHHHHHH`` (16 lowercase hexadecimal digits), here
followed by an extension for the writers that choose a format by it; it is created
exclusively, with the mode a plain ``open`` gives (0666 less the umask).
"""
from __future__ import annotations

import contextlib
import glob
import os
import re
import secrets
import stat
import threading
from collections.abc import Iterator

__all__ = ["atomic_output", "stale_temporaries", "temporary_name", "umask"]

_UMASK_LOCK = threading.Lock()

#: what follows ".NAME" in a temporary's name (the rule of mlr_bvh.h): ".tmp-", 16 lowercase
#: hexadecimal digits, then nothing or an extension (a dot and 1 to 16 characters, none of
#: them a dot or a path separator)
_TEMP_TAIL = r"\.tmp-[0-9a-f]{16}(\.[^./\\]{1,16})?"
_EXTENSION = re.compile(r"(\.[^./\\]{1,16})?")


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


def temporary_name(path: str | os.PathLike[str], suffix: str = "") -> str:
    """A new temporary name for `path` by the rule: ``DIR/.NAME.tmp-<16 hex><suffix>``."""
    path = os.fspath(path)
    if _EXTENSION.fullmatch(suffix) is None:
        raise ValueError(f"atomic_output: suffix {suffix!r} is not an extension (a dot and 1 "
                         "to 16 characters other than dots and path separators)")
    directory, name = os.path.split(os.path.abspath(path))
    return os.path.join(directory, f".{name}.tmp-{secrets.token_hex(8)}{suffix}")


def stale_temporaries(path: str | os.PathLike[str]) -> list[str]:
    """The temporaries of `path` that exist: those a writer of it that was killed left (or
    those of a writer still running), whether the C writer or :func:`atomic_output` made
    them. Sorted."""
    directory, name = os.path.split(os.path.abspath(os.fspath(path)))
    rule = re.compile(re.escape("." + name) + _TEMP_TAIL)
    found = glob.glob(os.path.join(glob.escape(directory), glob.escape("." + name) + ".tmp-*"))
    return sorted(p for p in found if rule.fullmatch(os.path.basename(p)))


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], suffix: str | None = None) -> Iterator[str]:
    """Context manager yielding a temporary path in the target's directory.

    Write the whole output to the yielded path; when the block ends without an exception the
    temporary file replaces ``path`` (``os.replace``, atomic on POSIX). ``suffix`` is the
    temporary file's extension (default: the target's), for writers that pick the format by
    extension (matplotlib, Pillow, numpy).

    The file is created (empty, exclusively) with the mode a plain ``open`` would give it
    (0666 less the umask: 0644 under umask 022), like the BVH files the C writer creates; when
    it replaces an existing regular file, it takes that file's mode (as the C writer does).
    """
    path = os.fspath(path)
    if suffix is None:
        suffix = os.path.splitext(path)[1]
        if _EXTENSION.fullmatch(suffix) is None:  # an unusual extension: none
            suffix = ""
    for _ in range(32):
        tmp = temporary_name(path, suffix)
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL
                             | getattr(os, "O_BINARY", 0), 0o666))
            break
        except FileExistsError:
            continue
    else:
        raise FileExistsError(f"atomic_output: no free temporary name beside {path}")
    try:
        yield tmp
        # an existing file's mode carries over (a 0600 output rewritten became 0644)
        with contextlib.suppress(OSError):
            st = os.stat(path)
            if stat.S_ISREG(st.st_mode):
                os.chmod(tmp, stat.S_IMODE(st.st_mode))
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
