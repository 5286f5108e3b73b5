"""Primitives on small or mixed data (issue 20, item 7): lattice defaults that scale with the
number of frames, a clear error below MIN_FRAMES, clips in other units scaled to the first."""
import subprocess
import sys
import warnings

import numpy as np
import pytest

import mlayer
from conftest import requires
from mlayer import InvalidArgumentError, MlayerWarning, PrimitiveModel
from mlayer.guards.metrics import body_height
from mlayer.manifold.primitives import MIN_FRAMES, default_lattices


def _clip(mocap, name, *, trim="auto"):
    path = mocap / name
    if not path.exists():
        pytest.skip(f"{name} not found")
    return mlayer.read_bvh(path, trim=trim)


def test_the_default_lattices_scale_with_the_frames():
    assert default_lattices(16) == ((4, 4), (2, 2))
    assert default_lattices(60) == ((7, 7), (3, 3))
    assert default_lattices(224) == ((14, 14), (7, 7))
    assert default_lattices(899) == ((29, 29), (14, 14))
    for n in (900, 7184):  # the paper's sizes from 900 frames on
        assert default_lattices(n) == ((30, 30), (15, 15))
    for n in range(MIN_FRAMES, 400):
        (s, _), (g, _) = default_lattices(n)
        assert s * s <= n and 4 * g * g <= n and g <= s
    with pytest.raises(InvalidArgumentError, match="15 training frames are too few"):
        default_lattices(15)


def test_a_60_frame_clip_with_the_defaults(mocap, tmp_path):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")[:60]
    model = PrimitiveModel.fit(m)
    assert model.som_codebook.shape[:2] == (7, 7)
    assert model.grbf.lattice == (3, 3)
    assert model.points.shape == (60, 2)
    g = model.generate(40, seed=1)
    assert g.n_frames == 40 and np.isfinite(g.rot).all()
    # the training poses are reproduced to a fraction of the body height
    assert model.fit_error < 0.05 * body_height(m)
    # the PCA manifold gets the lattice default too
    assert PrimitiveModel.fit(m, manifold="pca").grbf.lattice == (3, 3)
    # an explicit SOM smaller than the default lattice bounds it
    assert PrimitiveModel.fit(m, som=(2, 5), epochs=2).grbf.lattice == (2, 3)
    # and on the command line
    path = tmp_path / "short.bvh"
    mlayer.write_bvh(m, path)
    r = subprocess.run([sys.executable, "-m", "mlayer", "primitives", str(path), "-o",
                        str(tmp_path / "p.npz"), "--plots", ""], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert "GRBF: thin_plate, 3x3 centres, 60 frames" in r.stderr


def test_too_few_frames_is_one_clear_error(mocap, tmp_path):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")[:12]
    with pytest.raises(InvalidArgumentError, match="12 training frames are too few for the "
                                                   "default lattices"):
        PrimitiveModel.fit(m)
    # with both lattices given, the defaults' minimum does not apply
    assert PrimitiveModel.fit(m, som=(3, 3), lattice=(2, 2), k=2, epochs=2).points.shape[0] == 12


@requires("plot")  # (without matplotlib, the default --plots is the first error)
def test_too_few_frames_is_one_clear_error_on_the_command_line(mocap, tmp_path):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")[:12]
    path = tmp_path / "tiny.bvh"
    mlayer.write_bvh(m, path)
    r = subprocess.run([sys.executable, "-m", "mlayer", "primitives", str(path), "-o",
                        str(tmp_path / "p.npz")], capture_output=True, text=True, timeout=300)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("mlayer primitives: error")]
    assert len(errors) == 1 and "too few" in errors[0] and "--som and --lattice" in errors[0]
    assert not (tmp_path / "p.npz").exists()


def _scaled(m, f):
    sk = m.skeleton
    s = mlayer.Skeleton(sk.joint_names, sk.parents, sk.offsets * f, sk.channels,
                        sk.end_site_parents, sk.end_site_offsets * f)
    return mlayer.Motion(s, m.frame_time, m.root_pos * f, m.rot, m.trans * f)


def test_clips_in_other_units_are_scaled_to_the_first(mocap):
    # one rig (CMU's Daz-style 43 joints) in centimetres and in metres (a rescaled copy)
    a = _clip(mocap, "cmu_10_01_soccer_kick.bvh")[:300]
    b = _clip(mocap, "cmu_60_10_salsa_dance.bvh")[:300]
    ha, hb = body_height(a), body_height(b)
    assert ha / hb > 100
    opts = dict(k=4, epochs=3, som=(10, 10), lattice=(6, 6))
    with pytest.warns(MlayerWarning, match=r"clip 1 is in other units than clip 0 \(body "
                                           r"height 1.1\d* against 14\d\.\d*\): scaled by 12"):
        model = PrimitiveModel.fit([a, b], **opts)
    # the same model as from the second clip scaled by hand
    with warnings.catch_warnings():
        warnings.simplefilter("error", MlayerWarning)
        ref = PrimitiveModel.fit([a, _scaled(b, ha / hb)], **opts)
    np.testing.assert_array_equal(model.points, ref.points)
    np.testing.assert_allclose(model.grbf.coef_, ref.grbf.coef_, rtol=1e-9, atol=1e-9)
    # both clips' poses share the manifold: the salsa's frames are fitted as well as the kick's
    # (measured: 1.1% and 0.8% of the body height; without the scaling the salsa, at 1/128 of
    # the kick's size, came out at 18% of its own height)
    fit = model.predict(model.points)["positions"].reshape(600, -1)
    X = mlayer.pose_features([a, _scaled(b, ha / hb)])
    err = np.linalg.norm((fit - X).reshape(600, -1, 3), axis=-1).mean(-1)
    assert err[300:].mean() < 0.03 * ha and err[:300].mean() < 0.03 * ha
    # generated motion is in the first clip's units
    g = model.generate(60, seed=2, guards=False)
    assert 0.5 < body_height(g) / ha < 1.5


def test_clips_in_one_unit_are_not_scaled(mocap):
    a = _clip(mocap, "cmu_10_01_soccer_kick.bvh")[:200]
    with warnings.catch_warnings():
        warnings.simplefilter("error", MlayerWarning)
        model = PrimitiveModel.fit([a, _scaled(a, 1.9)], k=3, epochs=2, som=(6, 6),
                                   lattice=(4, 4))
    X = mlayer.pose_features([a, _scaled(a, 1.9)])
    # the second clip keeps its size: its features are 1.9 times the first's
    np.testing.assert_allclose(X[200:], 1.9 * X[:200], rtol=1e-9, atol=1e-9)
    assert model.points.shape == (400, 2)
