"""Generation at run time (mlr_generate.h): a model written by PrimitiveModel.runtime_bytes,
loaded by the C core, generates the frames PrimitiveModel.generate(guards=False) returns for
the same seed and options; bad model files and options are refused with a diag naming them."""
from __future__ import annotations

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
         "noise": "MLR_GEN_OPT_NOISE", "allow_unseen": "MLR_GEN_OPT_ALLOW_UNSEEN"}


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
    for what, (bad, msg) in cases.items():
        st, text = _load(bad)
        assert st == lib.MLR_E_PARSE, (what, st, text)
        assert msg in text, (what, text)


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
