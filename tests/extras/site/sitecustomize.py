"""Imported at the start of every interpreter that has this folder on PYTHONPATH (run.py puts it
there): every module named in $MLAYER_TEST_BLOCK (comma-separated top-level names), and its
submodules, is not found, as in an environment without it (``import`` raises
ModuleNotFoundError, ``importlib.util.find_spec`` returns None). Child processes inherit the
variables, so the CLI tests' subprocesses see the same environment."""
import os
import sys


class _Without:
    """A finder of sys.meta_path that finds nothing of the blocked names."""

    def __init__(self, finder, names):
        self._finder, self._names = finder, names

    def find_spec(self, fullname, path=None, target=None):
        if fullname.partition(".")[0] in self._names:
            return None
        return self._finder.find_spec(fullname, path, target)

    def __getattr__(self, name):  # invalidate_caches, find_distributions, ...
        return getattr(self._finder, name)


_names = frozenset(n for n in os.environ.get("MLAYER_TEST_BLOCK", "").split(",") if n)
if _names:
    sys.meta_path[:] = [_Without(f, _names) for f in sys.meta_path]
