"""An independent glTF 2.0 evaluator for the tests: node world positions at given times.

Written from the glTF 2.0 specification, separately from mlayer.io.gltf (it shares no code with
it and uses only numpy): GLB / JSON containers, data: URIs and files beside the .gltf,
accessors with strides, sparse substitution and normalized integers, TRS and matrix nodes,
animation samplers (LINEAR with slerp for rotations, STEP, CUBICSPLINE), and world transforms
as 4x4 matrix products down the node tree.
"""
from __future__ import annotations

import base64
import json
import os
import struct

import numpy as np

_DT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
       5126: np.float32}
_NORM = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
_N = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class Gltf:
    def __init__(self, path: str):
        raw = open(path, "rb").read()
        self.bin = None
        if raw[:4] == b"glTF":
            jlen = struct.unpack_from("<I", raw, 12)[0]
            self.doc = json.loads(raw[20:20 + jlen])
            rest = 20 + jlen
            if rest < len(raw):
                blen = struct.unpack_from("<I", raw, rest)[0]
                self.bin = raw[rest + 8: rest + 8 + blen]
        else:
            self.doc = json.loads(raw)
        self.dir = os.path.dirname(os.path.abspath(path))
        self.buffers = []
        for b in self.doc.get("buffers", []):
            uri = b.get("uri")
            if uri is None:
                self.buffers.append(self.bin)
            elif uri.startswith("data:"):
                self.buffers.append(base64.b64decode(uri.split(",", 1)[1]))
            else:
                self.buffers.append(open(os.path.join(self.dir, uri), "rb").read())
        nodes = self.doc["nodes"]
        self.parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}

    def _view(self, vi, offset, dtype, count, ncomp):
        v = self.doc["bufferViews"][vi]
        start = v.get("byteOffset", 0) + offset
        item = np.dtype(dtype).itemsize
        stride = v.get("byteStride", item * ncomp)
        buf = self.buffers[v["buffer"]]
        rows = np.frombuffer(buf, dtype=np.uint8, count=stride * (count - 1) + item * ncomp,
                             offset=start)
        rows = np.concatenate([rows, np.zeros(stride * count - rows.shape[0], np.uint8)])
        rows = rows.reshape(count, stride)[:, :item * ncomp].copy()
        return rows.view(np.dtype(dtype).newbyteorder("<")).astype(np.float64)

    def accessor(self, i):
        a = self.doc["accessors"][i]
        ct, n, count = a["componentType"], _N[a["type"]], a["count"]
        if "bufferView" in a:
            out = self._view(a["bufferView"], a.get("byteOffset", 0), _DT[ct], count, n)
        else:
            out = np.zeros((count, n))
        if "sparse" in a:
            sp = a["sparse"]
            ix = self._view(sp["indices"]["bufferView"], sp["indices"].get("byteOffset", 0),
                            _DT[sp["indices"]["componentType"]], sp["count"], 1)[:, 0]
            out[ix.astype(int)] = self._view(sp["values"]["bufferView"],
                                             sp["values"].get("byteOffset", 0), _DT[ct],
                                             sp["count"], n)
        if ct != 5126 and a.get("normalized"):
            out = np.maximum(out / _NORM[ct], -1.0)
        return out


def _slerp(a, b, u):
    """Row-wise slerp of unit quaternions (T, 4) along the shorter arc."""
    d = np.sum(a * b, axis=1)
    b = np.where(d[:, None] < 0, -b, b)
    d = np.abs(d)
    th = np.arccos(np.minimum(d, 1.0))
    small = d > 0.9999999
    sth = np.where(small, 1.0, np.sin(th))
    wa = np.where(small, 1 - u, np.sin((1 - u) * th) / sth)
    wb = np.where(small, u, np.sin(u * th) / sth)
    q = wa[:, None] * a + wb[:, None] * b
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _sample(keys, vals, mode, t, rot):
    """A sampler at the times t (T,), held outside its keys."""
    K = len(keys)
    cubic = mode == "CUBICSPLINE"
    if cubic:
        vals = vals.reshape(K, 3, -1)
        value = vals[:, 1]
    else:
        value = vals
        if rot:  # quantized keys are unit only to their precision: normalized first
            value = value / np.linalg.norm(value, axis=1, keepdims=True)
    if K == 1:
        out = np.repeat(value[:1], len(t), axis=0)
    else:
        i = np.clip(np.searchsorted(keys, t, side="right") - 1, 0, K - 2)
        td = keys[i + 1] - keys[i]
        u = np.clip((t - keys[i]) / td, 0.0, 1.0)
        if mode == "STEP":
            out = np.where((t >= keys[i + 1])[:, None], value[i + 1], value[i])
        elif cubic:
            c = [(2 * u**3 - 3 * u**2 + 1), td * (u**3 - 2 * u**2 + u), (-2 * u**3 + 3 * u**2),
                 td * (u**3 - u**2)]
            out = (c[0][:, None] * value[i] + c[1][:, None] * vals[i, 2]
                   + c[2][:, None] * value[i + 1] + c[3][:, None] * vals[i + 1, 0])
        elif rot:
            out = _slerp(value[i], value[i + 1], u)
        else:
            out = value[i] + u[:, None] * (value[i + 1] - value[i])
    if rot:
        out = out / np.linalg.norm(out, axis=1, keepdims=True)
    return out


def _matrices(t, q, s):
    """(T, 4, 4) transforms of translations, scalar-last rotations and scales (T, 3/4/3)."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    M = np.zeros((len(t), 4, 4))
    M[:, 0, 0], M[:, 0, 1], M[:, 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), \
        2 * (x * z + w * y)
    M[:, 1, 0], M[:, 1, 1], M[:, 1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), \
        2 * (y * z - w * x)
    M[:, 2, 0], M[:, 2, 1], M[:, 2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), \
        1 - 2 * (x * x + y * y)
    M[:, :3, :3] *= s[:, None, :]
    M[:, :3, 3] = t
    M[:, 3, 3] = 1.0
    return M


def key_times(g: Gltf, animation: int = 0) -> np.ndarray:
    an = g.doc["animations"][animation]
    return np.unique(np.concatenate([g.accessor(s["input"])[:, 0] for s in an["samplers"]]))


def world_positions(g: Gltf, times, animation: int = 0, nodes=None) -> dict:
    """{node: (T, 3) world positions} of the given nodes (default all) at the given times."""
    doc = g.doc
    times = np.asarray(times, dtype=np.float64)
    T = len(times)
    tracks = {}
    if doc.get("animations"):
        an = doc["animations"][animation]
        for ch in an["channels"]:
            s = an["samplers"][ch["sampler"]]
            tracks[(ch["target"]["node"], ch["target"]["path"])] = (
                g.accessor(s["input"])[:, 0], g.accessor(s["output"]),
                s.get("interpolation", "LINEAR"))
    local = {}

    def loc(i):
        if i in local:
            return local[i]
        nd = doc["nodes"][i]
        if "matrix" in nd:
            local[i] = np.broadcast_to(np.asarray(nd["matrix"], dtype=np.float64)
                                       .reshape(4, 4).T, (T, 4, 4))
            return local[i]
        trs = []
        for p, default in (("translation", [0, 0, 0]), ("rotation", [0, 0, 0, 1]),
                           ("scale", [1, 1, 1])):
            if (i, p) in tracks:
                keys, vals, mode = tracks[(i, p)]
                trs.append(_sample(keys, vals, mode, times, p == "rotation"))
            else:
                v = np.asarray(nd.get(p, default), dtype=np.float64)
                trs.append(np.broadcast_to(v, (T, len(v))))
        local[i] = _matrices(*trs)
        return local[i]
    world = {}

    def w(i):
        if i not in world:
            p = g.parent.get(i)
            world[i] = loc(i) if p is None else np.matmul(w(p), loc(i))
        return world[i]
    nodes = range(len(doc["nodes"])) if nodes is None else nodes
    return {n: w(n)[:, :3, 3].copy() for n in nodes}
