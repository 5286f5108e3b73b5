"""mlayer.guards.cleanup (mlr_cleanup.h): the wrapper against a direct cffi call on a real clip,
the floor height against numpy's quantile, argument errors, and denoise on the shared clips: the
cleanup and the floor move joints by at most 0.5% of body height."""
import numpy as np
import pytest

import mlayer
from conftest import SHARED_CLIPS
from mlayer.guards import cleanup
from mlayer._native import ffi, lib
from mlayer.model._rig import c_rig
from mlayer.guards.contacts import _point, detect_contacts
from mlayer.errors import InvalidArgumentError
from mlayer.guards.metrics import body_height

CLIPS = SHARED_CLIPS


@pytest.fixture(scope="module")
def walk(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[:600]
    synth = mlayer.decompose(m).synthesize(2.0)
    names, c = detect_contacts(m)
    return m, synth, names, c


def _ptr(a):
    return ffi.cast("double *", ffi.from_buffer(a)) if a.size else ffi.NULL


def test_fix_contacts_equals_a_direct_c_call(walk):
    m, synth, names, c = walk
    opts = {"blend": 0.3, "max_fold": 2.5}
    out, rep = cleanup.fix_contacts(synth, c, names, reference=m, return_report=True, **opts)
    pts = [_point(m.skeleton, n) for n in names]
    j = np.array([p[0] for p in pts], dtype=np.int32)
    e = np.array([p[1] for p in pts], dtype=np.int32)
    cu = np.ascontiguousarray(c, dtype=np.uint8)
    copts = ffi.new("mlr_cleanup_option[]", 2)
    copts[0].key, copts[0].value = lib.MLR_CLEANUP_OPT_BLEND, 0.3
    copts[1].key, copts[1].value = lib.MLR_CLEANUP_OPT_MAX_FOLD, 2.5
    root, rot = (np.ascontiguousarray(x, dtype=np.float64) for x in (synth.root_pos, synth.rot))
    rr, rq = (np.ascontiguousarray(x, dtype=np.float64) for x in (m.root_pos, m.rot))
    assert m.trans.shape[1] == 0
    o_root, o_rot = np.empty_like(root), np.empty_like(rot)
    crep = ffi.new("mlr_cleanup_report *")
    diag = ffi.new("mlr_diag *")
    rig, keep = c_rig(m.skeleton)
    st = lib.mlr_cleanup_contacts(
        rig, m.n_frames, float(m.fps), 1, _ptr(root), _ptr(rot), ffi.NULL, _ptr(rr), _ptr(rq),
        ffi.NULL, len(names), ffi.cast("const int32_t *", ffi.from_buffer(j)),
        ffi.cast("const int32_t *", ffi.from_buffer(e)),
        ffi.cast("const uint8_t *", ffi.from_buffer(cu)), copts, 2, _ptr(o_root), _ptr(o_rot),
        crep, ffi.NULL, diag)
    del keep
    assert st == lib.MLR_OK, ffi.string(diag.message).decode()
    np.testing.assert_array_equal(out.root_pos, o_root)
    np.testing.assert_array_equal(out.rot, o_rot)
    assert rep["floor_height"] == crep.floor_height
    assert rep["contact_frames"] == crep.contact_frames > 0
    assert rep["root_shift_max"] == crep.root_shift_max
    # the cleanup did something: the output differs from the synthesized motion
    assert np.abs(out.rot - synth.rot).max() > 1e-3


def test_floor_height_is_numpys_quantile(walk):
    m, _, names, c = walk
    p = m.positions()
    e = m.end_site_positions()
    heights = []
    for k, n in enumerate(names):
        j, es = _point(m.skeleton, n)
        y = (e[:, es, 1] if es >= 0 else p[:, j, 1])
        heights.append(y[c[:, k]])
    h = np.concatenate(heights)
    assert h.size > 100
    for q in (0.0, 0.05, 0.5, 0.93, 1.0):
        assert cleanup.floor_height(m, c, names, quantile=q) == pytest.approx(
            np.quantile(h, q), abs=1e-12 * body_height(m))
    # detected here when not given
    assert cleanup.floor_height(m) == pytest.approx(np.quantile(h, 0.05), abs=1e-12)


def test_argument_errors_name_the_argument(walk):
    m, synth, names, c = walk
    with pytest.raises(InvalidArgumentError, match="fix_contacts: motion"):
        cleanup.fix_contacts(np.zeros(3), c, names)
    with pytest.raises(InvalidArgumentError, match="contacts must be a bool array"):
        cleanup.fix_contacts(synth, c.astype(np.uint8), names)
    with pytest.raises(InvalidArgumentError, match="contacts must be a bool array"):
        cleanup.fix_contacts(synth, c[:, :1], names)
    with pytest.raises(InvalidArgumentError, match="reference has 10 frames"):
        cleanup.fix_contacts(synth, c, names, reference=m[:10])
    with pytest.raises(InvalidArgumentError, match="reference must be a mlayer.Motion"):
        cleanup.fix_contacts(synth, c, names, reference="m")
    with pytest.raises(InvalidArgumentError, match="unknown option 'blnd'"):
        cleanup.fix_contacts(synth, c, names, blnd=0.1)
    with pytest.raises(InvalidArgumentError, match="option blend = nan is not finite"):
        cleanup.fix_contacts(synth, c, names, blend=float("nan"))
    with pytest.raises(InvalidArgumentError, match=r"option blend = -0.1 is not > 0"):
        cleanup.fix_contacts(synth, c, names, blend=-0.1)
    with pytest.raises(InvalidArgumentError, match="floor: expected 'auto', None or a height"):
        cleanup.fix_contacts(synth, c, names, floor="low")
    with pytest.raises(InvalidArgumentError, match="floor: the height must be finite"):
        cleanup.fix_contacts(synth, c, names, floor=float("inf"))
    with pytest.raises(InvalidArgumentError, match="fix_contacts: up must be"):
        cleanup.fix_contacts(synth, c, names, up="w")
    with pytest.raises(InvalidArgumentError, match="Nowhere"):
        cleanup.fix_contacts(synth, c, ["Nowhere"] + list(names[1:]))
    with pytest.raises(InvalidArgumentError, match="floor_height: quantile"):
        cleanup.floor_height(m, c, names, quantile=1.5)
    with pytest.raises(InvalidArgumentError, match="floor_height: motion"):
        cleanup.floor_height(None)


@pytest.mark.parametrize("name", CLIPS)
def test_denoise_changes_only_what_slides(mocap, name):
    """Issue 38, item 3 (after items 4 and 7 of issue 18): the cleanup in denoise changes the
    motion (by more than 0.5% of body height) only where the denoised feet slide more than the
    input's, the feet then slide less than denoised. A contact whose denoised foot follows the
    input's path within 2% of the leg's length (its mean offset taken out), or slides at most
    1.25x the input's, is kept as it is, so a clean capture comes out as it went in: the shared
    captures were moved by 1.4-4.8% of body height when the kept contacts had to slide no more
    in all than the input's (path lengths, which at 120 fps are mostly capture noise); now by
    at most 0.73%, and the denoised feet's path is at most 1.08x the input's (CMU 01_01: 1.074x,
    the dog 1.024x, CMU 131_01 1.010x; 0.998-1.0x before)."""
    from mlayer.guards.metrics import foot_sliding
    path = mocap / name
    if not path.exists():
        pytest.skip(f"{name} absent")
    m = mlayer.read_bvh(path)
    a, rep = mlayer.denoise(m, return_report=True)
    b = mlayer.denoise(m, keep_contacts=False, floor=None)
    assert rep.contact_frames > 0 and np.isfinite(rep.floor_height)  # the cleanup did run
    d = np.linalg.norm(a.positions() - b.positions(), axis=-1).max() / body_height(m)
    names, c = detect_contacts(m)
    s_in, s_a, s_b = (foot_sliding(x, c, names) for x in (m, a, b))
    assert s_a <= 1.08 * s_in, (name, s_in, s_a, s_b)
    assert d <= 0.0075, (name, d)
    if d > 0.005:  # changed: the denoised feet slid, and slide less now
        assert s_a < s_b, (name, d, s_in, s_a, s_b)


@pytest.mark.parametrize("alpha", [0.5, 2.0, 3.0])
def test_ramp_track_is_an_option_of_the_cleanup(mocap, alpha):
    # the frames around a contact cross-fade from the reference's motion to the synthesis's
    # (ramp_track, the default) or carry the contact's offset at its edge alone (False, what
    # denoise and retiming use); either keeps the feet's largest acceleration within 1.5x the
    # larger of the input's and the synthesis's on the bundled walk (the judge's pop ratio;
    # where tracking matters, Xia's walks, the clips may not be redistributed: the FAIR jump
    # of test_guards_pops.py is the test that fails without it)
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[:600]
    synth = mlayer.decompose(m).synthesize(alpha)
    names, c = detect_contacts(m)
    feet = [m.joint_names.index(n) for n in names if n in m.joint_names]

    def accel(x):
        p = np.asarray(x.positions())[:, feet]
        return float(np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=-1).max())

    tracked = cleanup.fix_contacts(synth, c, names, reference=m)
    offset = cleanup.fix_contacts(synth, c, names, reference=m, ramp_track=False)
    assert np.abs(tracked.rot - offset.rot).max() > 1e-6  # the option is passed on
    base = max(accel(m), accel(synth))
    assert accel(tracked) <= 1.5 * base and accel(offset) <= 1.5 * base
    with pytest.raises(InvalidArgumentError, match="ramp_track = 0.5 is not 0 or 1"):
        cleanup.fix_contacts(synth, c, names, reference=m, ramp_track=0.5)
