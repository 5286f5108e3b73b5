"""The synthesis pipeline (mlayer.pipeline.pipeline): the C defaults give the Python API's motion,
the guards keep stylized real clips within what a body does, and bad switches are refused."""
import math
import warnings

import numpy as np
import pytest

import mlayer
from conftest import REPO, SHARED_CLIPS
from mlayer import _arrays
from mlayer.guards import plausibility as pl
from mlayer._native import ffi, lib
from mlayer.model._rig import c_rig
from mlayer.guards.metrics import body_height

CLIPS = SHARED_CLIPS


def _read(mocap, name, frames=1800):
    m = mlayer.read_bvh(mocap / name)
    return m[:frames] if frames and m.n_frames > frames else m


def _c_stylize(m, alpha):
    """What a runtime on the C ABI does with every default: decompose (the frame rate and the
    body height are the options), synthesize at alpha, create the guards with no option and
    apply them (no
    reference: the input's). The body translation goes where mlr_rig_body_translation_joint
    says (group 0 of the layers)."""
    N, J = m.n_frames, m.n_joints
    root, rot, trans = m._frames()
    rig, keep = c_rig(m.skeleton)
    diag = ffi.new("mlr_diag *")
    bj = ffi.new("int32_t *")
    assert lib.mlr_rig_body_translation_joint(rig, N, _arrays.ptr(root),
                                              _arrays.ptr(trans) if trans.size else ffi.NULL,
                                              bj, diag) == 0
    body = int(bj[0])
    if body == 0:
        group0 = root
    else:
        group0 = np.ascontiguousarray(trans[:, list(m.skeleton.trans_joints).index(body)])
    # the body height sets the translation's outlier gate (robust decomposition, on by default)
    opts = ffi.new("mlr_layers_option[]", 3)
    opts[0].key, opts[0].value = lib.MLR_LAYERS_OPT_FPS, m.fps
    opts[1].key, opts[1].value = lib.MLR_LAYERS_OPT_BODY_HEIGHT, body_height(m)
    opts[2].key, opts[2].value = lib.MLR_LAYERS_OPT_BODY_JOINT, body
    h = ffi.new("mlr_layers **")
    assert lib.mlr_layers_decompose(N, J, _arrays.ptr(group0), _arrays.ptr(rot), opts,
                                    3 if body else 2, ffi.NULL, h, diag) == 0, \
        ffi.string(diag.message)
    layers = ffi.gc(h[0], lib.mlr_layers_destroy)

    def synth(a):
        g0, q = np.empty((N, 3)), np.empty((N, J, 4))
        w = np.array([a], dtype=np.float64)
        assert lib.mlr_layers_synthesize(layers, 0, N, _arrays.ptr(w), 1, _arrays.ptr_out(g0),
                                         3 * N, _arrays.ptr_out(q), 4 * N * J, ffi.NULL) == 0
        r, t = root.copy(), trans.copy()
        if body == 0:
            r = g0
        else:
            t[:, list(m.skeleton.trans_joints).index(body)] = g0
        return r, q, t

    out_r, out_q, out_t = synth(alpha)
    # the guards learn from the input with its outlier frames replaced by denoised ones
    flags = np.zeros((N, 1 + J), dtype=np.uint8)
    assert lib.mlr_layers_get_outliers(layers, ffi.from_buffer("unsigned char[]", flags,
                                                               require_writable=True),
                                       flags.size) == 0
    bad = np.flatnonzero(flags.any(axis=1))
    gr, gq, gt = root.copy(), rot.copy(), trans.copy()
    if bad.size:
        dr, dq, dt = synth(1.0)
        gr[bad], gq[bad] = dr[bad], dq[bad]
        if gt.size:
            gt[bad] = dt[bad]
    g = ffi.new("mlr_guards **")
    tp = _arrays.ptr(gt) if gt.size else ffi.NULL
    assert lib.mlr_guards_create(rig, m.fps, N, _arrays.ptr(gr), _arrays.ptr(gq), tp,
                                 ffi.NULL, 0, ffi.NULL, g, diag) == 0, ffi.string(diag.message)
    guards = ffi.gc(g[0], lib.mlr_guards_destroy)
    w = np.array([alpha], dtype=np.float64)
    assert lib.mlr_guards_apply_trans(
        guards, _arrays.ptr(w), 1, ffi.NULL, ffi.NULL, ffi.NULL, _arrays.ptr_out(out_r),
        _arrays.ptr_out(out_q), _arrays.ptr_out(out_t) if trans.size else ffi.NULL, ffi.NULL, 0,
        ffi.NULL, diag) == 0, ffi.string(diag.message)
    return m.with_frames(root_pos=out_r, rot=out_q, trans=out_t)


@pytest.mark.parametrize("name", ["cmu_131_01_mj_style_walk.bvh", "bandai1_walk_happy_001.bvh",
                                  "ai4a_dog_D1_008_KAN01_002.bvh"])
@pytest.mark.parametrize("alpha", [1.0, 2.5])
def test_c_defaults_give_the_python_motion(mocap, name, alpha):
    m = _read(mocap, name, 900)
    py = mlayer.stylize(m, alpha) if alpha != 1.0 else mlayer.denoise(m)
    c = _c_stylize(m, alpha)
    p1, p2 = py.positions(), c.positions()
    H = body_height(m)
    assert np.max(np.abs(p1 - p2)) <= 1e-9 * H
    assert np.max(np.abs(py.trans - c.trans), initial=0.0) <= 1e-9 * H


@pytest.mark.parametrize("name", CLIPS)
@pytest.mark.parametrize("alpha", [2.0, 3.0])
def test_stylized_feet_slide_at_most_the_inputs(mocap, name, alpha):
    """Item 7 of issue 18: with every guard on, the stylized feet slide no more than the
    input's on the input's contacts. The last limits pass leaves the hinges IK put within
    their range as they are (LaFAN1 at alpha 3 slid 1.09x the input's when that pass also
    softened the straight stance knees within the reversal margin)."""
    from mlayer.guards.metrics import foot_sliding
    m = _read(mocap, name)
    names, c = mlayer.detect_contacts(m)
    out = mlayer.stylize(m, alpha)
    assert foot_sliding(out, c, names) <= foot_sliding(m, c, names) * (1 + 1e-9)


@pytest.mark.parametrize("name", CLIPS)
@pytest.mark.parametrize("alpha", [2.0, 3.0])
def test_stylize_keeps_knees_and_elbows_plausible(mocap, name, alpha):
    m = _read(mocap, name)
    out, report = mlayer.stylize(m, alpha, return_report=True)
    lim = mlayer.joint_limits(m)
    v = pl.hinge_violations(m, out, lim)
    assert report.limits_applied
    assert v["fold_frames"] == 0 and v["reversal_frames"] == 0, v["joints"]
    raw = mlayer.stylize(m, alpha, limits=None, floor=None, keep_contacts=False)
    assert np.max(np.abs(raw.positions() - out.positions())) > 0.01 * body_height(m)


@pytest.mark.parametrize("name", ["cmu_131_01_mj_style_walk.bvh", "cmu_60_10_salsa_dance.bvh"])
def test_switches_turn_each_guard_off(mocap, name):
    m = _read(mocap, name, 600)
    raw = mlayer.decompose(m).synthesize(2.0)
    off = mlayer.stylize(m, 2.0, limits=None, floor=None, keep_contacts=False)
    np.testing.assert_allclose(off.positions(), raw.positions(), atol=1e-9)
    _, rep = mlayer.stylize(m, 2.0, limits=None, return_report=True)
    assert not rep.limits_applied and rep.limited == {}
    _, rep = mlayer.stylize(m, 0.5, return_report=True)
    assert not rep.limits_applied  # the limits run by default only when some |alpha| > 1
    _, rep = mlayer.stylize(m, 0.5, limits=True, return_report=True)
    assert rep.limits_applied
    _, rep = mlayer.stylize(m, 2.0, floor=None, return_report=True)
    assert math.isnan(rep.floor_height) and rep.floor_frames == 0


def test_one_synthesis_serves_many_alphas(mocap):
    m = _read(mocap, "cmu_131_01_mj_style_walk.bvh", 600)
    s = mlayer.Synthesis(m)
    for a in (0.5, 2.0):
        out, _ = s.run(a)
        np.testing.assert_allclose(out.positions(), mlayer.stylize(m, a).positions(),
                                   atol=1e-12 * body_height(m))
    names, c = s.contacts()
    ref_names, ref_c = mlayer.detect_contacts(m)
    assert names == ref_names and np.array_equal(c, ref_c)


def test_explicit_limits_and_contact_joints(mocap):
    m = _read(mocap, "cmu_131_01_mj_style_walk.bvh", 600)
    lim = mlayer.joint_limits(m)
    knee = lim.hinges()[0]
    name = m.joint_names[knee]
    lo, hi = lim.range(name)["lo"], lim.range(name)["hi"]
    lim.set_range(name, kind="hinge", lo=lo, hi=min(hi, math.radians(60)))
    out, rep = mlayer.stylize(m, 2.0, limits=lim, return_report=True)
    assert name in rep.limited
    flex = pl.hinge_angles(out, lim)[name]["flexion"]
    assert flex.max() < 60.0 + 1e-6
    out2, rep2 = mlayer.stylize(m, 2.0, contact_joints=["LeftAnkle", "RightAnkle"],
                                return_report=True)
    assert rep2.contact_frames > 0


@pytest.mark.parametrize("kw, word", [({"limits": "sometimes"}, "limits"),
                                      ({"floor": float("nan")}, "floor"),
                                      ({"floor": "low"}, "floor"),
                                      ({"keep_contacts": "yes"}, "keep_contacts"),
                                      ({"up": "w"}, "up"),
                                      ({"contact_joints": ["NoSuchJoint"]}, "NoSuchJoint")])
def test_bad_switches_name_the_argument(mocap, kw, word):
    m = _read(mocap, "cmu_131_01_mj_style_walk.bvh", 200)
    with pytest.raises(mlayer.InvalidArgumentError, match=word):
        mlayer.stylize(m, 2.0, **kw)


def test_nan_alpha_is_refused(mocap):
    m = _read(mocap, "cmu_131_01_mj_style_walk.bvh", 200)
    with pytest.raises(mlayer.InvalidArgumentError, match="alpha"):
        mlayer.stylize(m, float("nan"))
    with pytest.raises(mlayer.InvalidArgumentError, match="alpha"):
        mlayer.stylize(m, 2.0, {"Left*": float("inf")})


def _count_fk(monkeypatch, inputs):
    """Count Motion._fk passes: (over the given motions' frames, over anything else)."""
    from mlayer.model import motion as M
    counts = {"input": 0, "other": 0}
    orig = M.Motion._fk

    def counting(self, want_rot):
        same = any(self.rot is m.rot for m in inputs)
        counts["input" if same else "other"] += 1
        return orig(self, want_rot)
    monkeypatch.setattr(M.Motion, "_fk", counting)
    return counts


def test_a_clip_computes_the_input_fk_once(mocap, monkeypatch):
    """One Clip: the up axis, body height, decomposition's gate, contacts, jitter and sliding
    of the input, and a stylize and a denoise, from one forward-kinematics pass of the input;
    the results are those of the separate functions."""
    m = _read(mocap, "lafan1_clip_a.bvh", 600)
    counts = _count_fk(monkeypatch, [m])
    clip = mlayer.pipeline.pipeline.Clip(m)
    out, rep = clip.stylize(2.0)
    den, _ = clip.denoise()
    figures = (clip.up, clip.body_height, clip.jitter(), clip.foot_sliding())
    names, c = clip.contacts
    assert counts == {"input": 1, "other": 0}
    monkeypatch.undo()
    assert figures[0] == m.up_axis
    assert figures[1] == body_height(m)
    assert figures[2] == pytest.approx(mlayer.metrics.jitter(m, fps=m.fps) / body_height(m),
                                       rel=1e-12)
    n2, c2 = mlayer.detect_contacts(m)
    assert names == n2 and np.array_equal(c, c2)
    assert figures[3] == pytest.approx(mlayer.metrics.foot_sliding(m, c2, n2) / body_height(m),
                                       rel=1e-12)
    ref = mlayer.stylize(m, 2.0)
    assert np.array_equal(out.rot, ref.rot) and np.array_equal(out.root_pos, ref.root_pos)
    assert np.array_equal(den.rot, mlayer.denoise(m).rot)
    # one decomposition serves both (same layer options); other guard options share it too
    assert clip.synthesis().layers is clip.synthesis(keep_contacts=False).layers
    assert clip.synthesis(gamma=2.0).layers is not clip.synthesis().layers


def test_stylize_runs_one_python_fk_pass_over_the_input(mocap, monkeypatch):
    m = _read(mocap, "cmu_01_01_playground_jumps.bvh", 600)
    counts = _count_fk(monkeypatch, [m])
    mlayer.stylize(m, 2.0)
    assert counts["input"] == 1


def test_up_axis_is_detected_once_and_kept(mocap, monkeypatch):
    m = _read(mocap, "lafan1_clip_a.bvh", 300)
    counts = _count_fk(monkeypatch, [m])
    ups = {m.up_axis for _ in range(3)}
    assert ups == {"y"} and counts["input"] == 1
    m.up_axis = None          # detect again
    assert m.up_axis == "y" and counts["input"] == 2
    m.rot = m.rot.copy()      # new frames: detect again
    assert m.up_axis == "y" and counts["input"] == 3
    assert m.up_axis == "y" and counts == {"input": 3, "other": 0}


def test_a_body_upside_down_is_named_in_a_warning():
    """Video pose estimators write image coordinates, y down: MediaPipe's and Azure Kinect's
    BVH exports stand on their heads along +Y, and the guards, which measure height along +Y,
    take their heads for the lowest points. The C guards note it, Python warns with it; the
    same clip upright does not warn."""
    m = mlayer.data.load_sample()[:240]
    with warnings.catch_warnings():
        warnings.simplefilter("error", mlayer.MlayerWarning)
        mlayer.stylize(m, 2.0)
    # a half turn about X: y and z negated, the root's rotation turned with them
    root = m.root_pos.copy()
    root[:, 1:] = -root[:, 1:]
    rot = m.rot.copy()
    w, x, y, z = (rot[:, 0, i].copy() for i in range(4))
    rot[:, 0] = np.stack([-x, w, -z, y], axis=-1)
    flipped = m.with_frames(root_pos=root, rot=rot)
    flipped.up_axis = "y"
    with pytest.warns(mlayer.MlayerWarning, match=r"upside down along \+Y"):
        mlayer.stylize(flipped, 2.0)


def test_a_guard_that_cannot_run_is_named_in_a_warning():
    """Issue 38, item 7: a rig without feet (fairmotion's 4-joint chain) got no contact or floor
    guard, silently; the C guards leave a note in their diag, Python warns with it."""
    m = mlayer.read_bvh(REPO / "tests" / "data" / "wild" / "fairmotion_sinusoidal.bvh",
                        strict=False)
    with pytest.warns(mlayer.MlayerWarning, match="no foot found.*contact and floor guards"):
        mlayer.stylize(m, 2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", mlayer.MlayerWarning)
        mlayer.stylize(m, 2.0, floor=None, keep_contacts=False)  # nothing skipped: no warning
