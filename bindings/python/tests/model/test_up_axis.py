"""Up axis: detected on the shared clips and on Z-up and X-up copies of them, given by read_bvh
and the CLI, and followed by the contacts, the body height, the guards and the features."""
import subprocess
import sys

import numpy as np
import pytest

import mlayer
from mlayer.model.up_axis import to_y_up
from conftest import SHARED_CLIPS

_H = np.sqrt(0.5)
# proper rotations taking +Y to each axis (the inverses of to_y_up's)
_FROM_Y = {"z": np.array([_H, _H, 0.0, 0.0]), "x": np.array([_H, 0.0, 0.0, -_H])}


def _qmul(a, b):
    w, x, y, z = a
    return np.stack([w * b[..., 0] - x * b[..., 1] - y * b[..., 2] - z * b[..., 3],
                     w * b[..., 1] + x * b[..., 0] + y * b[..., 3] - z * b[..., 2],
                     w * b[..., 2] - x * b[..., 3] + y * b[..., 0] + z * b[..., 1],
                     w * b[..., 3] + x * b[..., 2] - y * b[..., 1] + z * b[..., 0]], axis=-1)


def _rotate(q, v):
    """v (..., 3) rotated by unit quaternion q (an independent formula: the matrix of q)."""
    w, x, y, z = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return v @ R.T


def _turned(m, up):
    """The clip m (Y-up) standing on ``up`` instead: its root turned by a fixed rotation."""
    q = _FROM_Y[up]
    rot = m.rot.copy()
    rot[:, 0] = _qmul(q, rot[:, 0])
    out = m.with_frames(root_pos=_rotate(q, m.root_pos), rot=rot)
    out.up_axis = None  # detect
    return out


@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_the_shared_clips_are_y_up_and_their_turned_copies_are_found(mocap, name):
    m = mlayer.read_bvh(mocap / name)[:1500]
    g = mlayer.detect_up(m)
    assert (g.axis, g.sign, g.method) == ("y", 1, "feet") and g.sure, g
    assert m.up_axis == "y"
    for up in ("z", "x"):
        t = _turned(m, up)
        g = mlayer.detect_up(t)
        assert (g.axis, g.sign) == (up, 1) and g.sure, (up, g)
        assert t.up_axis == up
        # the turned positions are the originals turned (checked independently of to_y_up)
        np.testing.assert_allclose(_rotate(_FROM_Y[up], m.positions()), t.positions(),
                                   atol=1e-9 * mlayer.metrics.body_height(m))
        np.testing.assert_allclose(to_y_up(up, t.positions()), m.positions(),
                                   atol=1e-9 * mlayer.metrics.body_height(m))


@pytest.mark.parametrize("name", ["cmu_131_01_mj_style_walk.bvh", "lafan1_clip_a.bvh",
                                  "bandai1_walk_happy_001.bvh"])
def test_contacts_height_guards_and_features_follow_the_up_axis(mocap, name):
    m = mlayer.read_bvh(mocap / name)[:1200]
    t = _turned(m, "z")
    h = mlayer.metrics.body_height(m)
    assert mlayer.metrics.body_height(t) == pytest.approx(h, rel=1e-9)
    # along Y the turned clip's extent is another (a depth, or Bandai's path from its static
    # root): the wrong axis gives a wrong size
    assert abs(mlayer.metrics.body_height(t, up="y") - h) > 0.2 * h
    names, c = mlayer.detect_contacts(m)
    names_t, c_t = mlayer.detect_contacts(t)
    assert names_t == names
    assert (c_t == c).mean() > 0.999
    assert mlayer.guards.cleanup.floor_height(t) == pytest.approx(
        mlayer.guards.cleanup.floor_height(m), abs=1e-6 * h)
    # stylize with every guard: the turned result is the result turned
    s = mlayer.stylize(m, 2.0)
    s_t = mlayer.stylize(t, 2.0)
    err = np.abs(to_y_up("z", s_t.positions()) - s.positions()).max()
    assert err < 1e-6 * h, err / h
    # pose features remove the heading about the up axis
    f, f_t = mlayer.manifold.features.pose_features(m), mlayer.manifold.features.pose_features(t)
    assert np.abs(f - f_t).max() < 1e-6 * h


def test_read_bvh_and_assignment_give_the_axis(mocap):
    path = mocap / "cmu_131_01_mj_style_walk.bvh"
    m = mlayer.read_bvh(path, up="Z")
    assert m.up_axis == "z"
    assert m[10:20].up_axis == "z" and m.copy().up_axis == "z"
    assert m.with_frames().up_axis == "z"
    m.up_axis = None
    assert m.up_axis == "y"
    text = path.read_text()
    assert mlayer.read_bvh_string(text, up=0).up_axis == "x"
    with mlayer.model.up_axis.reading_up("z"):
        assert mlayer.read_bvh(path).up_axis == "z"
        assert mlayer.read_bvh(path, up="y").up_axis == "y"
    assert mlayer.read_bvh(path).up_axis == "y"
    for bad in ("w", 3, True, 1.0):
        with pytest.raises(mlayer.InvalidArgumentError, match="up must be"):
            mlayer.read_bvh(path, up=bad)
        with pytest.raises(mlayer.InvalidArgumentError, match="up must be"):
            m.up_axis = bad


def test_a_clip_with_no_names_and_no_extent_is_y_with_no_confidence():
    sk = mlayer.Skeleton(["a", "b"], [-1, 0], np.zeros((2, 3)))
    m = mlayer.Motion(sk, 1 / 30, np.zeros((5, 3)), np.tile([1.0, 0, 0, 0], (5, 2, 1)))
    g = mlayer.detect_up(m)
    assert (g.axis, g.method, g.confidence, g.sure) == ("y", "none", 0.0, False)
    assert m.up_axis == "y"


def test_info_prints_the_axis_and_up_overrides_it(mocap, tmp_path):
    m = _turned(mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[:300], "z")
    path = tmp_path / "zup.bvh"
    mlayer.write_bvh(m, path)
    run = [sys.executable, "-m", "mlayer", "info", "--no-tree", str(path)]
    out = subprocess.run(run, capture_output=True, text=True, check=True).stdout
    assert "up        Z (detected from the feet, confidence" in out
    assert "extent along Z" in out
    out = subprocess.run(run + ["--up", "y"], capture_output=True, text=True, check=True).stdout
    assert "up        Y (given)" in out
    r = subprocess.run(run + ["--up", "q"], capture_output=True, text=True)
    assert r.returncode == 2 and "invalid choice" in r.stderr
