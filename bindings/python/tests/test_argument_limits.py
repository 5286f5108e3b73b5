"""Absurd sizes and parameters are refused with the argument's name, before anything large is
allocated: Stream lags, resampling lengths, generated lengths, NaN smoothing, frame times."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

import mlayer
from mlayer import _arrays
from conftest import SHARED_CLIPS

CLIP = "cmu_01_01_playground_jumps.bvh"


@pytest.fixture(scope="module")
def clip(mocap):
    return mlayer.read_bvh(mocap / CLIP)[:120]


@pytest.fixture
def little_memory(monkeypatch):
    """A machine with 64 MiB available (what /proc/meminfo would say)."""
    monkeypatch.setattr(_arrays, "available_memory", lambda: 64 << 20)


def test_stream_lag(clip, little_memory):
    # 10**7 frames of lag were 10 GB of buffers, all cleared at construction
    with pytest.raises(mlayer.InvalidArgumentError, match=r"lag must be at most 1000000"):
        mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=10**7)
    # within the cap but beyond the memory: MemoryError naming lag and the size, before C
    with pytest.raises(MemoryError, match=r"lag=200000 .*GiB"):
        mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=200_000)
    with pytest.raises(MemoryError, match=r"lag=100000"):  # layered: two smoothers
        mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=100_000, lam_base=4.0)
    st = mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=1000)  # 1 MB: fine
    assert st.lag == 1000


def test_stream_buffers_are_checked_against_max_bytes(clip):
    """Issue 39: Stream(lag=10**6), the allowed maximum, took 5.1 GB on a 165-joint skeleton
    wherever that much memory was free. The buffers are now checked against max_bytes
    (default 256 MiB) first, with a clear error naming lag, the joints and the size."""
    with pytest.raises(mlayer.InvalidArgumentError,
                       match=r"lag=500000 on 31 joints needs \d+ bytes .*max_bytes=268435456"):
        mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=500_000)
    with pytest.raises(mlayer.InvalidArgumentError, match=r"max_bytes=1000\b"):
        mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=1000, max_bytes=1000)
    with pytest.raises(mlayer.InvalidArgumentError, match="max_bytes"):
        mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=10, max_bytes=0)
    assert mlayer.Stream(clip, lam=1.0, sigma=1.0, lag=1000).lag == 1000


def test_check_memory_uses_the_machine():
    avail = _arrays.available_memory()
    assert avail is None or avail > 0
    _arrays.check_memory(1 << 20, "one MiB")
    if avail is not None:
        with pytest.raises(MemoryError, match="the thing"):
            _arrays.check_memory(4 * avail, "the thing")


def test_resample_lengths(clip, little_memory):
    with pytest.raises(MemoryError, match=r"mlayer.resample: n_frames \(1000000 output"):
        mlayer.resample(clip, n_frames=10**6, allow_extreme=True)
    with pytest.raises(MemoryError, match=r"mlayer.resample: fps"):
        mlayer.resample(clip, fps=1e6, allow_extreme=True)
    with pytest.raises(MemoryError, match=r"mlayer.slerp_resample: n_frames"):
        mlayer.slerp_resample(clip, n_frames=10**6, allow_extreme=True)
    t = np.linspace(0, 10**6 - 1, clip.n_frames)
    with pytest.raises(MemoryError, match=r"mlayer.timewarp: time_map"):
        mlayer.timewarp(clip, time_map=t, allow_extreme=True)
    assert mlayer.resample(clip, n_frames=240).n_frames == 240  # 240 frames fit


def test_resample_to_two_frames(mocap):
    """The shortest output: works on every clip, contacts kept (the contact cleanup used to
    fail on it)."""
    for name in SHARED_CLIPS:
        m = mlayer.read_bvh(mocap / name)[:150]
        for fn in (lambda m=m: mlayer.resample(m, n_frames=2, allow_extreme=True),
                   lambda m=m: mlayer.slerp_resample(m, n_frames=2, allow_extreme=True),
                   lambda m=m: mlayer.timewarp(m, n_frames=2, allow_extreme=True)):
            out = fn()
            assert out.n_frames == 2, name
            assert np.isfinite(out.positions()).all(), name
        with pytest.raises(mlayer.InvalidArgumentError, match="n_frames must be an integer >= 2"):
            mlayer.resample(m, n_frames=1)


def test_frame_time(clip, mocap):
    with pytest.raises(mlayer.InvalidArgumentError, match=r"frame_time must be at least 1e-06"):
        mlayer.Motion(clip.skeleton, 1e-300, clip.root_pos, clip.rot)
    m = clip.copy()
    for bad in (1e-300, 0.0, -1.0, math.nan, math.inf, "fast"):
        with pytest.raises(mlayer.InvalidArgumentError, match="frame_time"):
            m.frame_time = bad
    text = (mocap / CLIP).read_text()
    tiny = re.sub(r"Frame Time:.*", "Frame Time: 1e-300", text)
    with pytest.raises(mlayer.ParseError, match=r"Frame Time 1e-300 s is below 1e-06 s"):
        mlayer.read_bvh_string(tiny)
    assert mlayer.read_bvh_string(re.sub(r"Frame Time:.*", "Frame Time: 0.00001", text)).fps \
        == pytest.approx(1e5)


@pytest.fixture(scope="module")
def model(mocap):
    m = mlayer.read_bvh(mocap / CLIP)[100:260]
    return mlayer.PrimitiveModel.fit([m], k=3, som=(5, 5), epochs=2, lattice=(4, 4))


@pytest.mark.parametrize("kw, name", [({"smooth": math.nan}, "smooth"),
                                      ({"smooth": -1.0}, "smooth"),
                                      ({"smooth": "lots"}, "smooth"),
                                      ({"noise": math.nan}, "noise"),
                                      ({"noise": math.inf}, "noise"),
                                      ({"seed": -1}, "seed")])
def test_generate_parameters(model, kw, name):
    with pytest.raises(mlayer.InvalidArgumentError, match=f"generate: {name}"):
        model.generate(30, guards=False, **kw)


def test_generate_length_and_motion_along(model, little_memory):
    with pytest.raises(MemoryError, match=r"generate: n_frames=10000000"):
        model.generate(10**7, guards=False)
    with pytest.raises(mlayer.InvalidArgumentError, match="motion_along: smooth"):
        model.motion_along(model.points[:10], smooth=math.nan)
    assert model.generate(30, guards=False, smooth=0.0).n_frames == 30
