"""Alpha over time: keyframed alpha curves (paper 1, section 6.2: the final motion composited
by changing the local weights over time).

An :class:`AlphaCurve` holds keys ``(time in seconds, alpha)``; between two keys the curve
eases from one to the other by the quintic smoothstep ``s(u) = u^3 (10 - 15 u + 6 u^2)``, and
it holds the first key's value before it and the last one's after it. The curve is C2 (no step
in the result's accelerations at a key), stays within its two keys (no overshoot past what was
keyed), and is exactly a key's value between two equal keys (constant keys give the constant
alpha's motion bit for bit). Its slope is zero at every key. The evaluation is the C core's
(``mlr_alpha_keys_eval``, ``mlr_layers.h``), and so is the synthesis
(``mlr_layers_synthesize_frames``, ``mlr_pipeline_set_alpha_keys``).

Wherever an alpha is taken (:func:`mlayer.stylize`, :meth:`mlayer.Layers.synthesize`,
:meth:`mlayer.Synthesis.run` and the values of their ``joints`` dicts), an AlphaCurve, a
sequence of ``(time, alpha)`` pairs or a ``"0:1,2.5:3,4:1"`` string is accepted beside a
number. Time 0 is the motion's first frame; frame ``i`` is at ``i * frame_time`` seconds.
"""
from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._native import ffi, lib
from ..errors import InvalidArgumentError

__all__ = ["AlphaCurve", "AlphaArg"]


class AlphaCurve:
    """Keyed alpha over time, smoothly interpolated (see the module's documentation).

    Parameters
    ----------
    keys : iterable of (float, float), or str
        ``(time_s, alpha)`` pairs with strictly increasing times, at least one; or the text
        form ``"0:1,2.5:3,4:1"`` (:meth:`parse`).

    Raises
    ------
    mlayer.InvalidArgumentError
        For no keys, a key that is not a pair of numbers, a time or alpha not finite, or times
        not strictly increasing (naming the key).

    Examples
    --------
    >>> from mlayer import AlphaCurve
    >>> c = AlphaCurve([(0, 1), (2.5, 3), (4, 1)])
    >>> float(c(2.5)), float(c(1.25))
    (3.0, 2.0)
    """

    __slots__ = ("_times", "_values")
    _times: NDArray[np.float64]
    _values: NDArray[np.float64]

    def __init__(self, keys: Iterable[tuple[float, float]] | str) -> None:
        tl: Any
        vl: Any
        if isinstance(keys, AlphaCurve):
            tl, vl = keys._times, keys._values
        elif isinstance(keys, str):
            tl, vl = _parse(keys)
        else:
            tl, vl = _pairs(keys)
        t = np.array(tl, dtype=np.float64)
        v = np.array(vl, dtype=np.float64)
        diag = ffi.new("mlr_diag *")
        if lib.mlr_alpha_keys_check(_ptr(t), _ptr(v), t.size, diag) != lib.MLR_OK:
            # (the C core's message as it is: it names the key)
            raise InvalidArgumentError(ffi.string(diag.message).decode("utf-8", "replace"))
        t.flags.writeable = v.flags.writeable = False
        object.__setattr__(self, "_times", t)
        object.__setattr__(self, "_values", v)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"AlphaCurve is immutable (cannot set {name!r})")

    @classmethod
    def parse(cls, text: str) -> AlphaCurve:
        """The curve of ``"TIME:ALPHA,TIME:ALPHA,..."`` (seconds; spaces allowed).

        Parameters
        ----------
        text : str
            The keys, e.g. ``"0:1,2.5:3,4:1"``.

        Returns
        -------
        AlphaCurve
            The curve.

        Raises
        ------
        mlayer.InvalidArgumentError
            For a malformed key (naming it) or bad keys.
        """
        return cls(text)

    @property
    def times(self) -> NDArray[np.float64]:
        """The keys' times in seconds (read-only)."""
        return self._times

    @property
    def values(self) -> NDArray[np.float64]:
        """The keys' alphas (read-only)."""
        return self._values

    @property
    def keys(self) -> list[tuple[float, float]]:
        """The keys as ``(time_s, alpha)`` pairs."""
        return [(float(a), float(b)) for a, b in zip(self._times, self._values)]

    @property
    def peak(self) -> float:
        """The key alpha of largest magnitude, the first such key's.

        What the guards take for a group with this curve (``mlr_pipeline.h``, "Alpha over
        time")."""
        return float(self._values[int(np.argmax(np.abs(self._values)))])

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """The curve at times ``t`` (seconds, any shape; finite).

        Parameters
        ----------
        t : array_like
            Times in seconds.

        Returns
        -------
        numpy.ndarray
            The alphas, of the shape of ``t``.

        Raises
        ------
        mlayer.InvalidArgumentError
            For a time not finite.
        """
        q = np.asarray(t, dtype=np.float64)
        flat = q.reshape(-1).copy()
        diag = ffi.new("mlr_diag *")
        out = ffi.cast("double *", ffi.from_buffer(flat)) if flat.size else ffi.NULL
        if lib.mlr_alpha_keys_eval(_ptr(self._times), _ptr(self._values), self._times.size,
                                   _ptr(flat), flat.size, out, diag) != lib.MLR_OK:
            raise InvalidArgumentError(ffi.string(diag.message).decode("utf-8", "replace"))
        return flat.reshape(q.shape)

    def sample(self, n_frames: int, fps: float) -> NDArray[np.float64]:
        """The curve at the frames of a clip.

        Parameters
        ----------
        n_frames : int
            Frames ``0 .. n_frames - 1``.
        fps : float
            The clip's frame rate: frame ``i`` is at ``i / fps`` seconds.

        Returns
        -------
        numpy.ndarray, shape (n_frames,)
            The alphas.
        """
        if not (isinstance(fps, (int, float, np.floating, np.integer)) and math.isfinite(fps)
                and fps > 0):
            raise InvalidArgumentError(f"fps: expected a finite number > 0, got {fps!r}")
        return self(np.arange(int(n_frames), dtype=np.float64) / float(fps))

    def __str__(self) -> str:
        return ",".join(f"{a:g}:{b:g}" for a, b in self.keys)

    def __repr__(self) -> str:
        return f"AlphaCurve({self.keys!r})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, AlphaCurve):
            return NotImplemented
        return bool(np.array_equal(self._times, other._times)
                    and np.array_equal(self._values, other._values))

    def __hash__(self) -> int:
        return hash((self._times.tobytes(), self._values.tobytes()))

    def __reduce__(self) -> tuple[Any, ...]:
        return (AlphaCurve, (self.keys,))


#: what an alpha argument takes: a number, an AlphaCurve, (time, alpha) pairs or their text
AlphaArg = float | AlphaCurve | str | Iterable[tuple[float, float]]

_KEY = re.compile(r"^\s*([^:]+?)\s*:\s*([^:]+?)\s*$")


def _parse(text: str) -> tuple[list[float], list[float]]:
    if not text.strip():
        raise InvalidArgumentError("alpha keys: empty (expected TIME:ALPHA,TIME:ALPHA,... such "
                                   "as '0:1,2.5:3,4:1')")
    t: list[float] = []
    v: list[float] = []
    for k, item in enumerate(text.split(",")):
        m = _KEY.match(item)
        if not m:
            raise InvalidArgumentError(f"alpha keys: key {k} {item.strip()!r} is not TIME:ALPHA "
                                       f"(expected e.g. '0:1,2.5:3,4:1')")
        try:
            t.append(float(m.group(1)))
            v.append(float(m.group(2)))
        except ValueError:
            raise InvalidArgumentError(f"alpha keys: key {k} {item.strip()!r}: not two numbers "
                                       f"TIME:ALPHA") from None
    return t, v


def _pairs(keys: Any) -> tuple[list[float], list[float]]:
    if isinstance(keys, Mapping):
        raise InvalidArgumentError("alpha keys: expected (time, alpha) pairs, got a dict (a dict "
                                   "of joint patterns goes to joints=)")
    try:
        items = list(keys)
    except TypeError:
        raise InvalidArgumentError(f"alpha keys: expected (time, alpha) pairs, got "
                                   f"{type(keys).__name__}") from None
    t: list[float] = []
    v: list[float] = []
    for k, kv in enumerate(items):
        try:
            a, b = kv
            ta, vb = float(a), float(b)
        except (TypeError, ValueError):
            raise InvalidArgumentError(f"alpha keys: key {k} {kv!r} is not a (time, alpha) pair "
                                       f"of numbers") from None
        t.append(ta)
        v.append(vb)
    return t, v


def _ptr(a: NDArray[np.float64]) -> Any:
    return ffi.cast("const double *", ffi.from_buffer(a)) if a.size else ffi.NULL


def as_alpha(value: Any, name: str) -> float | AlphaCurve:
    """A number (finite, as a float) or an AlphaCurve for an alpha argument called ``name``."""
    if isinstance(value, AlphaCurve):
        return value
    if isinstance(value, (bool, np.bool_)):
        raise InvalidArgumentError(f"{name}: expected a number or an AlphaCurve, got {value!r}")
    if isinstance(value, (int, float, np.integer, np.floating)) or \
            (isinstance(value, np.ndarray) and value.ndim == 0):
        f = float(value)
        if not math.isfinite(f):
            raise InvalidArgumentError(f"{name} must be finite, got {value!r}")
        return f
    if isinstance(value, Mapping):
        raise InvalidArgumentError(f"{name}: expected a number or an AlphaCurve, got a dict "
                                   f"(joint patterns and their alphas or curves go to joints=)")
    try:
        return AlphaCurve(value)
    except InvalidArgumentError as e:
        raise InvalidArgumentError(f"{name}: {e}") from None





def _curve_like(value: Any) -> bool:
    """Whether an alpha argument asks for a curve: an AlphaCurve, its text, or keys (anything
    else goes the way of a number, and its errors)."""
    if isinstance(value, (AlphaCurve, str)):
        return True
    if isinstance(value, np.ndarray):
        return value.ndim > 0
    return isinstance(value, (list, tuple, Mapping))


def has_curve(alpha: Any, joints: Mapping[str, Any] | None) -> bool:
    """Whether ``alpha`` or a value of ``joints`` is a curve."""
    return _curve_like(alpha) or any(_curve_like(v) for v in (joints or {}).values())
