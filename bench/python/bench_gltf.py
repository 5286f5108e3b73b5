"""glTF export and import speed: mlayer.write_gltf / read_gltf against pygltflib-based code
written the way a user would write it (below, in this script), on shared clips, in one run.
Prints the median of the repeats and the peer's time divided by mlayer's.

    python bench/python/bench_gltf.py [--clips lafan1_clip_a.bvh,cmu_01_01_playground_jumps.bvh]
                                      [--repeat 9] [--mocap DIR]
    python bench/python/bench_gltf.py --accuracy     # every shared clip: the file's error

``--accuracy`` writes every shared clip as GLB and prints the largest distance between the
joint positions that the tests' independent evaluator (bindings/python/tests/io/gltf_eval.py)
computes from the file and ``motion.positions()`` turned to Y-up metres, relative to the body
size, and the largest rotation error after read_gltf.

What each side does, so that the rows compare like with like:

- export: from a Motion read from BVH to a .glb on disk: the joints as nodes, a skin with
  inverse bind matrices, one LINEAR animation with the root translation and every joint's
  rotation (scalar-last), centimetres to metres. mlayer also turns the clip to Y-up (a no-op
  for these Y-up clips), writes End Site nodes and the channel layout, and, in its default row,
  the bones mesh; the "mesh=False" row is the same content as the peer's.
- import: from the .glb to frame arrays: the pygltflib reader loads the file, finds each
  joint's channels and turns its accessors into root positions (N, 3) and rotations (N, J, 4,
  scalar-first); mlayer.read_gltf builds a whole Motion (skeleton, offsets, End Sites, channel
  layout) from the same file.

pygltflib (pip install pygltflib) is required.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import tempfile
import time

import numpy as np

import mlayer
from benchutil import mocap_dir


def pygltflib_export(m: mlayer.Motion, path: str, scale: float) -> None:
    """A glTF exporter as a user writes it with pygltflib."""
    import pygltflib as g
    J, N = m.n_joints, m.n_frames
    offsets = m.offsets * scale
    root = m.root_pos * scale
    rest = np.zeros((J, 3))
    for j in range(J):
        rest[j] = (root[0] if j == 0 else rest[m.parents[j]] + offsets[j])
    nodes = []
    for j, name in enumerate(m.joint_names):
        t = root[0] if j == 0 else offsets[j]
        nodes.append(g.Node(name=name, translation=[float(x) for x in t], children=[]))
    for j in range(1, J):
        nodes[m.parents[j]].children.append(j)
    ibm = np.tile(np.eye(4, dtype=np.float32), (J, 1, 1))
    ibm[:, 3, :3] = -rest
    times = (np.arange(N) * m.frame_time).astype(np.float32)
    blobs = [ibm.tobytes(), times.tobytes(), root.astype(np.float32).tobytes()]
    q = m.rot[..., [1, 2, 3, 0]].astype(np.float32)
    blobs += [np.ascontiguousarray(q[:, j]).tobytes() for j in range(J)]
    views, accessors, offset = [], [], 0
    for b in blobs:
        views.append(g.BufferView(buffer=0, byteOffset=offset, byteLength=len(b)))
        offset += len(b)
    accessors.append(g.Accessor(bufferView=0, componentType=g.FLOAT, count=J, type=g.MAT4))
    accessors.append(g.Accessor(bufferView=1, componentType=g.FLOAT, count=N, type=g.SCALAR,
                                min=[float(times.min())], max=[float(times.max())]))
    accessors.append(g.Accessor(bufferView=2, componentType=g.FLOAT, count=N, type=g.VEC3))
    for j in range(J):
        accessors.append(g.Accessor(bufferView=3 + j, componentType=g.FLOAT, count=N,
                                    type=g.VEC4))
    samplers = [g.AnimationSampler(input=1, output=2, interpolation="LINEAR")]
    channels = [g.AnimationChannel(sampler=0, target=g.AnimationChannelTarget(
        node=0, path="translation"))]
    for j in range(J):
        samplers.append(g.AnimationSampler(input=1, output=3 + j, interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=j + 1, target=g.AnimationChannelTarget(
            node=j, path="rotation")))
    gl = g.GLTF2(scene=0, scenes=[g.Scene(nodes=[0])], nodes=nodes,
                 skins=[g.Skin(joints=list(range(J)), inverseBindMatrices=0, skeleton=0)],
                 animations=[g.Animation(samplers=samplers, channels=channels)],
                 accessors=accessors, bufferViews=views, buffers=[g.Buffer(byteLength=offset)])
    gl.set_binary_blob(b"".join(blobs))
    gl.save_binary(path)


def pygltflib_import(path: str):
    """Frame arrays from a .glb with pygltflib, as a user writes it."""
    import pygltflib as g
    gl = g.GLTF2().load_binary(path)
    blob = gl.binary_blob()

    def read(i, n):
        a = gl.accessors[i]
        v = gl.bufferViews[a.bufferView]
        start = (v.byteOffset or 0) + (a.byteOffset or 0)
        return np.frombuffer(blob, dtype=np.float32, count=a.count * n,
                             offset=start).reshape(a.count, n).astype(np.float64)
    joints = gl.skins[0].joints
    index = {n: k for k, n in enumerate(joints)}
    an = gl.animations[0]
    N = gl.accessors[an.samplers[0].input].count
    rot = np.tile([1.0, 0.0, 0.0, 0.0], (N, len(joints), 1))
    root = np.zeros((N, 3))
    for ch in an.channels:
        s = an.samplers[ch.sampler]
        k = index.get(ch.target.node)
        if k is None:
            continue
        if ch.target.path == "rotation":
            rot[:, k] = read(s.output, 4)[:, [3, 0, 1, 2]]
        elif ch.target.path == "translation" and k == 0:
            root = read(s.output, 3)
    return root, rot


def _seconds(fn, *args, **kw) -> float:
    t0 = time.perf_counter()
    fn(*args, **kw)
    return time.perf_counter() - t0


def accuracy(mocap: pathlib.Path, tmp: str) -> None:
    """The file's position error and the read-back rotation error on every shared clip."""
    import sys
    import warnings
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "bindings" / "python"
                           / "tests" / "io"))
    import gltf_eval as E
    from mlayer.io.gltf import _TO_Y, reframe
    from mlayer.model.units import UNITS
    out = os.path.join(tmp, "a.glb")
    for p in sorted(mocap.glob("*.bvh")):
        m = mlayer.read_bvh(p)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mlayer.MlayerWarning)  # CMU: unit unknown
            mlayer.write_gltf(m, out)
        x = reframe(m, _TO_Y[m.up_axis], UNITS[m.units] if m.units else 1.0)
        want = x.positions()
        g = E.Gltf(out)
        wp = E.world_positions(g, E.key_times(g), nodes=range(m.n_joints))
        got = np.stack([wp[j] for j in range(m.n_joints)], axis=1)
        size = float(np.median(np.ptp(want, axis=1).max(axis=1)))
        r = mlayer.read_gltf(out)
        d = np.abs(np.sum(r.rot * x.rot, axis=-1))
        ang = 2 * np.arccos(np.minimum(d, 1.0))
        print(f"{p.name:36s} up {m.up_axis} units {m.units or '?':2s}  file positions: max "
              f"error {np.abs(got - want).max() / size:.2e} of the body size; read back: "
              f"{np.abs(r.positions() - want).max() / size:.2e}, rotations {ang.max():.2e} rad")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clips", default="lafan1_clip_a.bvh,cmu_01_01_playground_jumps.bvh")
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--mocap", type=pathlib.Path, default=mocap_dir())
    ap.add_argument("--accuracy", action="store_true",
                    help="print the files' position and rotation errors instead of timing")
    args = ap.parse_args()
    if args.accuracy:
        with tempfile.TemporaryDirectory() as tmp:
            accuracy(args.mocap, tmp)
        return
    import pygltflib  # noqa: F401  (fails here, before any work, when it is missing)
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.clips.split(","):
            m = mlayer.read_bvh(args.mocap / name, units="cm")
            out = os.path.join(tmp, "m.glb")
            peer = os.path.join(tmp, "p.glb")
            print(f"{name}: {m.n_frames} frames, {m.n_joints} joints")
            rows = []
            # the two sides take turns, so the shared machine's slow spells fall on both
            # (and in turn first: the call after another one's frees pays page faults)
            t_m, t_n, t_p = [], [], []
            calls = [(t_m, mlayer.write_gltf, (m, out), {}),
                     (t_n, mlayer.write_gltf, (m, out), {"mesh": False}),
                     (t_p, pygltflib_export, (m, peer, 0.01), {})]
            for r in range(args.repeat):
                for times, fn, a, kw in calls[r % 3:] + calls[:r % 3]:
                    times.append(_seconds(fn, *a, **kw))
            em, en, ep = (float(np.median(t)) for t in (t_m, t_n, t_p))
            rows.append(("export mlayer.write_gltf", em, ep / em))
            rows.append(("export mlayer.write_gltf(mesh=False)", en, ep / en))
            rows.append(("export pygltflib (user code)", ep, 1.0))
            # both importers read the same file: mlayer's without the mesh
            mlayer.write_gltf(m, out, mesh=False)
            r_m, r_p = [], []
            for r in range(args.repeat):
                pair = [(r_m, mlayer.read_gltf), (r_p, pygltflib_import)]
                for times, fn in pair[r % 2:] + pair[:r % 2]:
                    times.append(_seconds(fn, out))
            im, ip = float(np.median(r_m)), float(np.median(r_p))
            rows.append(("import mlayer.read_gltf (a whole Motion)", im, ip / im))
            rows.append(("import pygltflib (user code: frame arrays)", ip, 1.0))
            # the two exporters' files agree
            root, rot = pygltflib_import(peer)
            r = mlayer.read_gltf(out)
            assert np.abs(root - r.root_pos).max() < 1e-6
            d = np.abs(np.sum(rot * r.rot, axis=-1))
            assert d.min() > 1 - 1e-6
            for label, t, ratio in rows:
                extra = f"  peer / this = {ratio:.2f}x" if ratio != 1.0 else ""
                print(f"  {label:44s} {1e3 * t:8.2f} ms{extra}")


if __name__ == "__main__":
    main()
