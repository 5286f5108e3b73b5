"""mlayer.layers.one_euro: the One Euro filter against a scalar transcription of the paper's
Algorithm 1, and against scipy's one-pole filter for beta = 0."""
import math

import numpy as np
import pytest
from scipy.signal import lfilter

import mlayer
from mlayer.layers.one_euro import OneEuroFilter, one_euro


def scalar_reference(x, rate, min_cutoff, beta, d_cutoff):
    def alpha(fc):
        tau = 1.0 / (2 * math.pi * fc)
        return 1.0 / (1.0 + tau * rate)

    out, xh, dxh = [], None, 0.0
    for v in x:
        if xh is None:
            xh = v
        else:
            dx = (v - xh) * rate
            dxh = dxh + alpha(d_cutoff) * (dx - dxh)
            xh = xh + alpha(min_cutoff + beta * abs(dxh)) * (v - xh)
        out.append(xh)
    return np.array(out)


def test_matches_the_algorithm(rng):
    y = np.cumsum(rng.normal(size=(300, 3)), axis=0) + rng.normal(scale=0.5, size=(300, 3))
    got = one_euro(y, 120.0, 1.5, 0.05, 1.0)
    for c in range(3):
        np.testing.assert_allclose(got[:, c], scalar_reference(y[:, c], 120.0, 1.5, 0.05, 1.0),
                                   rtol=0, atol=1e-12)


def test_beta_zero_is_a_one_pole_lowpass(rng):
    y = rng.normal(size=500)
    fc, rate = 3.0, 60.0
    a = 1.0 / (1.0 + rate / (2 * math.pi * fc))
    ref, _ = lfilter([a], [1.0, a - 1.0], y[1:], zi=[(1 - a) * y[0]])
    got = one_euro(y, rate, fc, 0.0)
    assert got[0] == y[0]
    np.testing.assert_allclose(got[1:], ref, rtol=0, atol=1e-12)


def test_streaming_object_and_errors(rng):
    y = rng.normal(size=(50, 2, 4))
    f = OneEuroFilter(30.0, 2.0, 0.1)
    out = np.array([f(v) for v in y])
    np.testing.assert_array_equal(out, one_euro(y, 30.0, 2.0, 0.1))
    f.reset()
    np.testing.assert_array_equal(f(y[0]), y[0])
    with pytest.raises(mlayer.InvalidArgumentError):
        f(np.zeros(3))
    with pytest.raises(mlayer.InvalidArgumentError):
        f(np.full((2, 4), np.nan))
    for bad in ({"rate": 0.0}, {"min_cutoff": -1.0}, {"d_cutoff": float("inf")},
                {"beta": -0.1}):
        args = {"rate": 30.0, "min_cutoff": 1.0, "beta": 0.0, "d_cutoff": 1.0, **bad}
        with pytest.raises(mlayer.InvalidArgumentError):
            OneEuroFilter(**args)
