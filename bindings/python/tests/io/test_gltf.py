"""glTF 2.0: mlayer.write_gltf / read_gltf and `mlayer convert`.

- every shared clip written as GLB (and as .gltf for some): the node world positions that an
  independent evaluator (gltf_eval.py, numpy only, no mlayer code) computes from the file match
  motion.positions() turned to Y-up and scaled to metres, to 1e-6 of the body size;
- read back: offsets and root positions exactly the float32 values written, rotations to
  float32 rounding, the frame time and the channel layout exact;
- Z-up and inch clips converted to Y-up metres (and back with read_gltf(up=, units=));
- the Khronos validator (npm gltf-validator, run by gltf_validate.js under node) finds no
  error and no warning (skipped only when node is absent);
- files written by others: the Khronos SimpleSkin (CC0) and RiggedSimple (CC BY 4.0) samples
  (tests/data/gltf/README.md) and files built here the way
  exporters write them (an Armature matrix node turning Z-up centimetres, STEP, CUBICSPLINE,
  non-uniform key times, normalized integer rotations, sparse accessors, a side .bin file);
- bad input: a ParseError naming the file and the reason, never a KeyError or IndexError.
"""
from __future__ import annotations

import base64
import json
import os
import pathlib
import shutil
import struct
import subprocess
import sys
import warnings

import numpy as np
import pytest

import mlayer
import mlayer.io.gltf as G
from mlayer import quat
from mlayer.model.units import UNITS
from conftest import SHARED_CLIPS, REPO

import gltf_eval as E

HERE = pathlib.Path(__file__).resolve().parent
DATA = REPO / "tests" / "data" / "gltf"
WILD = REPO / "tests" / "data" / "wild"
F32 = float(np.finfo(np.float32).eps)


# ---- helpers ---------------------------------------------------------------------------------

def _expected(m, up=None, units=None):
    """The motion turned to Y-up metres the way the file must hold it."""
    up = up or m.up_axis
    units = units or m.units
    return G.reframe(m, G._TO_Y[up], UNITS[units] if units else 1.0)


def _size(p):
    ext = p.reshape(-1, 3).max(axis=0) - p.reshape(-1, 3).min(axis=0)
    return float(np.median(np.ptp(p, axis=1).max(axis=1))) or float(ext.max())


def _file_positions(path, n_joints, times=None):
    g = E.Gltf(str(path))
    t = E.key_times(g) if times is None else times
    wp = E.world_positions(g, t, nodes=range(n_joints))
    return t, np.stack([wp[j] for j in range(n_joints)], axis=1)


def _validator():
    """(node, validator folder), or skip when node or the validator is absent; but where
    $MLAYER_EXPECT_GLTF_VALIDATOR is 1 (scripts/test.sh, where npm is there for setup.sh to
    install it) a missing validator fails."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed: the Khronos glTF validator (npm gltf-validator) "
                    "cannot run here")
    d = os.environ.get("GLTF_VALIDATOR") or str(REPO / ".venv" / "node_modules" /
                                                "gltf-validator")
    if not os.path.isdir(d):
        why = (f"the glTF validator (npm gltf-validator) is not at {d}: scripts/setup.sh "
               "installs it with npm")
        if os.environ.get("MLAYER_EXPECT_GLTF_VALIDATOR") == "1":
            pytest.fail(why)
        pytest.skip(why)
    return node, d


def validate(*paths):
    """The validator's reports of the files (a list of issues dicts)."""
    node, d = _validator()
    out = subprocess.run([node, str(HERE / "gltf_validate.js"), *map(str, paths)],
                         env={**os.environ, "GLTF_VALIDATOR": d}, capture_output=True,
                         text=True, timeout=300, check=True)
    return [json.loads(line)["issues"] for line in out.stdout.splitlines()]


def _clip(mocap, name):
    return mlayer.read_bvh(mocap / name)


# ---- round trips on the shared clips -----------------------------------------------------------

@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_shared_clip_round_trip(mocap, tmp_path, name):
    m = _clip(mocap, name)
    ext = ".gltf" if name.startswith(("cmu_10", "bandai")) else ".glb"
    out = tmp_path / ("clip" + ext)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mlayer.MlayerWarning)  # CMU units: unknown
        mlayer.write_gltf(m, out)
    x = _expected(m)
    want = x.positions()
    size = _size(want)
    # the file, evaluated independently: world positions of the joint nodes
    t, got = _file_positions(out, m.n_joints)
    assert t.shape == (m.n_frames,)
    np.testing.assert_allclose(t, (np.arange(m.n_frames) * m.frame_time).astype(np.float32))
    err = float(np.abs(got - want).max())
    assert err <= 1e-6 * size, f"{name}: max position error {err:.3g} (body size {size:.3g})"
    # read back
    r = mlayer.read_gltf(out)
    assert r.frame_time == m.frame_time
    assert r.skeleton.joint_names == m.skeleton.joint_names
    assert r.skeleton.channels == m.skeleton.channels
    np.testing.assert_array_equal(r.parents, m.parents)
    f32 = lambda a: np.asarray(a, dtype=np.float32).astype(np.float64)  # noqa: E731
    # node translations are JSON numbers (float64): the OFFSETs come back exactly; the
    # animation (root positions, position channels, rotations) is float32
    off = x.offsets.copy()
    off[0] = f32(x.root_pos[0])  # the root's: where the first frame has it
    np.testing.assert_array_equal(r.offsets, off)
    np.testing.assert_array_equal(r.root_pos, f32(x.root_pos))
    np.testing.assert_array_equal(r.trans, f32(x.trans))
    np.testing.assert_array_equal(r.end_site_parents, m.end_site_parents)
    np.testing.assert_array_equal(r.end_site_offsets, x.end_site_offsets)
    d = np.abs(np.sum(r.rot * x.rot, axis=-1))  # |cos(angle/2)|: same rotation up to sign
    ang = 2 * np.arccos(np.minimum(d, 1.0))
    assert float(ang.max()) < 4e-7, f"{name}: rotations differ by {ang.max():.3g} rad"
    assert r.up_axis == "y" and r.units == "m"
    np.testing.assert_allclose(r.positions(), want, rtol=0, atol=1e-6 * size)


def test_round_trip_bvh_text(mocap, tmp_path):
    """BVH -> glTF -> BVH keeps the hierarchy, the channel layout and the Euler orders."""
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh", units="m")
    mlayer.write_gltf(m, tmp_path / "a.glb")
    b = mlayer.read_gltf(tmp_path / "a.glb")
    mlayer.write_bvh(b, tmp_path / "b.bvh")
    c = mlayer.read_bvh(tmp_path / "b.bvh")
    assert c.skeleton.channels == m.skeleton.channels
    assert c.skeleton.euler_orders == m.skeleton.euler_orders
    assert c.n_frames == m.n_frames
    size = _size(m.positions())
    assert np.abs(c.positions() - m.positions()).max() < 1e-6 * size


# ---- up axis and units --------------------------------------------------------------------------

def _zup_inches(m):
    """m (Y-up cm) as a Z-up clip in inches, same motion."""
    z = G.reframe(m, G._TO_Y["z"].T, 0.01 / UNITS["in"])
    z.up_axis, z.units = "z", "in"
    return z


def test_zup_inch_clip_becomes_yup_metres(mocap, tmp_path):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")
    assert m.units == "cm" and m.up_axis == "y"
    z = _zup_inches(m)
    mlayer.write_gltf(z, tmp_path / "z.glb")
    want = m.positions() * 0.01  # the original clip in metres, Y-up
    size = _size(want)
    _, got = _file_positions(tmp_path / "z.glb", m.n_joints)
    assert np.abs(got - want).max() <= 1e-6 * size
    # and the up axis detected from the clip itself (no up_axis given)
    z2 = G.reframe(m, G._TO_Y["z"].T, 1.0)
    assert z2.up_axis == "z"
    mlayer.write_gltf(z2, tmp_path / "z2.glb", units="cm")
    _, got = _file_positions(tmp_path / "z2.glb", m.n_joints)
    assert np.abs(got - want).max() <= 1e-6 * size
    # back to Z-up inches on reading
    r = mlayer.read_gltf(tmp_path / "z.glb", up="z", units="in")
    assert r.up_axis == "z" and r.units == "in"
    assert np.abs(r.positions() - z.positions()).max() <= 1e-6 * _size(z.positions())


def test_overrides_win(mocap, tmp_path):
    m = _clip(mocap, "cmu_131_01_mj_style_walk.bvh")
    with pytest.warns(mlayer.MlayerWarning, match="unknown"):
        mlayer.write_gltf(m, tmp_path / "a.glb")
    mlayer.write_gltf(m, tmp_path / "b.glb", units="in", up="y")
    _, a = _file_positions(tmp_path / "a.glb", m.n_joints)
    _, b = _file_positions(tmp_path / "b.glb", m.n_joints)
    np.testing.assert_allclose(b, a * UNITS["in"], rtol=2e-6, atol=1e-7)
    with pytest.raises(mlayer.InvalidArgumentError, match="up"):
        mlayer.write_gltf(m, tmp_path / "c.glb", up="w")
    with pytest.raises(mlayer.InvalidArgumentError, match="units"):
        mlayer.write_gltf(m, tmp_path / "c.glb", units="furlong")
    assert not (tmp_path / "c.glb").exists()


def test_real_zup_clip(tmp_path):
    """A Z-up BVH from the wild (MakeHuman, CC0): detected Z-up, written Y-up."""
    src = WILD / "makehuman_walk1_zup.bvh"
    m = mlayer.read_bvh(src)
    assert m.up_axis == "z"
    mlayer.write_gltf(m, tmp_path / "w.glb", units="m")
    _, got = _file_positions(tmp_path / "w.glb", m.n_joints)
    want = mlayer.model.up_axis.to_y_up("z", m.positions())
    assert np.abs(got - want).max() <= 1e-6 * _size(want)
    ext = np.ptp(got, axis=1).mean(axis=0)  # the body's extent along x, y, z
    assert ext[1] > 2 * max(ext[0], ext[2])  # standing along Y


# ---- the validator ----------------------------------------------------------------------------

def test_validator_no_errors_no_warnings(mocap, tmp_path):
    paths = []
    for name in ("cmu_02_03_run_jog_25fps.bvh", "bandai1_walk_happy_001.bvh",
                 "ai4a_dog_D1_008_KAN01_002.bvh"):
        m = _clip(mocap, name)
        for ext in (".glb", ".gltf"):
            p = tmp_path / (name[:-4] + ext)
            mlayer.write_gltf(m, p)
            paths.append(p)
    m = _clip(mocap, "cmu_10_01_soccer_kick.bvh")
    mlayer.write_gltf(m, tmp_path / "nomesh.glb", mesh=False)
    paths.append(tmp_path / "nomesh.glb")
    for p, rep in zip(paths, validate(*paths), strict=True):
        assert rep["numErrors"] == 0, (p, rep["messages"])
        assert rep["numWarnings"] == 0, (p, rep["messages"])
        codes = {x["code"] for x in rep["messages"] if x["severity"] == 2}
        # infos left: every End Site node (a leaf with a translation only) is "empty"; without
        # the bones mesh the skin is used by nothing
        allowed = {"NODE_EMPTY"} | ({"UNUSED_OBJECT"} if p.name == "nomesh.glb" else set())
        assert codes <= allowed, (p, codes)


# ---- files written by others --------------------------------------------------------------------

def test_khronos_simple_skin():
    """The Khronos SimpleSkin sample (CC0, tests/data/gltf): 2 joints, 4 buffers, a stride."""
    path = DATA / "SimpleSkin.gltf"
    m = mlayer.read_gltf(path)
    assert m.n_joints == 2 and m.n_frames == 12 and m.fps == pytest.approx(2.0)
    g = E.Gltf(str(path))
    t = E.key_times(g)
    wp = E.world_positions(g, t, nodes=[1, 2])
    np.testing.assert_allclose(m.positions(), np.stack([wp[1], wp[2]], axis=1), atol=1e-12)
    # the rotation track: about Z by up to 90 degrees
    z = quat.log(m.rot[:, 1])[:, 2]
    assert np.degrees(z).max() == pytest.approx(90.0, abs=0.1)


def test_khronos_rigged_simple():
    """The Khronos RiggedSimple sample (CC BY 4.0, Cesium; a COLLADA2GLTF export): a root
    matrix node turning Z-up to Y-up above an empty group node, scales of 0.9999999."""
    path = DATA / "RiggedSimple.gltf"
    m = mlayer.read_gltf(path)
    assert m.n_joints == 2 and m.n_frames == 3
    g = E.Gltf(str(path))
    keys = E.key_times(g)  # 0.0417, 1.0417, 2.0833: not uniform, resampled at the median step
    assert m.frame_time == pytest.approx(float(np.median(np.diff(keys))), rel=1e-9)
    t = keys[0] + np.arange(3) * m.frame_time
    wp = E.world_positions(g, t, nodes=[2, 3])
    want = np.stack([wp[2], wp[3]], axis=1)
    size = float(np.ptp(want.reshape(-1, 3), axis=0).max())
    # the scales (1, 0.99999988, 0.99999988) are taken as their mean: 4e-8 of the size
    assert np.abs(m.positions() - want).max() <= 1e-7 * size
    # the root matrix's turn is folded into the root: the bone hangs along -Y (it stood along
    # Z before the matrix turned it)
    d = m.positions()[0, 1] - m.positions()[0, 0]
    assert abs(d[1]) > 0.99 * np.linalg.norm(d)


def _pack(doc, chunks, path, binary=False, side=None):
    """Write a glTF doc with the given byte chunks as one buffer (each 4-aligned) and
    bufferViews; returns the view indices."""
    buf = b""
    views = []
    for c in chunks:
        views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": len(c)})
        buf += c + b"\0" * ((-len(c)) % 4)
    doc["bufferViews"] = views
    if binary:
        doc["buffers"] = [{"byteLength": len(buf)}]
        js = json.dumps(doc).encode()
        js += b" " * ((-len(js)) % 4)
        data = struct.pack("<4sII", b"glTF", 2, 28 + len(js) + len(buf)) + \
            struct.pack("<II", len(js), 0x4E4F534A) + js + \
            struct.pack("<II", len(buf), 0x004E4942) + buf
        path.write_bytes(data)
        return
    if side:
        (path.parent / side).write_bytes(buf)
        doc["buffers"] = [{"byteLength": len(buf), "uri": side}]
    else:
        doc["buffers"] = [{"byteLength": len(buf), "uri": "data:application/octet-stream;"
                           "base64," + base64.b64encode(buf).decode()}]
    path.write_text(json.dumps(doc, indent=1))


def _exporter_file(path, rng, *, binary=False, side=None, rot_mode="LINEAR",
                   tr_mode="LINEAR", normalized=False, sparse=False, uniform=True):
    """A 4-joint chain as an exporter writes it: a static "Armature" matrix node turning Z-up
    centimetres to Y-up metres, joints with TRS, a mesh node, End-less leaf bones."""
    K = 9
    times = np.arange(K, dtype=np.float32) / np.float32(30) if uniform else \
        np.cumsum(rng.uniform(0.01, 0.08, K)).astype(np.float32)
    rv = rng.normal(0, 0.6, (K, 4, 3))
    q = quat.exp(rv)[..., [1, 2, 3, 0]].astype(np.float32)  # scalar-last
    chunks = [times.tobytes()]
    acc = [{"bufferView": 0, "componentType": 5126, "count": K, "type": "SCALAR",
            "min": [float(times.min())], "max": [float(times.max())]}]
    samplers, channels = [], []
    for j in range(4):
        if rot_mode == "CUBICSPLINE":
            tang = rng.normal(0, 0.3, (K, 2, 4)).astype(np.float32)
            data = np.stack([tang[:, 0], q[:, j], tang[:, 1]], axis=1).reshape(-1, 4)
            ctype, count = 5126, 3 * K
            raw = data.tobytes()
        elif normalized:
            raw = np.round(q[:, j] * 32767).astype(np.int16).tobytes()
            ctype, count = 5122, K
        else:
            raw, ctype, count = q[:, j].tobytes(), 5126, K
        chunks.append(raw)
        a = {"bufferView": len(chunks) - 1, "componentType": ctype, "count": count,
             "type": "VEC4"}
        if normalized:
            a["normalized"] = True
        acc.append(a)
        samplers.append({"input": 0, "output": len(acc) - 1, "interpolation": rot_mode})
        channels.append({"sampler": len(samplers) - 1,
                         "target": {"node": 1 + j, "path": "rotation"}})
    root_t = np.cumsum(rng.normal(0, 2.0, (K, 3)), axis=0).astype(np.float32) + \
        np.float32([0, 0, 90])
    if sparse:  # a constant track with two keys replaced: sparse over a zero base
        base = np.zeros((K, 3), np.float32)
        idx = np.array([2, 5], dtype=np.uint16)
        vals = root_t[idx]
        root_t = base.copy()
        root_t[idx] = vals
        chunks += [idx.tobytes(), vals.tobytes()]
        acc.append({"componentType": 5126, "count": K, "type": "VEC3", "sparse": {
            "count": 2, "indices": {"bufferView": len(chunks) - 2, "componentType": 5123},
            "values": {"bufferView": len(chunks) - 1}}})
    else:
        chunks.append(root_t.tobytes())
        acc.append({"bufferView": len(chunks) - 1, "componentType": 5126, "count": K,
                    "type": "VEC3"})
    samplers.append({"input": 0, "output": len(acc) - 1, "interpolation": tr_mode})
    channels.append({"sampler": len(samplers) - 1, "target": {"node": 1, "path": "translation"}})
    h = float(np.sqrt(0.5))
    # column-major matrix: rotate -90 degrees about X (Z-up -> Y-up), scale 0.01
    R = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], dtype=np.float64) * 0.01
    M = np.eye(4)
    M[:3, :3] = R
    nodes = [{"name": "Armature", "matrix": [float(x) for x in M.T.reshape(-1)],
              "children": [1, 6]},
             {"name": "Hips", "translation": [0, 0, 90], "children": [2],
              "scale": [1.0, 1.0, 1.0]},
             {"name": "Spine", "translation": [0, 0, 20], "children": [3],
              "rotation": [0, 0, h, h]},
             {"name": "Neck", "translation": [0, 0, 25], "children": [4]},
             {"name": "Head", "translation": [0, 0, 10], "children": [5]},
             {"name": "Head_end", "translation": [0, 0, 12]},
             {"name": "Body", "mesh": 0, "skin": 0}]
    doc = {"asset": {"version": "2.0", "generator": "test exporter"}, "scene": 0,
           "scenes": [{"nodes": [0]}], "nodes": nodes,
           "skins": [{"joints": [1, 2, 3, 4], "skeleton": 1}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": len(acc)}}]}],
           "animations": [{"samplers": samplers, "channels": channels}], "accessors": acc}
    pos = np.zeros((3, 3), np.float32)
    chunks.append(pos.tobytes())
    acc.append({"bufferView": len(chunks) - 1, "componentType": 5126, "count": 3,
                "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0]})
    _pack(doc, chunks, path, binary=binary, side=side)
    return times.astype(np.float64)


@pytest.mark.parametrize("variant", [
    dict(), dict(binary=True), dict(side="anim.bin"), dict(rot_mode="CUBICSPLINE"),
    dict(rot_mode="STEP", tr_mode="STEP"), dict(normalized=True), dict(sparse=True),
    dict(uniform=False)])
def test_exporter_files(tmp_path, rng, variant):
    path = tmp_path / ("x.glb" if variant.get("binary") else "x.gltf")
    times = _exporter_file(path, rng, **variant)
    m = mlayer.read_gltf(path)
    assert m.skeleton.joint_names == ["Hips", "Spine", "Neck", "Head"]
    assert m.skeleton.n_end_sites == 1
    g = E.Gltf(str(path))
    ft = m.frame_time
    if variant.get("uniform", True):
        assert m.n_frames == len(times) and ft == pytest.approx(1 / 30, rel=1e-6)
        t = times
    else:  # resampled at the median key interval
        assert ft == pytest.approx(float(np.median(np.diff(times))), rel=1e-9)
        t = times[0] + np.arange(m.n_frames) * ft
    wp = E.world_positions(g, t, nodes=[1, 2, 3, 4, 5])
    want = np.stack([wp[i] for i in (1, 2, 3, 4)], axis=1)
    size = float(np.ptp(want.reshape(-1, 3), axis=0).max())
    # at the keys: the same arithmetic to rounding; between keys (resampled), two slerp
    # implementations (the C core's, the evaluator's) agree to about 3e-9
    tol = (1e-9 if variant.get("uniform", True) else 1e-8) * size
    assert np.abs(m.positions() - want).max() <= tol
    assert np.abs(m.end_site_positions()[:, 0] - wp[5]).max() <= tol
    # a forced rate: resampled between the keys
    r = mlayer.read_gltf(path, fps=97.0)
    tt = times[0] + np.arange(r.n_frames) / 97.0
    assert tt[-1] <= times[-1] + 1e-9 and tt[-1] + 1 / 97.0 > times[-1]
    wp = E.world_positions(g, tt, nodes=[1, 2, 3, 4])
    want = np.stack([wp[i] for i in (1, 2, 3, 4)], axis=1)
    assert np.abs(r.positions() - want).max() <= 1e-8 * size


def test_node_tree_without_skin(tmp_path, rng):
    """No skin: the animated nodes' tree is the skeleton."""
    path = tmp_path / "x.gltf"
    _exporter_file(path, rng)
    doc = json.loads(path.read_text())
    del doc["skins"]
    del doc["nodes"][6]["skin"]
    path.write_text(json.dumps(doc))
    m = mlayer.read_gltf(path)
    assert m.skeleton.joint_names == ["Hips", "Spine", "Neck", "Head"]


def test_animation_choice(tmp_path, mocap):
    m = _clip(mocap, "cmu_60_10_salsa_dance.bvh")[:50]
    mlayer.write_gltf(m, tmp_path / "a.gltf")
    doc = json.loads((tmp_path / "a.gltf").read_text())
    doc["animations"].append(doc["animations"][0])
    (tmp_path / "b.gltf").write_text(json.dumps(doc))
    assert mlayer.read_gltf(tmp_path / "b.gltf", animation=1).n_frames == 50
    with pytest.raises(mlayer.InvalidArgumentError, match="animation=2.*2 animation"):
        mlayer.read_gltf(tmp_path / "b.gltf", animation=2)


# ---- bad input ----------------------------------------------------------------------------------

def _small(tmp_path, mocap):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")[:5]
    p = tmp_path / "s.gltf"
    mlayer.write_gltf(m, p)
    return json.loads(p.read_text())


def _bad(tmp_path, doc_or_bytes, match, name="bad.gltf", exc=mlayer.ParseError):
    p = tmp_path / name
    if isinstance(doc_or_bytes, bytes):
        p.write_bytes(doc_or_bytes)
    else:
        p.write_text(json.dumps(doc_or_bytes))
    with pytest.raises(exc, match=match) as e:
        mlayer.read_gltf(p)
    assert str(p) in str(e.value)
    if exc is mlayer.ParseError:
        assert e.value.path == str(p)


def test_bad_input(tmp_path, mocap):
    doc = _small(tmp_path, mocap)
    d = json.loads(json.dumps(doc))
    del d["animations"]
    _bad(tmp_path, d, "no animations")
    d = json.loads(json.dumps(doc))
    del d["animations"], d["skins"], d["meshes"], d["nodes"]
    _bad(tmp_path, d, "no nodes")
    _bad(tmp_path, b'{"asset": {"version": "2.0"}, "nodes": [', "broken JSON at line 1")
    _bad(tmp_path, b"\xff\xfe\x00garbage", "not glTF")
    _bad(tmp_path, b'{"nodes": []}', "asset.version")
    _bad(tmp_path, b'{"asset": {"version": "1.0"}}', "version 1.0")
    d = json.loads(json.dumps(doc))
    d["animations"][0]["samplers"][-1]["output"] = d["animations"][0]["samplers"][0]["output"]
    _bad(tmp_path, d, "type 'VEC3', expected VEC4")
    d = json.loads(json.dumps(doc))
    d["animations"][0]["channels"][0]["target"]["node"] = 999
    _bad(tmp_path, d, r"node = 999 is not an index")
    d = json.loads(json.dumps(doc))
    d["animations"][0]["samplers"][0]["input"] = 999
    _bad(tmp_path, d, "input = 999 is not an index")
    d = json.loads(json.dumps(doc))
    d["accessors"][d["animations"][0]["samplers"][0]["output"]]["count"] = 10 ** 6
    _bad(tmp_path, d, "do not fit")
    d = json.loads(json.dumps(doc))
    d["nodes"][1]["children"] = [0]
    _bad(tmp_path, d, "two parents|cycle")
    d = json.loads(json.dumps(doc))
    d["accessors"][d["animations"][0]["samplers"][0]["input"]]["componentType"] = 5123
    _bad(tmp_path, d, "componentType 5123: expected float")
    d = json.loads(json.dumps(doc))
    d["buffers"][0]["uri"] = d["buffers"][0]["uri"][:-10] + "!!!!"
    _bad(tmp_path, d, "base64")
    d = json.loads(json.dumps(doc))
    d["buffers"][0]["uri"] = "missing.bin"
    _bad(tmp_path, d, "cannot read missing.bin")
    d = json.loads(json.dumps(doc))
    d["buffers"][0]["uri"] = "https://example.com/x.bin"
    _bad(tmp_path, d, "only data: URIs and files inside")
    d = json.loads(json.dumps(doc))
    d["animations"][0]["samplers"][0]["interpolation"] = "BEZIER"
    _bad(tmp_path, d, "BEZIER")
    d = json.loads(json.dumps(doc))
    d["animations"][0]["channels"] = [c for c in d["animations"][0]["channels"]
                                      if c["target"]["path"] == "weights"]
    _bad(tmp_path, d, "animates no node")
    d = json.loads(json.dumps(doc))
    d["nodes"] = "nodes"
    _bad(tmp_path, d, "'nodes' is not a list")


def test_truncated_glb(tmp_path, mocap):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")[:5]
    data = G.gltf_bytes(m, binary=True)
    for cut in (0, 3, 11, 19, 40, len(data) // 2, len(data) - 1):
        _bad(tmp_path, data[:cut], "truncated|not glTF|broken JSON", name="t.glb")
    bad = bytearray(data)
    struct.pack_into("<I", bad, 4, 1)
    _bad(tmp_path, bytes(bad), "GLB version 1", name="v.glb")


def test_animated_scale_refused(tmp_path, rng):
    path = tmp_path / "x.gltf"
    _exporter_file(path, rng)
    doc = json.loads(path.read_text())
    doc["nodes"][2]["scale"] = [1.0, 2.0, 1.0]
    path.write_text(json.dumps(doc))
    with pytest.raises(mlayer.UnsupportedError, match=r"Spine.*non-uniform"):
        mlayer.read_gltf(path)


def test_scales_within_the_tolerance_of_uniform_are_read(tmp_path, rng):
    """Khronos' BrainStem.glb has node scales from 0.999999 to 1.00002 (float32 noise of its
    exporter): read as their mean, uniform; a spread beyond gltf.SCALE_TOLERANCE is refused."""
    ref_path, path = tmp_path / "ref.gltf", tmp_path / "noisy.gltf"
    _exporter_file(ref_path, np.random.default_rng(7))
    _exporter_file(path, np.random.default_rng(7))
    ref = mlayer.read_gltf(ref_path)
    doc = json.loads(path.read_text())
    noisy = {2: [0.999999, 1.00002, 1.0], 3: [1.00002, 0.999999, 1.00001]}  # Spine, Neck
    for node, sc in noisy.items():
        doc["nodes"][node]["scale"] = sc
    path.write_text(json.dumps(doc))
    m = mlayer.read_gltf(path)
    np.testing.assert_array_equal(m.rot, ref.rot)
    # each child's offset is scaled by the mean scale of the joints above it
    s2, s3 = (float(np.mean(v)) for v in noisy.values())
    want = ref.skeleton.offsets.copy()
    want[2:] *= s2
    want[3:] *= s3
    np.testing.assert_allclose(m.skeleton.offsets, want, rtol=1e-12, atol=1e-15)
    assert not np.array_equal(m.skeleton.offsets, ref.skeleton.offsets)
    # beyond the tolerance: refused, the message says by how much
    tol = G.SCALE_TOLERANCE
    doc["nodes"][2]["scale"] = [1.0, 1.0 + 3 * tol, 1.0]
    path.write_text(json.dumps(doc))
    with pytest.raises(mlayer.UnsupportedError, match=rf"Spine.*non-uniform.*beyond {tol:g}"):
        mlayer.read_gltf(path)


def test_mutated_files_never_crash(tmp_path, mocap, rng):
    """Random edits of a small file's JSON and bytes: a mlayer error or a motion, never a
    KeyError, IndexError or TypeError."""
    doc = _small(tmp_path, mocap)
    text = json.dumps(doc)
    glb = G.gltf_bytes(_clip(mocap, "bandai1_walk_happy_001.bvh")[:5], binary=True)
    p = tmp_path / "m.gltf"
    for k in range(300):
        if k % 2:
            b = bytearray(glb)
            for _ in range(rng.integers(1, 6)):
                b[rng.integers(0, len(b))] = rng.integers(0, 256)
            p.write_bytes(bytes(b))
        else:
            s = list(text)
            i = int(rng.integers(0, len(s)))
            s[i] = str(rng.choice(list('0123456789-[]{}",.:e ')))
            p.write_text("".join(s))
        try:
            mlayer.read_gltf(p)
        except (mlayer.ParseError, mlayer.UnsupportedError, mlayer.InvalidArgumentError):
            pass


def test_write_errors(tmp_path, mocap):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")[:5]
    with pytest.raises(mlayer.InvalidArgumentError, match=".glb or .gltf"):
        mlayer.write_gltf(m, tmp_path / "a.fbx")
    with pytest.raises(mlayer.MlayerIOError):
        mlayer.write_gltf(m, tmp_path / "no" / "such" / "a.glb")
    with pytest.raises(TypeError):
        mlayer.write_gltf("walk.bvh", tmp_path / "a.glb")
    # atomic: a failed write leaves the old file and no temporary
    (tmp_path / "keep.glb").write_bytes(b"old")
    bad = m.copy()
    bad.root_pos[2, 1] = np.nan
    with pytest.raises(mlayer.InvalidArgumentError):
        mlayer.write_gltf(bad, tmp_path / "keep.glb")
    assert (tmp_path / "keep.glb").read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.glb"]


# ---- the command line ---------------------------------------------------------------------------

def _cli(*args):
    from mlayer.cli import main
    return main([str(a) for a in args])


def test_cli_convert(tmp_path, mocap, capsys):
    src = mocap / "bandai1_walk_happy_001.bvh"
    assert _cli("convert", src, tmp_path / "a.glb") == 0
    m = mlayer.read_bvh(src)
    r = mlayer.read_gltf(tmp_path / "a.glb")
    assert np.abs(r.positions() - m.positions() * 0.01).max() < 1e-6
    assert _cli("convert", tmp_path / "a.glb", tmp_path / "b.bvh") == 0
    b = mlayer.read_bvh(tmp_path / "b.bvh")
    assert b.skeleton.channels == m.skeleton.channels
    assert np.abs(b.positions() - m.positions() * 0.01).max() < 1e-6
    # back into Z-up centimetres
    assert _cli("convert", tmp_path / "a.glb", tmp_path / "c.bvh", "--up", "z",
                "--units", "cm") == 0
    c = mlayer.read_bvh(tmp_path / "c.bvh")
    want = G.reframe(m, G._TO_Y["z"].T, 1.0).positions()
    assert np.abs(c.positions() - want).max() < 1e-4
    # a Z-up inch BVH given as such
    z = _zup_inches(m)
    mlayer.write_bvh(z, tmp_path / "z.bvh")
    assert _cli("convert", tmp_path / "z.bvh", tmp_path / "z.gltf", "--up", "z",
                "--units", "in") == 0
    r = mlayer.read_gltf(tmp_path / "z.gltf")
    assert np.abs(r.positions() - m.positions() * 0.01).max() < 1e-6
    assert _cli("convert", tmp_path / "a.glb", tmp_path / "d.bvh", "--fps", "10") == 0
    assert mlayer.read_bvh(tmp_path / "d.bvh").fps == pytest.approx(10.0)
    capsys.readouterr()
    # errors: one line, status 1, nothing written
    assert _cli("convert", src, tmp_path / "e.fbx") == 1
    assert _cli("convert", tmp_path / "a.glb", tmp_path / "f.bvh", "--animation", "3") == 1
    (tmp_path / "g.glb").write_bytes(b"glTF\x02\x00\x00\x00\xff\xff\x00\x00")
    assert _cli("convert", tmp_path / "g.glb", tmp_path / "h.bvh") == 1
    err = capsys.readouterr().err
    assert "e.fbx" in err and "animation=3" in err and "truncated GLB" in err
    assert not any((tmp_path / n).exists() for n in ("e.fbx", "f.bvh", "h.bvh"))
    assert _cli("convert", src, tmp_path / "x.bvh") == 1  # BVH to BVH: not a conversion
    assert "glTF" in capsys.readouterr().err


# ---- small and odd skeletons -------------------------------------------------------------------

def _odd_motions():
    rng = np.random.default_rng(7)
    q = lambda n, j: quat.exp(rng.normal(0, 0.4, (n, j, 3)))  # noqa: E731
    out = {}
    out["one_joint"] = mlayer.Motion.from_arrays(["Root"], [-1], [[0, 0, 0]],
                                                 rng.normal(0, 1, (5, 3)), q(5, 1))
    out["one_frame"] = mlayer.Motion.from_arrays(["Hips", "Leg", "Foot"], [-1, 0, 1],
                                                 [[0, 0, 0], [0, -0.4, 0], [0, -0.4, 0]],
                                                 [[0, 0.9, 0]], q(1, 3))
    chans = ["Xposition Yposition Zposition Zrotation Xrotation Yrotation", "", "Zrotation",
             "Xposition Yposition Zposition"]
    r = q(6, 4)
    r[:, 1] = r[:, 3] = [1, 0, 0, 0]
    out["channel_mix"] = mlayer.Motion.from_arrays(
        ["Hips", "Fixed", "Spin", "Slide"], [-1, 0, 1, 2],
        [[0, 0, 0], [0, 0.2, 0], [0, 0.3, 0], [0.1, 0, 0]], rng.normal(0, 1, (6, 3)), r,
        channels=chans, trans=rng.normal(0, 0.1, (6, 1, 3)), end_site_parents=[3],
        end_site_offsets=[[0, 0, 0.1]])
    for m in out.values():
        m.units = "m"
    return out


def test_odd_skeletons(tmp_path):
    paths = []
    for name, m in _odd_motions().items():
        p = tmp_path / f"{name}.glb"
        mlayer.write_gltf(m, p)
        paths.append(p)
        r = mlayer.read_gltf(p)
        assert r.skeleton.channels == m.skeleton.channels, name
        assert r.n_frames == m.n_frames and r.frame_time == m.frame_time
        size = max(_size(m.positions()), 1.0)
        assert np.abs(r.positions() - m.positions()).max() <= 1e-6 * size, name
        _, got = _file_positions(p, m.n_joints)
        assert np.abs(got - m.positions()).max() <= 1e-6 * size, name
    # no frames: the skeleton without an animation, which read_gltf refuses
    m0 = _odd_motions()["one_frame"][0:0]
    mlayer.write_gltf(m0, tmp_path / "empty.glb")
    paths.append(tmp_path / "empty.glb")
    with pytest.raises(mlayer.ParseError, match="no animations"):
        mlayer.read_gltf(tmp_path / "empty.glb")
    for p, rep in zip(paths, validate(*paths), strict=True):
        assert rep["numErrors"] == 0 and rep["numWarnings"] == 0, (p, rep["messages"])


def _with_times(path, times):
    """The exporter-style file at path with its key times replaced (bufferView 0)."""
    doc = json.loads(path.read_text())
    uri = doc["buffers"][0]["uri"]
    head, payload = uri.split(",", 1)
    buf = bytearray(base64.b64decode(payload))
    t = np.asarray(times, dtype=np.float32)
    buf[:t.nbytes] = t.tobytes()
    doc["buffers"][0]["uri"] = head + "," + base64.b64encode(bytes(buf)).decode()
    doc["accessors"][0]["min"], doc["accessors"][0]["max"] = [float(t[0])], [float(t[-1])]
    path.write_text(json.dumps(doc))


def test_hostile_key_times(tmp_path, rng):
    path = tmp_path / "x.gltf"
    _exporter_file(path, rng)
    _with_times(path, [0, 1e-9, 2e-9, 3e-9, 4e-9, 5e-9, 6e-9, 7e-9, 8e-9])
    with pytest.raises(mlayer.ParseError, match="below 1e-06 s"):
        mlayer.read_gltf(path)
    _with_times(path, [0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 1e9])
    with pytest.raises(mlayer.ParseError, match="too uneven"):
        mlayer.read_gltf(path)
    with pytest.raises(mlayer.InvalidArgumentError, match="fps=1000.0 makes"):
        mlayer.read_gltf(path, fps=1000.0)
    _with_times(path, [0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.05, 0.08])
    with pytest.raises(mlayer.ParseError, match="not increasing"):
        mlayer.read_gltf(path)
    with pytest.raises(mlayer.InvalidArgumentError, match="fps must be"):
        mlayer.read_gltf(path, fps=0)
    _with_times(path, np.arange(9) / 30)
    doc = json.loads(path.read_text())
    doc["accessors"].append({"componentType": 5126, "count": 10 ** 12, "type": "VEC4"})
    doc["animations"][0]["samplers"][0]["output"] = len(doc["accessors"]) - 1
    path.write_text(json.dumps(doc))
    with pytest.raises(mlayer.ParseError, match="too many"):
        mlayer.read_gltf(path)


def _side_doc(tmp_path, mocap):
    """A small glTF in tmp_path/g/ whose one buffer is the file s.bin beside it; the doc and
    its buffer's bytes."""
    doc = _small(tmp_path, mocap)
    head, _, payload = doc["buffers"][0]["uri"].partition(",")
    data = base64.b64decode(payload)
    (tmp_path / "g").mkdir()
    (tmp_path / "g" / "s.bin").write_bytes(data)
    doc["buffers"][0]["uri"] = "s.bin"
    return doc, data


def _read_with_uri(tmp_path, doc, uri, byte_length=None):
    d = json.loads(json.dumps(doc))
    d["buffers"][0]["uri"] = uri
    if byte_length is not None:
        d["buffers"][0]["byteLength"] = byte_length
    p = tmp_path / "g" / "x.gltf"
    p.write_text(json.dumps(d))
    return mlayer.read_gltf(p)


def test_external_buffers_are_read_only_inside_the_files_folder(tmp_path, mocap):
    """Issue 39, item 1: a buffer uri resolves only to a regular file inside the glTF's folder
    (URL-decoded, symlinks resolved); anything else is a ParseError naming the buffer, and
    nothing outside is opened (a FIFO would hang, /dev/zero would fill the memory)."""
    doc, data = _side_doc(tmp_path, mocap)
    # beside it, and in a subfolder: read
    assert _read_with_uri(tmp_path, doc, "s.bin").n_frames == 5
    (tmp_path / "g" / "sub").mkdir()
    shutil.copy(tmp_path / "g" / "s.bin", tmp_path / "g" / "sub" / "t%20x.bin")
    assert _read_with_uri(tmp_path, doc, "sub/t%2520x.bin").n_frames == 5
    # a secret beside the folder, with the same bytes (so the read would "work" if allowed)
    (tmp_path / "secret.bin").write_bytes(data)
    for uri in ["../secret.bin", "..%2Fsecret.bin", "sub/../../secret.bin",
                str(tmp_path / "secret.bin"), "%2F" + str(tmp_path / "secret.bin")[1:],
                "../../../../../../dev/zero", "/proc/self/environ", "file:///etc/passwd"]:
        with pytest.raises(mlayer.ParseError, match=r"buffers\[0\]") as e:
            _read_with_uri(tmp_path, doc, uri)
        assert "inside the glTF file's folder" in str(e.value), uri
    # a link inside the folder that leads out
    os.symlink(tmp_path / "secret.bin", tmp_path / "g" / "link.bin")
    with pytest.raises(mlayer.ParseError, match=r"buffers\[0\].*outside the glTF file's folder"):
        _read_with_uri(tmp_path, doc, "link.bin")
    # a FIFO inside the folder: refused at once, not read (it would block forever)
    os.mkfifo(tmp_path / "g" / "fifo.bin")
    with pytest.raises(mlayer.ParseError, match=r"buffers\[0\].*not a regular file"):
        _read_with_uri(tmp_path, doc, "fifo.bin")
    # a byteLength beyond the file: refused before reading
    with pytest.raises(mlayer.ParseError, match=r"buffers\[0\] is truncated"):
        _read_with_uri(tmp_path, doc, "s.bin", byte_length=len(data) + 1)


def test_convert_refuses_a_gltf_reaching_outside_its_folder(tmp_path, mocap):
    """The CLI: one line naming the file and the buffer, exit code 2, no output file."""
    doc, data = _side_doc(tmp_path, mocap)
    (tmp_path / "secret.bin").write_bytes(data)
    d = json.loads(json.dumps(doc))
    d["buffers"][0]["uri"] = "../secret.bin"
    p = tmp_path / "g" / "x.gltf"
    p.write_text(json.dumps(d))
    out = tmp_path / "out.bvh"
    r = subprocess.run([sys.executable, "-m", "mlayer", "convert", str(p), str(out)],
                       capture_output=True, text=True)
    assert r.returncode != 0
    assert "buffers[0]" in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


def _chain_doc(tmp_path, mocap, k):
    """The small glTF under a chain of k static nodes (a file of about 30 k bytes)."""
    doc = _small(tmp_path, mocap)
    nodes = doc["nodes"]
    n0 = len(nodes)
    roots = set(range(n0)) - {c for nd in nodes for c in nd.get("children", [])}
    for i in range(k):
        nodes.append({"children": [n0 + i + 1] if i + 1 < k else sorted(roots)})
    for sc in doc.get("scenes", []):
        sc["nodes"] = [n0]
    return doc


def test_node_trees_are_checked_in_linear_time(tmp_path, mocap, monkeypatch):
    """Issue 39: a chain of 40,000 nodes (940 KB) took 157 s, each node walked up to its root
    to rule out cycles (quadratic). Counted, not timed: the reader's checks on a 4,000-node
    chain stay within a few per node (about 8 million before)."""
    calls = [0]
    need = G._need

    def counting(cond, reason):
        calls[0] += 1
        return need(cond, reason)

    monkeypatch.setattr(G, "_need", counting)
    p = tmp_path / "chain.gltf"
    p.write_text(json.dumps(_chain_doc(tmp_path, mocap, 4000)))
    m = mlayer.read_gltf(p)
    assert m.n_frames == 5
    assert calls[0] < 20 * 4000
    # a cycle among the nodes is still found
    doc = _chain_doc(tmp_path, mocap, 50)
    doc["nodes"][-1]["children"].append(len(doc["nodes"]) - 50)
    _bad(tmp_path, doc, "two parents|cycle")


def test_json_nested_too_deep_is_a_parse_error(tmp_path):
    """Issue 39: JSON nested 100,000 deep ended in a RecursionError traceback."""
    _bad(tmp_path, b'{"asset": ' + b"[" * 100000 + b"]" * 100000 + b"}", "nested too deep")


def test_frames_are_checked_against_max_bytes_before_they_are_allocated(tmp_path, mocap):
    """Issue 39: a 406 KB GLB of 600 joints and 100k key times took 3.7 GB; fps= on a small
    file asked for 28 GiB. The frames x joints are checked against max_bytes first."""
    p = tmp_path / "s.gltf"
    p.write_text(json.dumps(_small(tmp_path, mocap)))
    m = mlayer.read_gltf(p)
    need = m.n_frames * m.n_joints * G._FRAME_BYTES
    assert mlayer.read_gltf(p, max_bytes=need).n_frames == m.n_frames
    with pytest.raises(mlayer.ParseError, match=r"more than max_bytes=") as e:
        mlayer.read_gltf(p, max_bytes=need - 1)
    assert str(p) in str(e.value)
    # fps= asks for the frames: the caller's argument, named
    with pytest.raises(mlayer.InvalidArgumentError, match=r"fps=100000.*max_bytes=1000000"):
        mlayer.read_gltf(p, fps=100000, max_bytes=1_000_000)
    for bad in (0, -1, 1.5, True):
        with pytest.raises(mlayer.InvalidArgumentError, match="max_bytes"):
            mlayer.read_gltf(p, max_bytes=bad)
