"""The lifetime of the C handles Python objects own: read-only attributes that describe a C
object (:class:`mlayer._attrs.ReadOnlyAttributes`), closing, and refusing copies that would
share a handle."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, SupportsIndex

from ._attrs import ReadOnlyAttributes
from ._native import ffi
from .errors import InvalidArgumentError

if TYPE_CHECKING:
    from typing_extensions import Self

__all__ = ["NativeHandle", "ReadOnlyAttributes", "refuse_copy"]


def refuse_copy(obj: Any, what: str = "copy", hint: str = "make a new one") -> TypeError:
    """The TypeError of a copy or pickle of an object whose C handle cannot be duplicated."""
    return TypeError(f"cannot {what} a mlayer.{type(obj).__name__}: it owns a C handle that "
                     f"cannot be duplicated ({hint})")


class NativeHandle:
    """Mixin for objects owning a C handle in ``self._h``, made with ``ffi.gc(ptr, destroy)``:
    the handle is freed when the object is collected, or at once by :meth:`close` or at the
    end of a ``with`` block. Every use goes through :meth:`_live`, so a closed object raises
    InvalidArgumentError instead of reaching freed memory.

    Copies: a copy that shared the handle would be left on freed memory when the other one is
    closed, so ``copy.copy``, ``copy.deepcopy`` and pickling raise TypeError unless the class
    defines ``_clone`` (a new object with its own handle, built from this one) and
    ``__reduce__``.
    """

    _h = None

    def close(self) -> None:
        """Free the C handle now. The object is unusable afterwards (its methods raise
        InvalidArgumentError)."""
        if self._h is not None:
            h, self._h = self._h, None
            ffi.release(h)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` (or the end of a ``with`` block) has freed the handle."""
        return self._h is None

    def _live(self) -> Any:
        """The C handle; InvalidArgumentError when the object is closed."""
        h = self._h
        if h is None:
            raise InvalidArgumentError(f"mlayer.{type(self).__name__}: the object is closed "
                                       "(close() or the end of its with block freed it)")
        return h

    def _clone(self) -> Any:
        raise refuse_copy(self)

    def __copy__(self) -> Any:
        self._live()
        return self._clone()

    def __deepcopy__(self, memo: dict[int, Any]) -> Any:
        self._live()
        return self._clone()

    def __reduce_ex__(self, protocol: SupportsIndex) -> Any:
        raise refuse_copy(self, "pickle")

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
