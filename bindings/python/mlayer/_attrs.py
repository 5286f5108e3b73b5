"""Public attributes: read-only, or validated where they are assigned.

Every public attribute of the package's classes is one of the two, so that a later call never
sees an invalid value (issue 39):

- **read-only** (named in the class's ``_readonly``): set by the constructor and by the
  methods that build the object (``fit``, ``load``: marked with :func:`builds` or run inside
  :func:`building`); anywhere else assigning or deleting it raises AttributeError, before
  the first fit too. For what describes a C handle, the results of a fit and everything whose
  shape the other attributes depend on: make a new object instead. A
  ``functools.cached_property`` named there is never assignable. (Classes with ``__slots__``
  and no ``__dict__`` cannot mark a build: there a read-only attribute can be set once.)
- **validated** (a checker in the class's ``_checked``): every assignment, the constructor's
  too, goes through ``check(obj, value, "Class.name")``, which returns the value to store
  (converted: a float, a copy of an array in the expected dtype) or raises
  :class:`~mlayer.errors.InvalidArgumentError` naming the attribute and the reason; the old
  value is then kept.

Attributes with a property of their own (``Motion.frame_time``, ``SOM.codebook``) validate in
its setter. Pickling and copying are unchanged: they restore ``__dict__`` or the slots directly.
"""
from __future__ import annotations

import contextlib
import functools
import math
from collections.abc import Callable, Iterator, Mapping
from typing import Any, TypeVar

import numpy as np

from ._args import integer as _integer
from ._arrays import finite as _finite
from .errors import InvalidArgumentError

__all__ = ["ReadOnlyAttributes", "Check", "builds", "building", "number", "integer", "choice",
           "instance", "text"]

#: a checker: (the object, the value assigned, "Class.name") -> the value to store
Check = Callable[[Any, Any, str], Any]

_F = TypeVar("_F", bound=Callable[..., Any])


class ReadOnlyAttributes:
    """Mixin: the attribute names in ``_readonly`` can be set only while the object is being
    built (in ``__init__``, or see :func:`building`; with ``__slots__`` and no ``__dict__``:
    once) and raise AttributeError when assigned otherwise or deleted; those in ``_checked``
    are validated by their checker on every assignment. For the sizes and parameters a C
    handle was made with: a reassigned ``n_out`` or ``rows`` would make the wrapper hand C a
    buffer of the wrong size."""

    __slots__ = ()
    _readonly: tuple[str, ...] = ()
    _checked: Mapping[str, Check] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "__init__" in cls.__dict__:  # the constructor builds the object
            # setattr: an assignment to cls.__init__ would declare an __init__ attribute here
            setattr(cls, "__init__", builds(cls.__dict__["__init__"]))  # noqa: B010

    def __setattr__(self, name: str, value: Any) -> None:
        cls = type(self)
        check = cls._checked.get(name)
        if check is not None:
            value = check(self, value, f"{cls.__name__}.{name}")
        elif name in cls._readonly and _locked(self, name):
            raise AttributeError(f"{cls.__name__}.{name} is read-only (make a new "
                                 f"{cls.__name__} instead)")
        object.__setattr__(self, name, value)

    def __delattr__(self, name: str) -> None:
        cls = type(self)
        if name in cls._readonly or name in cls._checked:
            raise AttributeError(f"{cls.__name__}.{name} is read-only")
        object.__delattr__(self, name)


def _locked(obj: Any, name: str) -> bool:
    """Whether a read-only attribute cannot be assigned now."""
    if isinstance(getattr(type(obj), name, None), functools.cached_property):
        return True  # computed and kept; never assigned (this would not compute it)
    d = getattr(obj, "__dict__", None)
    if d is not None:
        return not d.get("_building", 0)
    try:  # __slots__ only: once
        object.__getattribute__(obj, name)
    except AttributeError:
        return False
    return True


@contextlib.contextmanager
def building(obj: Any) -> Iterator[Any]:
    """The read-only attributes of obj assignable inside the block (a method that builds the
    object: ``__init__``, ``fit``, ``load``). Nothing for an object without ``__dict__``."""
    d = getattr(obj, "__dict__", None)
    if d is None:
        yield obj
        return
    d["_building"] = d.get("_building", 0) + 1
    try:
        yield obj
    finally:
        d["_building"] -= 1
        if not d["_building"]:
            del d["_building"]


def builds(method: _F) -> _F:
    """Decorator: the method builds its object (runs inside :func:`building`)."""
    @functools.wraps(method)
    def wrapped(self: Any, *args: Any, **kwargs: Any) -> Any:
        with building(self):
            return method(self, *args, **kwargs)
    return wrapped  # type: ignore[return-value]


# ---- checkers ---------------------------------------------------------------------------------

def number(lo: float | None = None, hi: float | None = None, *, above: bool = False,
           nan: bool = False) -> Check:
    """A finite float in [lo, hi] ((lo, hi] with ``above``); NaN too with ``nan``."""
    def check(obj: Any, v: Any, name: str) -> float:
        if nan and isinstance(v, (float, np.floating)) and math.isnan(v):
            return float(v)
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer,
                                                                 np.floating)):
            raise InvalidArgumentError(f"{name} must be a number, got {v!r}")
        f = _finite(v, name)
        if lo is not None and (f <= lo if above else f < lo):
            raise InvalidArgumentError(f"{name} must be {'>' if above else '>='} {lo:g}, "
                                       f"got {v!r}")
        if hi is not None and f > hi:
            raise InvalidArgumentError(f"{name} must be <= {hi:g}, got {v!r}")
        return f
    return check


def integer(lo: int | None = None, hi: int | None = None) -> Check:
    """An int in [lo, hi] (:func:`mlayer._args.integer`: not a bool, not a float)."""
    def check(obj: Any, v: Any, name: str) -> int:
        return _integer(v, name, lo, hi)
    return check


def choice(*values: str) -> Check:
    """One of the strings given."""
    def check(obj: Any, v: Any, name: str) -> str:
        if not isinstance(v, str) or v not in values:
            raise InvalidArgumentError(f"{name} must be one of {', '.join(map(repr, values))}, "
                                       f"got {v!r}")
        return v
    return check


def instance(cls: type, what: str) -> Check:
    """An instance of cls (``what`` names it in the message)."""
    def check(obj: Any, v: Any, name: str) -> Any:
        if not isinstance(v, cls):
            raise InvalidArgumentError(f"{name} must be {what}, got {type(v).__name__}")
        return v
    return check


def text(obj: Any, v: Any, name: str) -> str:
    """A str."""
    if not isinstance(v, str):
        raise InvalidArgumentError(f"{name} must be a str, got {type(v).__name__}")
    return v
