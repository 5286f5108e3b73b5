"""Motion layers through Python: the layer identity checked independently in numpy/scipy on
every real clip, synthesis, joint patterns, the base-layer floor, and bad input."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import scale_turn

import mlayer
from mlayer import quat
from mlayer.layers.layers import base_s_max, body_translation

CLIPS = ["cmu_01_01_playground_jumps", "cmu_131_01_mj_style_walk", "cmu_10_01_soccer_kick",
         "cmu_60_10_salsa_dance", "cmu_02_03_run_jog_25fps", "lafan1_clip_a",
         "bandai1_walk_happy_001", "ai4a_dog_D1_008_KAN01_002"]


def _scipy(q):
    """scalar-first (w, x, y, z) -> scipy Rotation (scalar-last)."""
    return Rotation.from_quat(np.asarray(q)[..., [1, 2, 3, 0]].reshape(-1, 4))


def _same_rotation_deg(a, b):
    """Largest angle in degrees between rotations given as scalar-first quaternions."""
    return np.degrees((_scipy(a).inv() * _scipy(b)).magnitude().max())


@pytest.fixture(scope="module")
def walk():
    return mlayer.data.load_sample()


@pytest.mark.parametrize("clip", CLIPS)
def test_layer_identity_checked_with_scipy(mocap, clip):
    m = mlayer.read_bvh(mocap / f"{clip}.bvh")
    L = mlayer.decompose(m)
    n, j = m.n_frames, m.n_joints
    assert L.control.shape == L.residual.shape == (n, 1 + j, 3)
    # (Mb (+) control) (+) residual, composed here with scipy rotations, is the input
    qb = _scipy(L.base.rot)
    qc = qb * Rotation.from_rotvec(L.control[:, 1:].reshape(-1, 3))
    q = qc * Rotation.from_rotvec(L.residual[:, 1:].reshape(-1, 3))
    err = (q.inv() * _scipy(m.rot)).magnitude().max()
    assert err < 1e-9, f"{clip}: rotations off by {err} rad"
    # the translation group is the body translation: the root's, or Bandai's Hips channels
    b = L.body_joint
    root = body_translation(L.base, b) + L.control[:, 0] + L.residual[:, 0]
    scale = np.ptp(m.positions().reshape(-1, 3), axis=0).max()
    assert np.abs(root - body_translation(m, b)).max() < 1e-9 * scale
    # and the library's own reconstruction agrees
    r = L.reconstruct()
    assert _same_rotation_deg(r.rot, m.rot) < 1e-7
    assert np.abs(r.root_pos - m.root_pos).max() < 1e-9 * scale
    assert np.abs(r.trans - m.trans).max() < 1e-9 * scale if m.trans.size else True
    # base quaternions are unit and the parameters are reported for every group
    assert np.allclose(np.linalg.norm(L.base.rot, axis=-1), 1.0, atol=1e-12)
    for name in ("lam", "sigma", "base_s", "lam_c", "sigma_c", "control_dof"):
        a = getattr(L, name)
        assert a.shape == (1 + j,) and np.all(np.isfinite(a)) and np.all(a > 0), name


def test_synthesis_alphas(walk):
    L = mlayer.decompose(walk)
    base = L.synthesize(0.0)
    assert np.allclose(base.root_pos, L.base.root_pos, atol=1e-12)
    assert _same_rotation_deg(base.rot, L.base.rot) < 1e-9
    # alpha = 1: the base plus the controllable layer, computed independently
    den = L.synthesize(1.0)
    ref = _scipy(L.base.rot) * Rotation.from_rotvec(L.control[:, 1:].reshape(-1, 3))
    assert _same_rotation_deg(den.rot, ref.as_quat()[:, [3, 0, 1, 2]]) < 1e-9
    assert np.allclose(den.root_pos, L.base.root_pos + L.control[:, 0], atol=1e-12)
    # alpha = 2 doubles the control rotation vector, its angle saturated below a half turn
    two = L.synthesize(2.0)
    v = (_scipy(L.base.rot).inv() * _scipy(two.rot)).as_rotvec().reshape(L.control[:, 1:].shape)
    assert np.allclose(v, scale_turn(L.control[:, 1:], 2.0), atol=1e-9)
    # denoise / stylize are the same computations
    assert np.array_equal(mlayer.denoise(walk, keep_contacts=False, floor=None).rot, den.rot)
    assert np.array_equal(mlayer.stylize(walk, 2.0, keep_contacts=False, limits=None,
                                         floor=None).rot, two.rot)
    # the skeleton and frame rate are kept
    assert two.skeleton == walk.skeleton and two.fps == walk.fps


def test_joint_patterns_scale_only_their_joints(walk):
    L = mlayer.decompose(walk)
    names = walk.joint_names
    w = L.alphas(1.0, {"Left*": 3.0, "LeftWrist": 0.5})
    for k, n in enumerate(names):
        expect = 0.5 if n == "LeftWrist" else 3.0 if n.startswith("Left") else 1.0
        assert w[1 + k] == expect, n
    assert w[0] == 1.0
    out = L.synthesize(1.0, {"Left*": 3.0})
    den = L.synthesize(1.0)
    changed = ~np.all(np.isclose(out.rot, den.rot, atol=1e-12), axis=(0, 2))
    assert [n for n, c in zip(names, changed) if c] == [n for n in names
                                                        if n.startswith("Left")
                                                        and np.abs(L.control[:, 1 + names.index(n)]
                                                                   ).max() > 0]
    assert np.array_equal(out.root_pos, den.root_pos)
    assert not np.array_equal(L.synthesize(1.0, root_alpha=2.0).root_pos, den.root_pos)


def test_base_floor_follows_the_frame_rate(walk):
    # the response of the LGS at the cutoff is 1/2 for the chosen s
    for fps, fc in ((120.0, 0.25), (30.0, 0.25), (24.0, 1.0)):
        s = base_s_max(fps, fc)
        assert math.isclose(1.0 / (1.0 + s * (2 * math.sin(math.pi * fc / fps)) ** 4), 0.5)
    L = mlayer.decompose(walk)
    assert L.base_s.max() <= base_s_max(walk.fps, 0.25) * (1 + 1e-12)
    free = mlayer.decompose(walk, base_cutoff=None)
    assert free.base_s.max() > 100 * L.base_s.max()
    # gamma bound: every joint's largest displacement stays within gamma
    assert np.all(L.base_max_angle[1:] <= math.pi / 2 + 1e-12)


def _decompose_old_formula(m, root_pos, extra=()):
    """The layers as Python made them before the floor moved into C: the upper end of the base
    search computed here (base_s_max at 0.25 Hz) and passed as MLR_LAYERS_OPT_BASE_S_MAX."""
    from mlayer._native import ffi, lib
    opts = [(lib.MLR_LAYERS_OPT_GAMMA, math.pi / 2),
            (lib.MLR_LAYERS_OPT_BASE_S_MAX, base_s_max(m.fps, 0.25)),
            (lib.MLR_LAYERS_OPT_ROBUST, 0.0)] + list(extra)
    copts = ffi.new("mlr_layers_option[]", len(opts))
    for k, (key, value) in enumerate(opts):
        copts[k].key, copts[k].value = key, value
    root = np.ascontiguousarray(root_pos, dtype=np.float64)
    rot = np.ascontiguousarray(m.rot, dtype=np.float64)
    out = ffi.new("mlr_layers **")
    n, j = m.n_frames, m.n_joints
    assert lib.mlr_layers_decompose(n, j, ffi.cast("const double *", ffi.from_buffer(root)),
                                    ffi.cast("const double *", ffi.from_buffer(rot)), copts,
                                    len(opts), ffi.NULL, out, ffi.NULL) == 0
    h = ffi.gc(out[0], lib.mlr_layers_destroy)
    got = {"base_pos": np.empty((n, 3)), "base_rot": np.empty((n, j, 4)),
           "control": np.empty((n, 1 + j, 3)), "residual": np.empty((n, 1 + j, 3)),
           "base_s": np.empty(1 + j)}
    buf = {k: ffi.cast("double *", ffi.from_buffer(v, require_writable=True))
           for k, v in got.items()}
    assert lib.mlr_layers_get_base(h, buf["base_pos"], 3 * n, buf["base_rot"], 4 * n * j) == 0
    assert lib.mlr_layers_get_control(h, buf["control"], 3 * n * (1 + j)) == 0
    assert lib.mlr_layers_get_residual(h, buf["residual"], 3 * n * (1 + j)) == 0
    assert lib.mlr_layers_get_param(h, lib.MLR_LAYERS_PARAM_BASE_S, buf["base_s"], 1 + j) == 0
    return got


@pytest.mark.parametrize("clip", CLIPS)
def test_floor_in_c_gives_the_layers_of_the_python_formula(mocap, clip):
    # decompose now passes the frame rate (MLR_LAYERS_OPT_FPS, default cutoff 0.25 Hz) and the
    # C core derives the floor: bit for bit what the Python formula gave
    m = mlayer.read_bvh(mocap / f"{clip}.bvh")
    L = mlayer.decompose(m, robust=False)   # the outlier search also takes the frame rate
    old = _decompose_old_formula(m, m.root_pos)
    np.testing.assert_array_equal(L.base.rot, old["base_rot"])
    np.testing.assert_array_equal(L.control[:, 1:], old["control"][:, 1:])
    np.testing.assert_array_equal(L.residual[:, 1:], old["residual"][:, 1:])
    np.testing.assert_array_equal(L.base_s[1:], old["base_s"][1:])
    if L.body_joint == 0:  # every clip but Bandai: everything as before
        np.testing.assert_array_equal(L.base.root_pos, old["base_pos"])
        np.testing.assert_array_equal(L.control, old["control"])
        np.testing.assert_array_equal(L.residual, old["residual"])
        np.testing.assert_array_equal(L.base_s, old["base_s"])
        np.testing.assert_array_equal(L.base.trans, m.trans)
    else:  # the translation group is the body joint's, smoothed with that joint's s
        from mlayer._native import lib
        assert clip.startswith("bandai") and m.joint_names[L.body_joint] == "Hips"
        body = _decompose_old_formula(m, body_translation(m, L.body_joint),
                                      [(lib.MLR_LAYERS_OPT_BODY_JOINT, L.body_joint)])
        np.testing.assert_array_equal(body_translation(L.base, L.body_joint), body["base_pos"])
        np.testing.assert_array_equal(L.control, body["control"])
        np.testing.assert_array_equal(L.residual, body["residual"])
        np.testing.assert_array_equal(L.base_s, body["base_s"])
        assert L.base_s[0] == L.base_s[1 + L.body_joint]
        np.testing.assert_array_equal(L.base.root_pos, m.root_pos)


def test_base_cutoff_reaches_c(walk):
    # another cutoff moves the C floor; lam_b / sigma_b still win over it
    L = mlayer.decompose(walk, base_cutoff=1.0)
    assert L.base_s.max() <= base_s_max(walk.fps, 1.0) * (1 + 1e-12)
    assert L.base_s.max() < mlayer.decompose(walk).base_s.max()
    fixed = mlayer.decompose(walk, lam_b=2.0, base_cutoff=1.0)
    np.testing.assert_allclose(fixed.base_s, (2.0 * 0.1) ** 2)


def test_explicit_control_parameters(walk):
    L = mlayer.decompose(walk, lam_c=1.0, sigma_c=1.0)
    assert np.allclose(L.lam_c, 1.0) and np.allclose(L.sigma_c, 1.0)
    assert np.all(np.isnan(L.control_gcv))
    # the controllable layer of the root is then exactly mlayer.lgs of its displacement
    disp = walk.root_pos - L.base.root_pos
    assert np.allclose(L.control[:, 0], mlayer.lgs(disp, 1.0, 1.0), atol=1e-9)


def test_denoising_reduces_added_noise(walk):
    rng = np.random.default_rng(7)
    noisy = walk.with_frames(rot=quat.mul(walk.rot, quat.exp(
        rng.normal(scale=math.radians(1.5), size=walk.rot.shape[:-1] + (3,)))))
    den = mlayer.denoise(noisy)
    e_noisy = mlayer.metrics.mpjpe(noisy, walk)
    e_den = mlayer.metrics.mpjpe(den, walk)
    assert e_den < 0.5 * e_noisy
    assert mlayer.metrics.jitter(den) < 0.1 * mlayer.metrics.jitter(noisy)


@pytest.mark.parametrize("kw,msg", [
    ({"gamma": 1.0}, "gamma"), ({"gamma": math.pi}, "gamma"), ({"lam_c": float("nan")}, "lam_c"),
    ({"sigma_c": -1.0}, "sigma"), ({"base_cutoff": 0.0}, "base_cutoff"),
    ({"base_cutoff": 1000.0}, "base_cutoff")])
def test_bad_parameters(walk, kw, msg):
    with pytest.raises(mlayer.InvalidArgumentError, match=msg):
        mlayer.decompose(walk[:50], **kw)


def test_bad_alphas_and_patterns(walk):
    L = mlayer.decompose(walk[:60])
    for bad in (float("nan"), float("inf"), "x"):
        with pytest.raises(mlayer.InvalidArgumentError, match="alpha"):
            L.synthesize(bad)
    with pytest.raises(mlayer.InvalidArgumentError, match="matches no joint.*LeftHip"):
        L.synthesize(1.0, {"Nope*": 2.0})
    with pytest.raises(mlayer.InvalidArgumentError, match="alpha of 'Left\\*'"):
        L.synthesize(1.0, {"Left*": float("nan")})


def test_too_short_clip(walk):
    with pytest.raises(mlayer.InvalidArgumentError, match="at least 3 frames"):
        mlayer.decompose(walk[:2])
    L = mlayer.decompose(walk[:3])
    assert L.synthesize(1.0).n_frames == 3


def test_save_npz(tmp_path, walk):
    L = mlayer.decompose(walk[:100])
    L.save_npz(tmp_path / "l.npz")
    z = np.load(tmp_path / "l.npz")
    assert np.array_equal(z["control"], L.control) and np.array_equal(z["lam_c"], L.lam_c)
    assert list(z["joint_names"]) == walk.joint_names
    assert sorted(p.name for p in tmp_path.iterdir()) == ["l.npz"]


# ---- the body translation where it lives (Bandai: a static joint_Root, the walk in Hips) -----

def _jitter(m, j):
    """Mean magnitude of the third difference of joint j's world position."""
    return np.linalg.norm(np.diff(m.positions()[:, j], 3, axis=0), axis=-1).mean()


@pytest.fixture(scope="module")
def bandai(mocap):
    return mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")


def test_body_translation_joint_on_the_clips(mocap, bandai):
    from mlayer.layers.layers import body_translation_joint
    hips = bandai.joint_names.index("Hips")
    assert hips != 0 and body_translation_joint(bandai) == hips
    assert mlayer.decompose(bandai).body_joint == hips
    assert "Hips" in repr(mlayer.decompose(bandai))
    for clip in CLIPS:
        if not clip.startswith("bandai"):
            m = mlayer.read_bvh(mocap / f"{clip}.bvh")
            assert body_translation_joint(m) == 0, clip
    # a list of clips: the first non-root answer
    cmu = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    assert body_translation_joint([cmu, cmu]) == 0
    assert body_translation_joint([bandai[:50], bandai]) == hips
    # Bandai without its walk (Hips channels frozen at frame 0): the root again
    frozen = bandai.trans.copy()
    col = list(bandai.trans_joints).index(hips)
    frozen[:, col] = frozen[0, col]
    assert body_translation_joint(bandai.with_frames(trans=frozen)) == 0
    with pytest.raises(mlayer.InvalidArgumentError, match="Motion"):
        body_translation_joint([cmu, "x"])


def test_denoise_smooths_the_body_translation_where_it_lives(mocap, bandai):
    # 1 cm of noise (0.6% of the body height) on the Hips channels; on a clip whose root
    # carries the translation (CMU, every 4th frame: 30 fps), the same relative noise on the root
    rng = np.random.default_rng(3)
    hips = bandai.joint_names.index("Hips")
    p = list(bandai.trans_joints).index(hips)
    trans = bandai.trans.copy()
    trans[:, p] += rng.normal(scale=1.0, size=trans[:, p].shape)
    noisy = bandai.with_frames(trans=trans)
    den = mlayer.denoise(noisy, keep_contacts=False, floor=None)
    drop = _jitter(noisy, hips) / _jitter(den, hips)
    assert drop > 8.0, drop  # measured 14.6; the layers left these channels alone before (1.0)
    # the static root and the other position channels keep their values
    np.testing.assert_array_equal(den.root_pos, bandai.root_pos)
    others = np.arange(trans.shape[1]) != p
    np.testing.assert_array_equal(den.trans[:, others], noisy.trans[:, others])
    cmu = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[::4]
    scale = 1.0 * 24.0 / 170.0
    ncmu = cmu.with_frames(root_pos=cmu.root_pos + rng.normal(scale=scale,
                                                              size=cmu.root_pos.shape))
    dcmu = mlayer.denoise(ncmu, keep_contacts=False, floor=None)
    assert _jitter(ncmu, 0) / _jitter(dcmu, 0) > 8.0
    np.testing.assert_array_equal(dcmu.trans, ncmu.trans)


def test_stylize_scales_the_body_translation(bandai):
    hips = bandai.joint_names.index("Hips")
    L = mlayer.decompose(bandai)
    base = body_translation(L.base, hips)
    den = body_translation(mlayer.stylize(bandai, 1.0, keep_contacts=False, floor=None), hips)
    two = mlayer.stylize(bandai, 2.0, keep_contacts=False, floor=None,
                         limits=None)
    d1, d2 = den - base, body_translation(two, hips) - base
    assert np.abs(d1).max() > 1.0  # cm: there is style in the Hips translation to scale
    np.testing.assert_allclose(d2, 2.0 * d1, rtol=0, atol=1e-9 * np.abs(base).max())
    np.testing.assert_allclose(d1, L.control[:, 0], rtol=0, atol=1e-9 * np.abs(base).max())
    # root_alpha scales it alone; the static root stays put
    only = L.synthesize(1.0, root_alpha=3.0)
    np.testing.assert_allclose(body_translation(only, hips) - base, 3.0 * d1, rtol=0,
                               atol=1e-9 * np.abs(base).max())
    np.testing.assert_array_equal(only.rot, L.synthesize(1.0).rot)
    np.testing.assert_array_equal(two.root_pos, bandai.root_pos)


def test_save_npz_has_the_body_translation(tmp_path, bandai):
    L = mlayer.decompose(bandai[:60])
    L.save_npz(tmp_path / "b.npz")
    z = np.load(tmp_path / "b.npz")
    assert int(z["body_joint"]) == L.body_joint == 1
    np.testing.assert_array_equal(z["base_trans"], L.base.trans)
