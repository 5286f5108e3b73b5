"""Generation at run time (mlr_generate.h): a model written by PrimitiveModel.runtime_bytes,
loaded by the C core, generates the frames PrimitiveModel.generate(guards=False) returns for
the same seed and options; bad model files and options are refused with a diag naming them."""
from __future__ import annotations

import math
import struct
import zlib

import numpy as np
import pytest

import mlayer
from mlayer._native import ffi, lib
from mlayer.manifold.primitives import PrimitiveModel


def _load(data: bytes, skeleton=ffi.NULL):
    out = ffi.new("mlr_gen_model **")
    diag = ffi.new("mlr_diag *")
    buf = ffi.from_buffer(data)
    st = lib.mlr_gen_model_load(ffi.NULL, buf, len(data), skeleton, out, diag)
    msg = ffi.string(diag.message).decode()
    if st != 0:
        assert out[0] == ffi.NULL
        return st, msg
    return st, ffi.gc(out[0], lib.mlr_gen_model_destroy)


_KEYS = {"frames": "MLR_GEN_OPT_FRAMES", "start_frame": "MLR_GEN_OPT_START_FRAME",
         "start": "MLR_GEN_OPT_START", "rank": "MLR_GEN_OPT_RANK", "smooth": "MLR_GEN_OPT_SMOOTH",
         "noise": "MLR_GEN_OPT_NOISE", "allow_unseen": "MLR_GEN_OPT_ALLOW_UNSEEN",
         "pin_feet": "MLR_GEN_OPT_PIN_FEET"}


def _generator(model_h, seed: int, opts: list[tuple[int, float]]):
    """(status, the generator or the diag's message)."""
    gen = ffi.new("mlr_generator **")
    diag = ffi.new("mlr_diag *")
    arr = ffi.new("mlr_generate_option[]", max(len(opts), 1))
    for i, (k, v) in enumerate(opts):
        arr[i].key, arr[i].value = k, v
    st = lib.mlr_generator_create(ffi.NULL, model_h, seed, arr if opts else ffi.NULL, len(opts),
                                  gen, diag)
    if st != 0:
        assert gen[0] == ffi.NULL
        return st, ffi.string(diag.message).decode()
    return st, ffi.gc(gen[0], lib.mlr_generator_destroy)


def _frames(model_h, n: int, seed: int, **opts: float) -> tuple[np.ndarray, int]:
    st, g = _generator(model_h, seed, [(getattr(lib, _KEYS[k]), float(v))
                                       for k, v in opts.items()])
    assert st == 0, g
    diag = ffi.new("mlr_diag *")
    size = lib.mlr_gen_model_frame_size(model_h)
    out = np.empty((n, size))
    for f in range(n):
        st = lib.mlr_generator_next(g, ffi.cast("double *", ffi.from_buffer(out[f])), diag)
        assert st == 0, ffi.string(diag.message)
    return out, int(lib.mlr_generator_start_frame(g))


@pytest.fixture(scope="module")
def walk(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    model = PrimitiveModel.fit([m], epochs=4, k=6, som=(10, 10), lattice=(6, 6), order=2)
    return m, model


def _python(model: PrimitiveModel, n: int, seed: int, **kw) -> np.ndarray:
    g = model.generate(n, seed=seed, guards=False, **kw)
    b = model.body_joint
    pos = g.root_pos if b == 0 else g.trans[:, model._body_slot()]
    return np.hstack([pos, g.rot.reshape(n, -1)])


@pytest.mark.parametrize("seed,kw", [(0, {}), (7, {"start_frame": 40}),
                                     (3, {"most_likely": True}),
                                     (11, {"second_likely": True, "smooth": 0.5}),
                                     (5, {"smooth": 0.0}),
                                     (9, {"start_frame": 10, "start": 2}),
                                     (13, {"noise": 0.4}),
                                     (2, {"noise": 1.0, "allow_unseen": True}),
                                     (2**64 - 1, {"noise": 0.1, "most_likely": True})])
def test_c_frames_equal_python_generate(walk, seed, kw):
    _, model = walk
    st, h = _load(model.runtime_bytes())
    assert st == 0, h
    n = 150
    want = _python(model, n, seed, **kw)
    opts: dict[str, float] = {"frames": n}
    if "start_frame" in kw:
        opts["start_frame"] = kw["start_frame"]
    if kw.get("most_likely"):
        opts["rank"] = 1
    if kw.get("second_likely"):
        opts["rank"] = 2
    for k in ("smooth", "start", "noise", "allow_unseen"):
        if k in kw:
            opts[k] = float(kw[k])
    got, start = _frames(h, n, seed, **opts)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # the unseeded start frame is the generator's first draw, in Python as in C
    if "start_frame" not in kw:
        assert start == mlayer.manifold.markov.Rng(seed).below(model.points.shape[0])


def test_endless_frames_continue(walk):
    _, model = walk
    st, h = _load(model.runtime_bytes())
    got, _ = _frames(h, 400, 2, frames=100)
    np.testing.assert_allclose(got[:100], _python(model, 100, 2), rtol=0, atol=1e-12)
    assert np.isfinite(got).all()
    q = got[:, 3:].reshape(400, -1, 4)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)
    # no jump at the segment joins larger than the largest step within the segments
    step = np.abs(np.diff(got[:, :3], axis=0)).max(axis=1)
    inside = np.delete(step, [99, 199, 299])
    assert step[[99, 199, 299]].max() <= 2.0 * inside.max()


def test_skeleton_check(walk):
    from mlayer.model.motion import _create_handle
    m, model = walk
    data = model.runtime_bytes()
    sk = m.skeleton

    def handle(names):
        return _create_handle(list(names), np.ascontiguousarray(sk.parents, np.int32),
                              np.ascontiguousarray(sk.offsets), list(sk.channels),
                              np.ascontiguousarray(sk.end_site_parents, np.int32),
                              np.ascontiguousarray(sk.end_site_offsets), 0, 1.0)
    with handle(sk.joint_names) as hs:
        st, h = _load(data, hs)
        assert st == 0, h
    assert lib.mlr_gen_model_n_joints(h) == sk.n_joints
    assert ffi.string(lib.mlr_gen_model_joint_name(h, 1)).decode() == sk.joint_names[1]
    other = list(sk.joint_names)
    other[2] = "Elsewhere"
    with handle(other) as hs:
        st, msg = _load(data, hs)
    assert st == lib.MLR_E_INVALID_ARG
    assert f"joint 2 is '{sk.joint_names[2]}' in the model, 'Elsewhere' in the skeleton" in msg


def _rebuild(body: bytes, version: int = 1, mark: int = 0x01020304, n_fields: int | None = None,
             head: bytes | None = None) -> bytes:
    """A file from its original header fields with a replaced payload, size and CRC fixed."""
    nf = struct.unpack_from("<I", head, 20)[0] if n_fields is None else n_fields
    lib_v, skel = struct.unpack_from("<I", head, 16)[0], struct.unpack_from("<Q", head, 32)[0]
    h = b"MLRGEN\0\0" + struct.pack("<IIIIQQQ", version, mark, lib_v, nf, 64 + len(body), skel,
                                    zlib.crc32(body))
    return h.ljust(64, b"\0") + body


def test_bad_files_are_refused(walk):
    _, model = walk
    data = model.runtime_bytes()
    head, body = data[:64], data[64:]
    cases = {
        "truncated": (data[:-8], "the header gives"),
        "short": (data[:40], "no MLRGEN magic"),
        "magic": (b"MLRGEX\0\0" + data[8:], "no MLRGEN magic"),
        "version": (_rebuild(body, version=2, head=head), "model format version 2"),
        "byte order": (_rebuild(body, mark=0x04030201, head=head), "byte-order mark"),
        "damaged": (data[:-1] + bytes([data[-1] ^ 1]), "CRC-32"),
        "fields": (_rebuild(body, n_fields=99, head=head), "99 fields"),
    }
    # a count too large: the first field's first dimension
    big = bytearray(body)
    struct.pack_into("<Q", big, 32, 1 << 40)
    cases["count"] = (_rebuild(bytes(big), head=head), "run past the end of the file")
    # an unknown field name
    unk = bytearray(body)
    unk[0:24] = b"frame_tyme".ljust(24, b"\0")
    cases["unknown"] = (_rebuild(bytes(unk), head=head), "unknown field 'frame_tyme'")
    # the contact names and the floor the runtime guards read
    names_at, floor_at = _field_data(body, "contact_names"), _field_data(body, "floor_height")
    merged = bytearray(body)
    merged[body.index(b"\0", names_at)] = ord("x")  # two names become one
    cases["contact names"] = (_rebuild(bytes(merged), head=head),
                              "field 'contact_names' holds 3 names for 4 contact columns")
    inf_floor = bytearray(body)
    struct.pack_into("<d", inf_floor, floor_at, float("inf"))
    cases["floor"] = (_rebuild(bytes(inf_floor), head=head), "field 'floor_height' is infinite")
    for what, (bad, msg) in cases.items():
        st, text = _load(bad)
        assert st == lib.MLR_E_PARSE, (what, st, text)
        assert msg in text, (what, text)


def _field_data(body: bytes, name: str) -> int:
    """Offset in body of the data of the named field (docs/model-format.md)."""
    at = 0
    while at < len(body):
        field = body[at:at + 24].rstrip(b"\0").decode()
        typ, _, d0, d1 = struct.unpack_from("<IIQQ", body, at + 24)
        if field == name:
            return at + 48
        at += 48 + (d0 * d1 * (1 if typ == 3 else 8) + 7) // 8 * 8
    raise KeyError(name)


def test_every_truncation_is_refused(walk):
    _, model = walk
    data = model.runtime_bytes()
    for cut in list(range(0, 200, 7)) + list(range(len(data) - 100, len(data), 3)):
        st, _ = _load(data[:cut])
        assert st == lib.MLR_E_PARSE, cut


def test_bad_options_are_refused(walk):
    _, model = walk
    st, h = _load(model.runtime_bytes())
    n, k = model.points.shape[0], model.centers.shape[0]
    key = {name: getattr(lib, c) for name, c in _KEYS.items()}
    for opts, msg in [([(99, 1.0)], "generate: unknown option key 99"),
                      ([(key["frames"], 1)],
                       "option frames = 1 is not an integer in 2 .. 10000000"),
                      ([(key["frames"], 2.5)], "option frames = 2.5 is not"),
                      ([(key["start_frame"], n)],
                       f"option start_frame = {n} is not in -1 .. {n - 1}"),
                      ([(key["start"], k)], f"option start = {k} is not in -1 .. {k - 1}"),
                      ([(key["rank"], 3)], "option rank = 3 is not 0 (sampled), 1"),
                      ([(key["noise"], -0.5)], "option noise = -0.5 is not"),
                      ([(key["allow_unseen"], 2)], "option allow_unseen = 2 is not"),
                      ([(key["smooth"], float("nan"))], "option smooth = nan is not finite"),
                      ([(key["rank"], 1), (key["rank"], 1)], "option rank given twice")]:
        st, text = _generator(h, 0, opts)
        assert st == lib.MLR_E_INVALID_ARG, (opts, text)
        assert msg in text, (opts, text)


def test_save_runtime_loads_from_the_file(walk, tmp_path):
    _, model = walk
    path = tmp_path / "walk.mlrgen"
    model.save_runtime(path)
    assert path.read_bytes() == model.runtime_bytes()
    out = ffi.new("mlr_gen_model **")
    diag = ffi.new("mlr_diag *")
    st = lib.mlr_gen_model_load_file(ffi.NULL, str(path).encode(), ffi.NULL, out, diag)
    assert st == 0, ffi.string(diag.message)
    h = ffi.gc(out[0], lib.mlr_gen_model_destroy)
    assert lib.mlr_gen_model_n_points(h) == model.points.shape[0]
    assert lib.mlr_gen_model_n_primitives(h) == model.centers.shape[0]


def test_c_example_writes_the_bvh_python_writes(walk, mocap, tmp_path):
    """examples/c/generate.c, from a meson build named by MLR_BUILD_DIR: its BVH file of the
    first segment is byte for byte the one of generate(guards=False) written by Python."""
    import os
    import subprocess
    build = os.environ.get("MLR_BUILD_DIR")
    exe = os.path.join(build, "examples", "c", "example_generate") if build else ""
    if not (exe and os.path.exists(exe)):
        pytest.skip("set MLR_BUILD_DIR to a meson build of the C examples")
    _, model = walk
    model.save_runtime(tmp_path / "walk.mlrgen")
    mlayer.write_bvh(model.generate(120, seed=3, guards=False), tmp_path / "py.bvh")
    rig = str(mocap / "cmu_131_01_mj_style_walk.bvh")
    subprocess.run([exe, rig, str(tmp_path / "walk.mlrgen"), str(tmp_path / "c.bvh"), "120", "3",
                    "120"], check=True, capture_output=True)
    assert (tmp_path / "c.bvh").read_bytes() == (tmp_path / "py.bvh").read_bytes()
    # GUARDS 1: the limits learned from the rig's frames and the model's floor; the contact
    # points of the written file stay above the floor but for the file's six decimals
    for guards, out in (("0", "c0.bvh"), ("1", "c1.bvh")):
        subprocess.run([exe, rig, str(tmp_path / "walk.mlrgen"), str(tmp_path / out), "400",
                        "3", "120", guards], check=True, capture_output=True)
    from mlayer.guards.contacts import contact_positions
    low = [contact_positions(mlayer.read_bvh(tmp_path / f), model.contact_names)[..., 1].min()
           for f in ("c0.bvh", "c1.bvh")]
    assert low[0] < model.floor_height - 0.5
    assert low[1] >= model.floor_height - 1e-5


def test_cli_runtime_model_under_a_static_root(mocap, tmp_path):
    """`mlayer primitives --runtime` on a rig whose body joint (Hips) is below a static root
    (Bandai's joint_Root): the C frames drive the body joint's position channels as Python's
    generate does."""
    from mlayer.cli import main
    clip = mocap / "bandai1_walk_happy_001.bvh"
    if not clip.exists():
        pytest.skip("bandai1_walk_happy_001.bvh not found")
    npz, rt = tmp_path / "m.npz", tmp_path / "m.mlrgen"
    assert main(["primitives", str(clip), "-o", str(npz), "--som", "8x8", "--lattice", "6x6",
                 "--epochs", "4", "--k", "5", "--plots", "", "--runtime", str(rt)]) == 0
    model = PrimitiveModel.load(npz)
    assert model.body_joint != 0
    st, h = _load(rt.read_bytes())
    assert st == 0, h
    assert lib.mlr_gen_model_body_joint(h) == model.body_joint
    got, _ = _frames(h, 120, 4, frames=120)
    np.testing.assert_allclose(got, _python(model, 120, 4), rtol=0, atol=1e-12)
    # a wrong extension is refused before any work
    assert main(["primitives", str(clip), "-o", str(npz), "--runtime",
                 str(tmp_path / "m.bin")]) == 1


def _fk_points(skeleton, frames: np.ndarray, joints: list[int], body_joint: int = 0,
               rest_root=None, rest_trans=None) -> np.ndarray:
    """World positions of joints of generated frames, by numpy (not the C core)."""
    n, J = frames.shape[0], skeleton.n_joints
    rot = frames[:, 3:].reshape(n, J, 4)
    local = np.repeat(np.asarray(skeleton.offsets, float)[None], n, axis=0)
    root = np.repeat(np.zeros(3)[None] if rest_root is None else np.asarray(rest_root)[None], n, 0)
    tj = list(skeleton.trans_joints)
    for i, j in enumerate(tj):
        local[:, j] = skeleton.offsets[j] if rest_trans is None else rest_trans[i]
    if body_joint == 0:
        root = frames[:, :3]
    else:
        local[:, body_joint] = frames[:, :3]

    def rotate(q, v):
        w, u = q[:, :1], q[:, 1:]
        t = 2.0 * np.cross(u, v)
        return v + w * t + np.cross(u, t)

    def mul(a, b):
        w1, v1, w2, v2 = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
        return np.hstack([w1 * w2 - np.sum(v1 * v2, axis=1, keepdims=True),
                          w1 * v2 + w2 * v1 + np.cross(v1, v2)])
    wpos, wrot = np.empty((n, J, 3)), np.empty((n, J, 4))
    for j in range(J):
        p = skeleton.parents[j]
        if p < 0:
            wpos[:, j], wrot[:, j] = root, rot[:, j]
        else:
            wpos[:, j] = wpos[:, p] + rotate(wrot[:, p], local[:, j])
            wrot[:, j] = mul(wrot[:, p], rot[:, j])
    return wpos[:, joints]


def _guarded(model_h, rig, limits_h, n: int, seed: int, frames: int, rest=ffi.NULL,
             pin_feet: bool = True):
    st, g = _generator(model_h, seed, [(lib.MLR_GEN_OPT_FRAMES, float(frames)),
                                       (lib.MLR_GEN_OPT_PIN_FEET, float(pin_feet))])
    assert st == 0, g
    diag = ffi.new("mlr_diag *")
    st = lib.mlr_generator_set_guards(g, rig, rest, limits_h, diag)
    assert st == 0, ffi.string(diag.message)
    out = np.empty((n, lib.mlr_gen_model_frame_size(model_h)))
    for f in range(n):
        st = lib.mlr_generator_next(g, ffi.cast("double *", ffi.from_buffer(out[f])), diag)
        assert st == 0, ffi.string(diag.message)
    return out


def test_guards_keep_generated_frames_in_their_limits_and_above_the_floor(walk, mocap):
    """mlr_generator_set_guards: with the guards on, every generated frame (over several
    segments) has its contact points on or above the model's floor and its joints within the
    limits, measured by numpy forward kinematics and swing-twist angles; the unguarded frames
    of the same seed break both. The guards leave the walk, the heading and the ground track
    alone: guards-off frames are those of the generator without the call, bit for bit."""
    import sys
    from conftest import REPO
    from mlayer.model._rig import c_rig
    sys.path.insert(0, str(REPO / "bench" / "python"))
    import plausibility as bench_pl
    m, model = walk
    st, h = _load(model.runtime_bytes())
    assert st == 0, h
    lim = mlayer.joint_limits(m)
    n, seg, seed = 500, 150, 3
    plain, _ = _frames(h, n, seed, frames=seg)
    J = m.n_joints
    # tighter ranges than the generated frames reach, on four swing-twist joints: half the
    # largest swing of the unguarded frames (measured with a range of 0.001 radians)
    swing = {}
    for name in ("LeftHip", "RightHip", "LeftShoulder", "RightShoulder"):
        r = lim.range(name)
        assert r["kind"] == "swing-twist"
        lim.set_range(name, kind="swing-twist", swing=1e-3, twist=math.pi)
        reach = bench_pl.swing_twist_excess(lim, plain[:, 3:].reshape(n, J, 4))[name]
        swing[name] = 0.5 * (math.radians(reach) + 1e-3)
        lim.set_range(name, kind="swing-twist", swing=swing[name], twist=r["twist"])
    before = bench_pl.swing_twist_excess(lim, plain[:, 3:].reshape(n, J, 4))
    assert min(before[k] for k in swing) > 1.0, before  # degrees past the tight ranges
    rig, keep = c_rig(m.skeleton)
    got = _guarded(h, rig, lim._h, n, seed, seg)
    after = bench_pl.swing_twist_excess(lim, got[:, 3:].reshape(n, J, 4))
    assert max(after.values()) == 0.0, after
    # the floor: the model's contact points (joints here), by numpy forward kinematics
    names = list(model.contact_names)
    joints = [m.joint_names.index(c) for c in names]
    floor = model.floor_height
    low_plain = _fk_points(m.skeleton, plain, joints)[..., 1].min()
    low = _fk_points(m.skeleton, got, joints)[..., 1].min(axis=1)
    size = float(np.ptp(m.root_pos[:, 1]) + 1.0)
    assert floor - low_plain > 0.5  # the unguarded feet go that far below the floor
    assert low.min() >= floor - 1e-12 * size
    # a frame is lifted by exactly its own lowest point's distance below the floor
    lift = got[:, 1] - plain[:, 1]
    below = np.maximum(floor - _fk_points(m.skeleton, np.hstack([plain[:, :3], got[:, 3:]]),
                                          joints)[..., 1].min(axis=1), 0.0)
    np.testing.assert_allclose(lift, below, rtol=0, atol=1e-12 * size)
    # the ground track and heading are the unguarded ones, bit for bit
    np.testing.assert_array_equal(got[:, [0, 2]], plain[:, [0, 2]])
    # the root is free (no limits, no floor on its rotation): its rotation bit for bit
    np.testing.assert_array_equal(got[:, 3:7], plain[:, 3:7])
    del keep


def test_pinned_feet_slide_less(walk):
    """MLR_GEN_OPT_PIN_FEET (on by default with the guards): each foot found by name is held
    where it touches down, by IK, and let go over 0.2 s. Measured with the plausibility bench's
    own rule (its forward kinematics, foot points, floor and height-and-speed contacts, as
    bench_generate_sliding.py measures PrimitiveModel.generate): 600 frames of the CMU walk's
    model slid 1.38x the training clip's sliding with the limits and the floor alone, 0.67x with
    the feet pinned; the feet accelerate no harder (2.37x and 2.48x the training clip's largest
    foot acceleration, which the generation itself exceeds at segment joins)."""
    import sys
    from conftest import REPO
    from mlayer.model._rig import c_rig
    sys.path.insert(0, str(REPO / "bench" / "python"))
    import bench_plausibility as bp
    m, model = walk
    st, h = _load(model.runtime_bytes())
    assert st == 0, h
    rig, keep = c_rig(m.skeleton)
    lim = mlayer.joint_limits(m)
    pts, _ = bp.all_points(m)
    brig = bp.make_rig(m, pts)

    def measure(motion):
        p, _ = bp.all_points(motion)
        f = p[:, brig.feet]
        c = bp.contact_frames(f, brig.up, brig.floor, brig.H, float(motion.fps))
        acc = np.linalg.norm(f[2:] - 2 * f[1:-1] + f[:-2], axis=-1).max()
        return bp.mean_contact_speed(f, c, brig.up, float(motion.fps)) / brig.H, acc

    train, acc0 = measure(m)
    n, J = 600, m.n_joints
    got = {}
    for pin in (False, True):
        out = _guarded(h, rig, lim._h, n, 3, 150, pin_feet=pin)
        got[pin] = measure(m[:n].with_frames(root_pos=out[:, :3].copy(),
                                            rot=out[:, 3:].reshape(n, J, 4).copy()))
    assert got[False][0] > 1.2 * train  # the limits and the floor leave the feet sliding
    assert got[True][0] < 0.6 * got[False][0]
    assert got[True][0] < train
    assert got[True][1] <= 1.1 * max(got[False][1], acc0)


def test_guards_under_a_static_root_use_the_rest_translations(mocap):
    """Bandai's body joint (Hips) is below a static root: the floor guard's kinematics put the
    root and the other position channels at the rest values given (the model's
    rest_root_pos, rest_trans) and the generated position on the body joint, as motion_along
    does; its contact points then stay on or above the floor (numpy forward kinematics), the
    unguarded ones go below it, and without limits only the height changes."""
    from mlayer.model._rig import c_rig
    clip = mocap / "bandai1_walk_happy_001.bvh"
    if not clip.exists():
        pytest.skip("bandai1_walk_happy_001.bvh not found")
    m = mlayer.read_bvh(clip)
    model = PrimitiveModel.fit([m], epochs=4, k=5, som=(8, 8), lattice=(6, 6))
    assert model.body_joint != 0
    st, h = _load(model.runtime_bytes())
    assert st == 0, h
    rest = np.ascontiguousarray(np.r_[model.rest_root_pos, np.asarray(model.rest_trans).ravel()])
    rig, keep = c_rig(m.skeleton)
    plain, _ = _frames(h, 300, 2, frames=100)
    # the floor's subject: the feet left unpinned, so that only the lift changes the frames
    got = _guarded(h, rig, ffi.NULL, 300, 2, 100, ffi.cast("double *", ffi.from_buffer(rest)),
                   pin_feet=False)
    joints = [m.joint_names.index(c) for c in model.contact_names]

    def lowest(frames):
        return _fk_points(m.skeleton, frames, joints, model.body_joint, model.rest_root_pos,
                          model.rest_trans)[..., 1].min()
    size = float(np.ptp(m.trans[:, 0, 1]) + 1.0)
    assert model.floor_height - lowest(plain) > 0.1
    assert lowest(got) >= model.floor_height - 1e-12 * size
    np.testing.assert_array_equal(np.delete(got, 1, axis=1), np.delete(plain, 1, axis=1))
    del keep


def test_guards_are_refused_on_bad_arguments(walk, mocap):
    from mlayer.model._rig import c_rig
    m, model = walk
    st, h = _load(model.runtime_bytes())
    assert st == 0, h
    rig, keep = c_rig(m.skeleton)
    lim = mlayer.joint_limits(m)
    diag = ffi.new("mlr_diag *")

    def fresh():
        st, g = _generator(h, 1, [])
        assert st == 0, g
        return g
    assert lib.mlr_generator_set_guards(fresh(), ffi.NULL, ffi.NULL, lim._h, diag) == \
        lib.MLR_E_INVALID_ARG
    assert "rig is NULL" in ffi.string(diag.message).decode()
    # another skeleton, named by its first differing joint
    other = mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")
    orig, okeep = c_rig(other.skeleton)
    assert lib.mlr_generator_set_guards(fresh(), orig, ffi.NULL, ffi.NULL, diag) == \
        lib.MLR_E_INVALID_ARG
    msg = ffi.string(diag.message).decode()
    assert "mlr_generator_set_guards: rig:" in msg and "the model" in msg, msg
    # limits of another rig
    olim = mlayer.joint_limits(other)
    if olim.n_joints != m.n_joints:
        assert lib.mlr_generator_set_guards(fresh(), rig, ffi.NULL, olim._h, diag) == \
            lib.MLR_E_INVALID_ARG
        assert "limits of" in ffi.string(diag.message).decode()
    # a non-finite rest value
    rest = np.zeros(3 + 3 * len(m.skeleton.trans_joints))
    rest[1] = np.nan
    assert lib.mlr_generator_set_guards(fresh(), rig, ffi.cast("double *", ffi.from_buffer(rest)),
                                        lim._h, diag) == lib.MLR_E_INVALID_ARG
    assert "rest[1]" in ffi.string(diag.message).decode()
    # after the first frame, or twice
    g = fresh()
    pose = np.empty(lib.mlr_gen_model_frame_size(h))
    assert lib.mlr_generator_next(g, ffi.cast("double *", ffi.from_buffer(pose)), diag) == 0
    assert lib.mlr_generator_set_guards(g, rig, ffi.NULL, lim._h, diag) == lib.MLR_E_BAD_STATE
    assert "before the first mlr_generator_next" in ffi.string(diag.message).decode()
    g = fresh()
    assert lib.mlr_generator_set_guards(g, rig, ffi.NULL, lim._h, diag) == 0
    assert lib.mlr_generator_set_guards(g, rig, ffi.NULL, lim._h, diag) == lib.MLR_E_BAD_STATE


def test_no_call_computes_a_whole_segment(walk):
    """The next segment is computed ahead in parts over the calls of the current one. Per
    segment after the first: the largest call's share of the processor time of all the
    segment's calls; the smallest share over five segments (a call the machine slowed down,
    a page fault, makes one segment's share larger, not all five) is below 0.1. When a
    segment's first call computed the segment, every share was 0.31 to 0.47 here. The thread's
    processor time leaves out the time the machine gave to other jobs."""
    import time
    _, model = walk
    st, h = _load(model.runtime_bytes())
    assert st == 0, h
    seg = 300
    st, g = _generator(h, 5, [(lib.MLR_GEN_OPT_FRAMES, float(seg))])
    assert st == 0, g
    diag = ffi.new("mlr_diag *")
    pose = np.empty(lib.mlr_gen_model_frame_size(h))
    p = ffi.cast("double *", ffi.from_buffer(pose))
    took = np.empty(6 * seg)
    for f in range(took.size):
        t0 = time.thread_time_ns()
        st = lib.mlr_generator_next(g, p, diag)
        took[f] = time.thread_time_ns() - t0
        assert st == 0
    share = [took[s * seg:(s + 1) * seg].max() / took[s * seg:(s + 1) * seg].sum()
             for s in range(1, 6)]
    assert min(share) < 0.1, share
