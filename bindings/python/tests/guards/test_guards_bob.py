"""Alpha means alpha for the body's bob too (issue 38 item 6), with the guards on.

The bob, defined here and not by mlayer: the standard deviation over frames of the pelvis'
height minus its centred moving average over 1 s. The synthesis scales it by alpha; the contact
cleanup, pinning the feet, moved the body by what the legs could not reach within 0.1 s and so
put the bob back at alpha 0.5 (LaFAN1: 1.30 alpha) or took it out at alpha 3 (CMU 02_03's
run: 0.69 alpha). The vertical part of that shift is now spread over a gait cycle.
"""
import warnings

import numpy as np
import pytest

import mlayer


def bob(m: mlayer.Motion, pelvis: int = 0) -> float:
    up = "xyz".index(str(m.up_axis).lower()[-1])
    y = np.asarray(m.positions(), float)[:, pelvis, up]
    w = int(round(m.fps)) | 1
    h = w // 2
    yp = np.concatenate([np.full(h, y[0]), y, np.full(h, y[-1])])
    c = np.concatenate([[0.0], np.cumsum(yp)])
    return float(np.std(y - (c[w:] - c[:-w]) / w))


@pytest.mark.parametrize("name, alpha", [
    ("cmu_02_03_run_jog_25fps.bvh", 3.0),  # 0.69 alpha before
    ("cmu_02_03_run_jog_25fps.bvh", 2.0),
    ("lafan1_clip_a.bvh", 0.5),
    ("lafan1_clip_a.bvh", 2.0),
    ("lafan1_clip_a.bvh", 3.0),
])
def test_the_bob_follows_alpha_with_the_guards_on(mocap, name, alpha):
    m = mlayer.read_bvh(mocap / name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = mlayer.stylize(m, alpha)
        raw = mlayer.stylize(m, alpha, limits=None, floor=None, keep_contacts=False)
    assert 0.85 <= bob(raw) / bob(m) / alpha <= 1.15  # the synthesis scales it
    assert 0.7 <= bob(out) / bob(m) / alpha <= 1.3


def test_a_toe_the_cleanup_takes_under_the_floor_does_not_lift_the_body_each_step():
    """CMU 01_03's climb (tests/data/wild) at alpha 0.5: after the cleanup a toe tip went under
    the floor at each step's toe-off, and the floor's last lift raised the whole body for it,
    once a step: the bob kept 1.32 alpha. The toe tips are turned up once more after the
    cleanup (the tilt of toe_tilt.c, as before it), and the body is lifted only for what the
    tilt cannot reach."""
    from conftest import REPO
    m = mlayer.read_bvh(REPO / "tests" / "data" / "wild" / "assimp_cmu_01_03_first600.bvh")
    pelvis = list(m.joint_names).index("Hips")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = mlayer.stylize(m, 0.5)
    assert 0.7 <= bob(out, pelvis) / bob(m, pelvis) / 0.5 <= 1.3
