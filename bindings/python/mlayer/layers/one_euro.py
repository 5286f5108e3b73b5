"""The One Euro filter (Casiez, Roussel and Vogel, "1 Euro Filter: A Simple Speed-based Low-pass
Filter for Noisy Input in Interactive Systems", CHI 2012), for comparison with the LGS stream.

It is the ad-hoc filter live systems use today: a first-order low-pass whose cutoff rises with
the signal's speed, so slow motion is smoothed hard (little jitter) and fast motion little
(little lag). For each channel, at sampling rate ``rate`` (Hz):

    alpha(fc)  = 1 / (1 + rate / (2 pi fc))         (smoothing factor of a cutoff fc)
    dx_i       = (x_i - xhat_{i-1}) * rate          (speed against the previous output)
    dxhat_i    = dxhat_{i-1} + alpha(d_cutoff) (dx_i - dxhat_{i-1})
    fc_i       = min_cutoff + beta |dxhat_i|
    xhat_i     = xhat_{i-1} + alpha(fc_i) (x_i - xhat_{i-1})

with xhat_0 = x_0 and dxhat_0 = 0 (the paper's Algorithm 1). ``beta = 0`` gives a plain
exponential smoother with cutoff ``min_cutoff``. It is causal (no lag parameter, no look-ahead):
its output always trails the signal, and it is not the LGS posterior any lag would converge to.

Quaternions are filtered as their four components (after sign continuity) and renormalized, as
the LGS stream does. Pure numpy: O(channels) per sample.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays, _attrs
from ..errors import InvalidArgumentError
from ..model.motion import MIN_FRAME_TIME

__all__ = ["OneEuroFilter", "one_euro"]


def _alpha(rate: float, cutoff: Any) -> Any:
    return 1.0 / (1.0 + rate / (2.0 * math.pi * cutoff))


class OneEuroFilter(_attrs.ReadOnlyAttributes):
    """A One Euro filter over m channels, one sample at a time (:meth:`__call__`).

    The parameters are attributes of the same names, checked when they are assigned (as here:
    InvalidArgumentError for a value out of range); a change applies from the next sample.

    Parameters
    ----------
    rate : float
        Samples per second (> 0, at most a million).
    min_cutoff : float, optional
        Cutoff at rest, Hz (> 0).
    beta : float, optional
        How fast the cutoff grows with speed (per unit of the channel per second; >= 0).
    d_cutoff : float, optional
        Cutoff of the speed estimate, Hz (> 0).

    Raises
    ------
    mlayer.InvalidArgumentError
        For parameters out of range.
    """
    rate: float
    min_cutoff: float
    beta: float
    d_cutoff: float

    _checked = {"rate": _attrs.number(0.0, 1.0 / MIN_FRAME_TIME, above=True),
                "min_cutoff": _attrs.number(0.0, above=True), "beta": _attrs.number(0.0),
                "d_cutoff": _attrs.number(0.0, above=True)}

    def __init__(self, rate: float, min_cutoff: float = 1.0, beta: float = 0.0,
                 d_cutoff: float = 1.0) -> None:
        vals = {"rate": rate, "min_cutoff": min_cutoff, "d_cutoff": d_cutoff}
        for name, v in vals.items():
            if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v)
                    and v > 0):
                raise InvalidArgumentError(f"OneEuroFilter: {name} must be finite and > 0, "
                                           f"got {v!r}")
        if not (math.isfinite(beta) and beta >= 0):
            raise InvalidArgumentError(f"OneEuroFilter: beta must be finite and >= 0, got "
                                       f"{beta!r}")
        self.rate, self.min_cutoff, self.beta, self.d_cutoff = (float(rate), float(min_cutoff),
                                                                float(beta), float(d_cutoff))
        self.reset()

    def reset(self) -> None:
        """Forget the past samples."""
        self._x: NDArray[np.float64] | None = None
        self._dx: NDArray[np.float64] | None = None

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        """Filter the next sample.

        Parameters
        ----------
        x : array_like
            Any shape, the same every call; finite.

        Returns
        -------
        numpy.ndarray
            The output (a copy).

        Raises
        ------
        mlayer.InvalidArgumentError
            For a non-numeric or non-finite sample, or another shape than the first.
        """
        try:
            x = np.asarray(x, dtype=np.float64)  # keeps a scalar 0-d
        except (TypeError, ValueError) as e:
            raise InvalidArgumentError(f"OneEuroFilter: x is not numeric ({e})") from None
        _arrays.require_finite(x, "OneEuroFilter: x")
        if self._x is None:
            self._x, self._dx = x.copy(), np.zeros_like(x)
            return x.copy()
        if x.shape != self._x.shape:
            raise InvalidArgumentError(
                f"OneEuroFilter: sample shape {x.shape} differs from the first {self._x.shape}")
        x0, dx0 = self._x, self._dx
        assert dx0 is not None  # set with _x
        dx = (x - x0) * self.rate
        dx0 += _alpha(self.rate, self.d_cutoff) * (dx - dx0)
        a = _alpha(self.rate, self.min_cutoff + self.beta * np.abs(dx0))
        x0 += a * (x - x0)
        return x0.copy()


def one_euro(y: ArrayLike, rate: float, min_cutoff: float = 1.0, beta: float = 0.0,
             d_cutoff: float = 1.0) -> NDArray[np.float64]:
    """One Euro filter along axis 0: every other index is its own channel.

    Parameters
    ----------
    y : array_like, shape (N, ...)
        The samples.
    rate, min_cutoff, beta, d_cutoff : float
        As for :class:`OneEuroFilter`.

    Returns
    -------
    numpy.ndarray
        Of ``y``'s shape.
    """
    y = _arrays.as_f64(y, "one_euro: y")
    if y.ndim < 1:
        raise InvalidArgumentError("one_euro: y needs a frame axis")
    f = OneEuroFilter(rate, min_cutoff, beta, d_cutoff)
    out = np.empty_like(y)
    for i in range(y.shape[0]):
        out[i] = f(y[i])
    return out
