"""The compiled cffi extension: `ffi` and `lib` for the rest of the package, and the lifetime
of the C handles Python objects own."""
from ._mlayer import ffi, lib  # noqa: F401

__all__ = ["ffi", "lib", "NativeHandle"]


class NativeHandle:
    """Mixin for objects owning a C handle in ``self._h``, made with ``ffi.gc(ptr, destroy)``:
    the handle is freed when the object is collected, or at once by :meth:`close` or at the
    end of a ``with`` block."""

    _h = None

    def close(self) -> None:
        """Free the C handle now. The object is unusable afterwards."""
        if self._h is not None:
            ffi.release(self._h)
            self._h = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
