"""MPJPE and jitter against direct numpy computations, on a real clip and on hand-made arrays."""
import numpy as np
import pytest

import mlayer

from conftest import REPO
from mlayer import metrics


def test_mpjpe_on_a_real_clip_matches_numpy(mocap):
    m = mlayer.read_bvh(mocap / "cmu_10_01_soccer_kick.bvh")
    a, b = m[10:400], m[11:401]  # the clip against itself one frame later
    pa, pb = a.positions(), b.positions()
    ref = np.mean([[np.sqrt(np.sum((pa[f, j] - pb[f, j]) ** 2)) for j in range(pa.shape[1])]
                   for f in range(pa.shape[0])])
    assert metrics.mpjpe(a, b) == pytest.approx(ref, rel=1e-12)
    assert metrics.mpjpe(pa, pb) == pytest.approx(ref, rel=1e-12)  # arrays work too
    assert metrics.mpjpe(a, a) == 0.0


def test_mpjpe_hand_made():
    a = np.zeros((2, 3, 3))
    b = a.copy()
    b[..., 0], b[..., 1] = 3.0, 4.0  # every joint 5 away
    assert metrics.mpjpe(a, b) == 5.0
    b[1] = 0.0  # half the frames exact
    assert metrics.mpjpe(a, b) == 2.5
    with pytest.raises(mlayer.InvalidArgumentError):
        metrics.mpjpe(a, b[:1])
    with pytest.raises(mlayer.InvalidArgumentError):
        metrics.mpjpe(np.zeros((2, 3)), np.zeros((2, 3)))


def test_jitter_on_a_real_clip_matches_numpy(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    p = m.positions()
    d3 = p[3:] - 3 * p[2:-1] + 3 * p[1:-2] - p[:-3]
    ref = np.sqrt((d3 ** 2).sum(axis=-1)).mean()
    assert metrics.jitter(m) == pytest.approx(ref, rel=1e-12)
    assert metrics.jitter(m, fps=m.fps) == pytest.approx(ref * m.fps ** 3, rel=1e-12)
    # a smoothed clip jitters less: a moving average of the positions
    k = np.ones(5) / 5
    smooth = np.apply_along_axis(lambda x: np.convolve(x, k, mode="valid"), 0, p)
    assert metrics.jitter(smooth) < metrics.jitter(p[2:-2])


def test_jitter_hand_made():
    t = np.arange(10.0)
    p = np.zeros((10, 2, 3))
    p[:, 0, 0] = t ** 3  # third difference is 6 everywhere
    p[:, 1, 1] = 2 * t ** 2 - t  # quadratic: third difference 0
    assert metrics.jitter(p) == pytest.approx(3.0, abs=1e-12)
    assert metrics.jitter(p, fps=10) == pytest.approx(3000.0, rel=1e-12)
    with pytest.raises(mlayer.InvalidArgumentError):
        metrics.jitter(p[:3])


def test_units_are_guessed_from_the_body_height_or_given(mocap):
    from mlayer.model.units import length_unit
    assert length_unit(1.7) == "m" and length_unit(170.0) == "cm" and length_unit(1700.0) == "mm"
    assert length_unit(24.0) is None and length_unit(0.01) is None  # CMU's ~24 units: unclear
    lafan = mlayer.read_bvh(mocap / "lafan1_clip_a.bvh")
    assert lafan.units == "cm" and lafan.metres_per_unit == 0.01
    cmu = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    assert cmu.units is None and cmu.metres_per_unit is None
    cmu = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh", units="IN")
    assert cmu.units == "in" and cmu[3:9].units == "in" and cmu.copy().metres_per_unit == 0.0254
    with mlayer.io.bvh.reading_units("ft"):
        assert mlayer.read_bvh(mocap / "lafan1_clip_a.bvh").units == "ft"
    for bad in ("furlong", 1.0, True):
        with pytest.raises(mlayer.InvalidArgumentError, match="units must be one of"):
            mlayer.read_bvh(mocap / "lafan1_clip_a.bvh", units=bad)


def test_inches_are_guessed_where_only_they_give_a_person(mocap):
    """Issue 38, item 5: clips in inches were taken as centimetres (people 0.53-0.59 m tall);
    a character at an odd scale was called millimetres (0.35 m)."""
    from mlayer.model.units import human_leg_length, length_unit
    assert length_unit(53.6, leg=32.3) == "in"      # PyMO's optical walk
    assert length_unit(5.3, leg=2.7) == "ft"
    assert length_unit(154.3, leg=85.9) == "cm"     # LaFAN1
    assert length_unit(1.11, leg=0.64) == "m"       # CMU 60_10, rescaled to metres
    assert length_unit(348.2, leg=164.5) is None    # Mixamo's Malcolm, scaled x2: nothing fits
    assert length_unit(24.1, leg=14.8) is None      # CMU's units (~5.6 cm)
    assert length_unit(41.2, leg=21.7) is None      # a child's size in inches: not guessed
    assert length_unit(50.0, leg=85.0) is None      # a person lying down, in cm: no guess
    wild = REPO / "tests" / "data" / "wild"
    for name in ("pymo_av_8walk_meredith_first600.bvh", "pybvh_test1.bvh", "pybvh_test3.bvh"):
        m = mlayer.read_bvh(wild / name)
        assert m.units == "in" and m.metres_per_unit == 0.0254, name
    assert mlayer.read_bvh(wild / "pybvh_test2.bvh").units == "cm"
    assert mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh").units is None
    assert mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh").units == "cm"
    dog = mlayer.read_bvh(mocap / "ai4a_dog_D1_008_KAN01_002.bvh")
    assert human_leg_length(dog) is None and dog.units == "cm"  # not human: metric units only


def test_info_says_the_given_units(mocap):
    import subprocess
    import sys
    run = [sys.executable, "-m", "mlayer", "info", "--no-tree",
           str(mocap / "cmu_131_01_mj_style_walk.bvh")]
    out = subprocess.run(run + ["--units", "in"], capture_output=True, text=True, check=True)
    assert "in (given): 0.57" in out.stdout
    r = subprocess.run(run + ["--units", "parsec"], capture_output=True, text=True)
    assert r.returncode == 2 and "invalid choice" in r.stderr
