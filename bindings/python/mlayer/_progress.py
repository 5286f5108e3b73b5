"""Progress of long library calls, and the package's logger.

Library code does not print: it reports steps to the ``mlayer`` logger (``logging``; the
package adds a NullHandler, so nothing shows unless the application configures logging, as the
command line does) and draws progress bars with tqdm through :func:`progress_bar`.

The ``progress=`` argument of the calls that take one (``mlayer.batch``,
``mlayer.plotting.render.render``/``render_gif``, ``PrimitiveModel.fit``):

- ``None`` (the default): a bar on stderr when stderr is a terminal and tqdm is installed;
  nothing otherwise;
- ``False``: no bar; ``True``: a bar on stderr (needs tqdm: the ``progress`` extra; checked
  before any work, :class:`mlayer.MissingDependencyError` without it);
- a stream (anything with ``write``): a bar on it (needs tqdm);
- a callable ``f(done, total)``: called after each step instead of a bar.
"""
from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from typing import IO, Any, Protocol

from ._optional import available, require
from .errors import InvalidArgumentError

__all__ = ["logger", "progress_bar", "resolve", "ProgressArg", "Bar", "BarFactory"]

#: what a ``progress=`` argument may be (see the module's docstring)
ProgressArg = bool | IO[str] | Callable[[int, int], object] | None


class Bar(Protocol):
    """What :func:`resolve`'s factory makes: a tqdm bar, a callback or nothing."""

    def update(self, n: int = 1) -> Any: ...
    def set_description_str(self, text: str) -> Any: ...
    def set_postfix_str(self, text: str) -> Any: ...
    def close(self) -> Any: ...
    def __enter__(self) -> Bar: ...
    def __exit__(self, *exc: object) -> Any: ...


#: ``make(total, desc="", unit="it") -> Bar``
BarFactory = Callable[..., Bar]

#: the package's logger (children: ``mlayer.manifold.primitives``, ``mlayer.batch``, ...)
logger = logging.getLogger("mlayer")


class _Off:
    """No bar."""

    def update(self, n: int = 1) -> None:
        pass

    def set_description_str(self, text: str) -> None:
        pass

    def set_postfix_str(self, text: str) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> _Off:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Callback(_Off):
    """progress= a callable(done, total): called after each update."""

    def __init__(self, fn: Callable[[int, int], object], total: int) -> None:
        self.fn, self.total, self.done = fn, total, 0

    def update(self, n: int = 1) -> None:
        self.done += n
        self.fn(self.done, self.total)


def _is_terminal(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


def resolve(progress: ProgressArg, feature: str) -> BarFactory:
    """Check a ``progress=`` argument before any work and return a factory
    ``make(total, desc, unit) -> bar`` (a tqdm bar, a callback or nothing, each with
    ``update(n)``, ``set_description_str``, ``set_postfix_str``, ``close`` and a context
    manager). Raises MissingDependencyError when a bar is asked for explicitly and tqdm is
    missing, InvalidArgumentError for a value of another kind."""
    if progress is None:
        stream = sys.stderr
        on = stream is not None and _is_terminal(stream) and available("tqdm")
    elif progress is False or progress is True:
        stream, on = sys.stderr, progress
    elif hasattr(progress, "write"):
        stream, on = progress, True
    elif callable(progress):
        return lambda total, desc="", unit="it": _Callback(progress, total)
    else:
        raise InvalidArgumentError(f"{feature}: progress must be None, True, False, a stream or "
                                   f"a callable(done, total), got {type(progress).__name__}")
    if not on:
        return lambda total, desc="", unit="it": _Off()
    tqdm = require("tqdm", feature=f"{feature} with progress=True").tqdm

    def make(total: int, desc: str = "", unit: str = "it") -> Bar:
        return tqdm(total=total, desc=desc, unit=unit, file=stream, leave=True,
                    dynamic_ncols=True)
    return make


def progress_bar(progress: ProgressArg, total: int, desc: str = "", unit: str = "it", *,
                 feature: str = "mlayer") -> Bar:
    """``resolve(progress, feature)(total, desc, unit)``: the bar of one loop."""
    return resolve(progress, feature)(total, desc, unit)
