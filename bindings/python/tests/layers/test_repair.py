"""mlr_layers_repair (issue 18, item 1): the guards learn from the input with its outlier frames
replaced by the denoised ones, in the C core, so a runtime on the C ABI gets Python's motion."""
import numpy as np
import pytest

import mlayer
from mlayer import _arrays
from mlayer._native import ffi, lib
from mlayer.guards.metrics import body_height
from mlayer.pipeline.pipeline import Synthesis
from test_robust import glitch


def _numpy_repair(layers):
    """The composition Python's pipeline did before the C function: the alpha-1 synthesis
    written over every frame that is an outlier of some group."""
    m = layers.motion
    bad = layers.outlier_frames
    if bad.size == 0:
        return m
    den = layers.synthesize(1.0)
    root, rot, trans = m.root_pos.copy(), m.rot.copy(), m.trans.copy()
    root[bad], rot[bad] = den.root_pos[bad], den.rot[bad]
    if trans.size:
        trans[bad] = den.trans[bad]
    return m.with_frames(root_pos=root, rot=rot, trans=trans)


@pytest.fixture(scope="module")
def glitched(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[:900]
    return glitch(m, 400)


@pytest.fixture(scope="module")
def glitched_bandai(mocap):
    """A rig whose body translation rides on Hips (a non-root joint): the glitch goes into its
    position channels."""
    m = mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")
    layers = mlayer.decompose(m)
    assert layers.body_joint != 0
    col = int(np.flatnonzero(m.skeleton.trans_joints == layers.body_joint)[0])
    trans = m.trans.copy()
    h = body_height(m)
    for k, i in enumerate(range(200, 204)):
        trans[i, col] += (1 if k % 2 == 0 else -1) * 1000 * h * np.array([1.0, 0.3, -0.5])
    return m.with_frames(trans=trans)


@pytest.mark.parametrize("clip", ["glitched", "glitched_bandai"])
def test_repaired_is_the_numpy_composition(request, clip):
    m = request.getfixturevalue(clip)
    layers = mlayer.decompose(m)
    assert layers.outlier_frames.size >= 4
    got, want = layers.repaired(), _numpy_repair(layers)
    for a, b in ((got.root_pos, want.root_pos), (got.rot, want.rot), (got.trans, want.trans)):
        assert a.shape == b.shape
        assert np.max(np.abs(a - b), initial=0.0) <= 1e-12
    # frames that are not outliers are the input's, bit for bit
    ok = np.setdiff1d(np.arange(m.n_frames), layers.outlier_frames)
    assert np.array_equal(got.rot[ok], m.rot[ok])
    assert np.array_equal(got.root_pos[ok], m.root_pos[ok])


def test_no_outliers_gives_the_input(glitched):
    layers = mlayer.decompose(glitched, robust=False)
    assert layers.outlier_frames.size == 0
    assert layers.repaired() is glitched


@pytest.mark.parametrize("clip", ["glitched", "glitched_bandai"])
def test_stylize_unchanged_by_the_c_repair(request, monkeypatch, clip):
    m = request.getfixturevalue(clip)
    new = mlayer.stylize(m, 2.0)
    den = mlayer.denoise(m)
    monkeypatch.setattr(Synthesis, "_guard_input", lambda self: _numpy_repair(self.layers))
    old = mlayer.stylize(m, 2.0)
    old_den = mlayer.denoise(m)
    for a, b in ((new, old), (den, old_den)):
        assert np.max(np.abs(a.positions() - b.positions())) <= 1e-12 * body_height(m)
        assert np.max(np.abs(a.rot - b.rot)) <= 1e-12


def test_c_repair_bad_arguments(glitched):
    layers = mlayer.decompose(glitched)
    N, J = glitched.n_frames, glitched.n_joints
    t = np.array(glitched.root_pos, order="C")
    q = np.array(glitched.rot, order="C")
    n = ffi.new("size_t *")
    diag = ffi.new("mlr_diag *")
    assert lib.mlr_layers_repair(layers._h, 0, N, _arrays.ptr_out(t), t.size - 1, ffi.NULL, 0,
                                 n, diag) == lib.MLR_E_INVALID_ARG
    assert "n_root_pos" in ffi.string(diag.message).decode()
    assert lib.mlr_layers_repair(layers._h, 1, N, ffi.NULL, 0, _arrays.ptr_out(q), q.size,
                                 n, ffi.NULL) == lib.MLR_E_INVALID_ARG
    assert np.array_equal(q, glitched.rot) and np.array_equal(t, glitched.root_pos)
    assert lib.mlr_layers_repair(layers._h, 0, N, _arrays.ptr_out(t), t.size, _arrays.ptr_out(q),
                                 q.size, n, ffi.NULL) == lib.MLR_OK
    assert n[0] == layers.outlier_frames.size
    assert 4 * J * N == q.size


def _c_stylize_repaired(m, alpha):
    """A runtime on the C ABI with every default, the guards' input repaired in C:
    decompose (fps, body height, body joint), mlr_layers_repair on a copy of the input,
    mlr_guards_create on it, synthesize at alpha, mlr_guards_apply_trans (no reference)."""
    from mlayer.model._rig import c_rig
    N, J = m.n_frames, m.n_joints
    root, rot, trans = m._frames()
    rig, keep = c_rig(m.skeleton)
    diag = ffi.new("mlr_diag *")
    body = mlayer.decompose(m).body_joint
    col = list(m.skeleton.trans_joints).index(body) if body else None
    group0 = root if body == 0 else np.ascontiguousarray(trans[:, col])
    opts = ffi.new("mlr_layers_option[]", 3)
    opts[0].key, opts[0].value = lib.MLR_LAYERS_OPT_FPS, m.fps
    opts[1].key, opts[1].value = lib.MLR_LAYERS_OPT_BODY_HEIGHT, body_height(m)
    opts[2].key, opts[2].value = lib.MLR_LAYERS_OPT_BODY_JOINT, body
    h = ffi.new("mlr_layers **")
    assert lib.mlr_layers_decompose(N, J, _arrays.ptr(group0), _arrays.ptr(rot), opts,
                                    3 if body else 2, ffi.NULL, h, diag) == 0
    layers = ffi.gc(h[0], lib.mlr_layers_destroy)
    g0, gq = group0.copy(), rot.copy()
    assert lib.mlr_layers_repair(layers, 0, N, _arrays.ptr_out(g0), g0.size, _arrays.ptr_out(gq),
                                 gq.size, ffi.NULL, ffi.NULL) == 0
    gr, gt = (g0, trans) if body == 0 else (root, trans.copy())
    if body:
        gt[:, col] = g0
    g = ffi.new("mlr_guards **")
    assert lib.mlr_guards_create(rig, m.fps, N, _arrays.ptr(gr), _arrays.ptr(gq),
                                 _arrays.ptr(gt) if gt.size else ffi.NULL, ffi.NULL, 0,
                                 ffi.NULL, g, diag) == 0, ffi.string(diag.message)
    guards = ffi.gc(g[0], lib.mlr_guards_destroy)
    s0, q = np.empty((N, 3)), np.empty((N, J, 4))
    w = np.array([alpha], dtype=np.float64)
    assert lib.mlr_layers_synthesize(layers, 0, N, _arrays.ptr(w), 1, _arrays.ptr_out(s0),
                                     3 * N, _arrays.ptr_out(q), 4 * N * J, ffi.NULL) == 0
    out_r, out_t = (s0, trans.copy()) if body == 0 else (root.copy(), trans.copy())
    if body:
        out_t[:, col] = s0
    assert lib.mlr_guards_apply_trans(
        guards, _arrays.ptr(w), 1, ffi.NULL, ffi.NULL, ffi.NULL, _arrays.ptr_out(out_r),
        _arrays.ptr_out(q), _arrays.ptr_out(out_t) if out_t.size else ffi.NULL, ffi.NULL, 0,
        ffi.NULL, diag) == 0, ffi.string(diag.message)
    return m.with_frames(root_pos=out_r, rot=q, trans=out_t)


@pytest.mark.parametrize("clip", ["glitched", "glitched_bandai"])
@pytest.mark.parametrize("alpha", [1.0, 2.5])
def test_c_runtime_with_repair_gives_the_python_motion(request, clip, alpha):
    m = request.getfixturevalue(clip)
    py = mlayer.stylize(m, alpha) if alpha != 1.0 else mlayer.denoise(m)
    c = _c_stylize_repaired(m, alpha)
    H = body_height(m)
    assert np.max(np.abs(py.positions() - c.positions())) <= 1e-9 * H
    assert np.max(np.abs(py.trans - c.trans), initial=0.0) <= 1e-9 * H
