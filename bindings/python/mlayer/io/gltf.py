"""glTF 2.0 files: write a :class:`~mlayer.Motion` as a skinned skeleton with one animation, and
read the skeletal animations of glTF files back into Motions.

What :func:`write_gltf` writes (``.glb``: binary; ``.gltf``: JSON with the buffer embedded as a
base64 ``data:`` URI, so the file stands alone and is replaced atomically; use ``.glb`` for the
smaller file, about 3/4 of the size):

- one node per joint, in the motion's joint order (node ``j`` is joint ``j``), children as in
  the skeleton, one root node (the skeleton's root); the node's translation is the joint's
  OFFSET (the root's: its position in the first frame) and its rotation the identity: the rest
  pose, which is also the bind pose;
- one leaf node per BVH End Site (named ``"Joint/End"``, as :func:`mlayer.find_point` names
  them), not a joint of the skin;
- a skin over the joints with inverse bind matrices (the inverse rest-pose world transforms);
- by default (``mesh=True``) a small skinned mesh of "bones" (an octahedron from each joint to
  each child and End Site, rigidly bound to the joint), because a skin is only meaningful with
  a mesh: glTF lets a skin be used only by a node with a mesh, and viewers show nothing of a
  skeleton alone. It sits on a second root node of the scene (the glTF rule for skinned meshes:
  their node's own transform is ignored, so it is kept at the root). ``mesh=False`` leaves it
  out; the skin is then unused (the Khronos validator reports it as an info, UNUSED_OBJECT);
- one animation: a rotation channel for every joint with rotation channels and a translation
  channel for the root and for the joints with position channels, LINEAR, at the frame times
  ``k * frame_time`` (k = 0 .. N-1);
- Y-up metres, as glTF requires: the clip is turned from its up axis (:attr:`Motion.up_axis`,
  or ``up=``) to +Y by a proper rotation and scaled from its units (:attr:`Motion.units`, or
  ``units=``) to metres;
- ``animations[0].extras.mlayer``: the exact frame time, the BVH channel layout (so that
  BVH -> glTF -> BVH keeps the Euler orders) and the source frame (up axis, unit).

glTF stores these numbers as float32, so a round trip is exact up to float32: offsets and
translations to about 6e-8 relative, rotations to about 1e-7 rad.

:func:`read_gltf` reads one animation of any glTF 2.0 file: the joints of the skin it animates
(or, without a skin, the tree of the nodes it animates), sampled at its keyframe times when
those are uniform (the frame rate follows from them), else resampled (``fps=`` forces a
resampling): LINEAR translations by linear interpolation, rotations by slerp, STEP by holding,
CUBICSPLINE by its Hermite curve. Static transforms above the skeleton (an "Armature" node
turning a Z-up rig, scaling centimetres) are folded into the root; uniform static scales on the
joints are folded into the offsets. A scale is uniform and static when each of its components,
at every key, is within :data:`SCALE_TOLERANCE` (1e-3, relative) of their mean, which is the
factor folded in: exporters write float32 noise there (Khronos' BrainStem.glb has node scales
from 0.999999 to 1.00002), and 0.1% is a millimetre on a metre-long bone, below what motion
capture resolves and far below an intended squash or stretch. A non-uniform or animated scale
beyond it is refused (:class:`~mlayer.UnsupportedError`): a Motion has no scale. Every problem
with the file is a :class:`~mlayer.ParseError` naming the file and the reason.
"""
from __future__ import annotations

import base64
import binascii
import json
import math
import os
import stat
import struct
import urllib.parse
import warnings
from typing import Any

import numpy as np

from .._files import atomic_output
from .._version import __version__
from ..errors import (InvalidArgumentError, MlayerIOError, MlayerWarning, ParseError,
                      UnsupportedError)
from ..model import quat
from ..model.motion import (DEFAULT_JOINT_CHANNELS, DEFAULT_ROOT_CHANNELS, MAX_FRAME_TIME,
                            MIN_FRAME_TIME, Motion, Skeleton)
from ..model.units import UNITS, units_arg
from ..model.up_axis import axis_name

__all__ = ["write_gltf", "read_gltf", "gltf_bytes", "reframe"]

_GLB_MAGIC = b"glTF"
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942
_FLOAT, _UBYTE, _USHORT, _UINT = 5126, 5121, 5123, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_TRANS_CHANNELS = "Xposition Yposition Zposition Zrotation Yrotation Xrotation"
_MAX_FRAMES = 50_000_000  # frames read_gltf resamples to at most (fps=)
MAX_BYTES = 1 << 30
#: how far (relative to their mean) the components and keys of a node's scale may spread and
#: still be read as one uniform, static factor: float32 noise of exporters passes, a real
#: non-uniform or animated scale does not (see the module's doc)
SCALE_TOLERANCE = 1e-3
"""The default ``max_bytes`` of :func:`read_gltf`."""
_FRAME_BYTES = 112  # per frame and joint: sampled rotation and translation, the Motion's copies
_MAX_VALUES = 1 << 27  # values of an accessor without a bufferView (zeros, sparse) at most

# Signed permutation matrices of the proper rotations taking each up axis to +Y (as
# mlayer.model.up_axis.to_y_up): Z-up: (x, y, z) -> (x, z, -y); X-up: (x, y, z) -> (-y, x, z).
_TO_Y = {"y": np.eye(3),
         "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
         "x": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])}


# ---- the frame: up axis and units ------------------------------------------------------------

def reframe(motion: Motion, rotation: np.ndarray, scale: float) -> Motion:
    """The motion seen in another frame: every position multiplied by ``scale * rotation``.

    Parameters
    ----------
    motion : Motion
        The clip.
    rotation : numpy.ndarray
        (3, 3) signed permutation matrix with determinant +1 (a quarter-turn rotation, such as
        the ones from an up axis to +Y); being a permutation, it changes no digit.
    scale : float
        Length factor (e.g. 0.01 from centimetres to metres), finite and > 0.

    Returns
    -------
    Motion
        Offsets, End Site offsets, root positions and position channels turned and scaled;
        local rotations conjugated by the rotation (their vector part turned), so that the world
        positions are ``scale * rotation @ motion.positions()``. The up axis and units of the
        result are not set.

    Raises
    ------
    InvalidArgumentError
        When ``rotation`` is not a signed permutation of determinant +1 or ``scale`` is not a
        finite positive number.
    """
    sk, root_pos, rot, trans = _reframed(motion, rotation, scale)
    if rot is motion.rot:
        rot = rot.copy()
    return Motion(sk, motion.frame_time, root_pos.copy() if root_pos is motion.root_pos
                  else root_pos, rot, trans.copy() if trans is motion.trans else trans,
                  _trusted=True)


def _reframed(motion: Motion, rotation: np.ndarray,
              scale: float) -> tuple[Skeleton, np.ndarray, np.ndarray, np.ndarray]:
    """reframe's skeleton and frames (root_pos, rot, trans), the input's own arrays where
    nothing changes them (the rotations for a Y-up clip)."""
    M = np.asarray(rotation, dtype=np.float64)
    if M.shape != (3, 3) or not np.array_equal(np.abs(M).sum(axis=0), np.ones(3)) or \
            not np.array_equal(np.abs(M).sum(axis=1), np.ones(3)) or \
            not np.all(np.isin(M, (-1.0, 0.0, 1.0))) or round(np.linalg.det(M)) != 1:
        raise InvalidArgumentError("reframe: rotation must be a 3x3 signed permutation matrix "
                                   "with determinant +1")
    if not (isinstance(scale, (int, float, np.floating)) and math.isfinite(scale) and scale > 0):
        raise InvalidArgumentError(f"reframe: scale must be finite and > 0, got {scale!r}")
    s = float(scale)
    sk = motion.skeleton
    root_pos, rot, trans = motion._frames(finite=True)
    identity = np.array_equal(M, np.eye(3))
    perm = np.argmax(np.abs(M), axis=1)  # v' = sign * v[perm]: no arithmetic but the scale
    sign = M[np.arange(3), perm]

    def turn(v: np.ndarray) -> np.ndarray:
        if identity:
            return v * s if s != 1.0 else v
        return v[..., perm] * (sign * s)

    new_sk = Skeleton(sk.joint_names, sk.parents, turn(sk.offsets), list(sk.channels),
                      sk.end_site_parents, turn(sk.end_site_offsets))
    if not identity:
        r = np.empty_like(rot)
        r[..., 0] = rot[..., 0]
        r[..., 1:] = rot[..., 1 + perm] * sign
        rot = r
    return new_sk, turn(root_pos), rot, turn(trans)


def _source_frame(motion: Motion, up: str | None,
                  units: str | None) -> tuple[str, str | None, float]:
    """The clip's up axis and unit (given or the motion's) and its size in metres."""
    up = axis_name(up, "mlayer.write_gltf") or motion.up_axis
    units = units_arg(units, "mlayer.write_gltf") or motion.units
    if units is None:
        warnings.warn("mlayer.write_gltf: the clip's length unit is unknown (its body height "
                      "suggests none); written as metres unchanged; pass units= to convert",
                      MlayerWarning, stacklevel=3)
        return up, None, 1.0
    return up, units, UNITS[units]


# ---- writing ---------------------------------------------------------------------------------

class _Bin:
    """The binary buffer being built: bufferViews (4-byte aligned) and accessors."""

    def __init__(self) -> None:
        self.parts: list[Any] = []  # bytes and C-contiguous numpy arrays, written as they are
        self.size = 0
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def view(self, data: np.ndarray, target: int | None = None) -> int:
        data = np.ascontiguousarray(data)
        v: dict[str, Any] = {"buffer": 0, "byteOffset": self.size, "byteLength": data.nbytes}
        if target is not None:
            v["target"] = target
        self.parts.append(data)
        self.size += data.nbytes
        pad = (-self.size) % 4
        if pad:
            self.parts.append(b"\0" * pad)
            self.size += pad
        self.views.append(v)
        return len(self.views) - 1

    def accessor(self, view: int, offset: int, ctype: int, count: int, atype: str,
                 minmax: np.ndarray | None = None) -> int:
        a: dict[str, Any] = {"bufferView": view, "componentType": ctype, "count": int(count),
                             "type": atype}
        if offset:
            a["byteOffset"] = int(offset)
        if minmax is not None:
            a["min"] = [float(x) if ctype == _FLOAT else int(x) for x in minmax.min(axis=0)]
            a["max"] = [float(x) if ctype == _FLOAT else int(x) for x in minmax.max(axis=0)]
        self.accessors.append(a)
        return len(self.accessors) - 1

    def data(self) -> bytes:
        return b"".join(p.data.cast("B") if isinstance(p, np.ndarray) else p
                        for p in self.parts)


def _bones(rest: np.ndarray, tails: list[tuple[int, np.ndarray]], size: float
           ) -> Any:
    """The bones mesh: an octahedron from each joint to each child / End Site (rest pose):
    positions (V, 3) float32, the joint of each vertex (V,), triangle indices (3T,)."""
    par = np.array([p for p, _ in tails], dtype=np.int64)
    head = rest[par]
    tail = np.array([t for _, t in tails])
    d = tail - head
    L = np.linalg.norm(d, axis=1)
    keep = L > 1e-4 * size  # a zero-length bone (CMU's hip and shoulder joints) draws nothing
    if not keep.any():
        return None
    par, head, tail, d, L = par[keep], head[keep], tail[keep], d[keep], L[keep]
    d = d / L[:, None]
    a = np.where((np.abs(d[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(d, a)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(d, u)
    r = (0.08 * L)[:, None]
    mid = head + (0.15 * L)[:, None] * d
    verts = np.stack([head, mid + r * u, mid + r * v, mid - r * u, mid - r * v, tail],
                     axis=1)  # (B, 6, 3)
    B = par.shape[0]
    ring = np.array([[0, 2, 1], [0, 3, 2], [0, 4, 3], [0, 1, 4],
                     [5, 1, 2], [5, 2, 3], [5, 3, 4], [5, 4, 1]], dtype=np.int64)
    tris = (np.arange(B)[:, None, None] * 6 + ring[None]).reshape(-1)
    return verts.reshape(-1, 3).astype(np.float32), np.repeat(par, 6), tris


def gltf_bytes(motion: Motion, *, binary: bool = True, up: str | None = None,
               units: str | None = None, mesh: bool = True) -> bytes:
    """The glTF 2.0 file of ``motion`` as bytes (what :func:`write_gltf` writes).

    Parameters
    ----------
    motion : Motion
        The clip.
    binary : bool
        True: GLB; False: glTF JSON with the buffer as a base64 ``data:`` URI.
    up, units, mesh
        As for :func:`write_gltf`.

    Returns
    -------
    bytes
        The file's contents.

    Raises
    ------
    InvalidArgumentError
        For a motion with non-finite values, or bad ``up`` / ``units``.
    """
    return b"".join(p.data.cast("B") if isinstance(p, np.ndarray) else p
                    for p in _gltf_parts(motion, binary, up, units, mesh))


def _gltf_parts(motion: Motion, binary: bool, up: str | None, units: str | None,
                mesh: bool) -> list:
    """The file as a list of buffers (bytes, numpy arrays) to write one after the other: the
    frames are not copied into one block first."""
    if not isinstance(motion, Motion):
        raise TypeError(f"write_gltf: expected a mlayer.Motion, got {type(motion).__name__}")
    up, units, mpu = _source_frame(motion, up, units)
    sk, root_pos, rot, trans = _reframed(motion, _TO_Y[up], mpu)
    J, E, N = sk.n_joints, sk.n_end_sites, rot.shape[0]
    frame_time = motion.frame_time
    names = sk.joint_names
    root0 = root_pos[0] if N else sk.offsets[0]
    # the rest pose (identity rotations; the root where the first frame has it): the bind pose
    rest_m = Motion(sk, frame_time, root0[None].copy(), np.tile([1.0, 0.0, 0.0, 0.0], (1, J, 1)),
                    np.broadcast_to(sk.offsets[sk.trans_joints], (1, len(sk.trans_joints), 3))
                    .copy(), _trusted=True)
    rest, wrot = rest_m.forward_kinematics()
    rest_end = rest_m._end_sites(rest, wrot)[0]
    rest = rest[0]
    b = _Bin()
    nodes: list[dict] = []
    for j in range(J):
        t = root0 if j == 0 else sk.offsets[j]
        node: dict[str, Any] = {"name": names[j]}
        if np.any(t):
            node["translation"] = [float(x) for x in t]
        nodes.append(node)
    for e in range(E):
        p = int(sk.end_site_parents[e])
        node = {"name": f"{names[p]}/End"}
        if np.any(sk.end_site_offsets[e]):
            node["translation"] = [float(x) for x in sk.end_site_offsets[e]]
        nodes.append(node)
    for j in range(1, J):
        nodes[int(sk.parents[j])].setdefault("children", []).append(j)
    for e in range(E):
        nodes[int(sk.end_site_parents[e])].setdefault("children", []).append(J + e)
    # inverse bind matrices: the inverse of each joint's rest world transform (a translation)
    ibm = np.tile(np.eye(4, dtype=np.float32), (J, 1, 1))
    ibm[:, 3, :3] = -rest.astype(np.float32)  # column-major: the translation is column 3
    ibm_acc = b.accessor(b.view(ibm), 0, _FLOAT, J, "MAT4")
    skin: dict[str, Any] = {"name": "skeleton", "joints": list(range(J)),
                            "inverseBindMatrices": ibm_acc, "skeleton": 0}
    doc: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": f"mlayer {__version__}"},
        "scene": 0, "scenes": [{"name": "mlayer", "nodes": [0]}],
        "nodes": nodes, "skins": [skin]}
    if mesh:
        tails = [(int(sk.parents[j]), rest[j]) for j in range(1, J)] + \
                [(int(sk.end_site_parents[e]), rest_end[e]) for e in range(E)]
        ext = np.concatenate([rest, rest_end]) if E else rest
        size = float(np.max(ext.max(axis=0) - ext.min(axis=0))) if J > 1 or E else 0.0
        bones = _bones(rest, tails, size) if size > 0 else None
        if bones is not None:
            pos, vj, idx = bones
            V = pos.shape[0]
            jt, jtype = (np.uint8, _UBYTE) if J <= 256 else (np.uint16, _USHORT)
            joints = np.zeros((V, 4), dtype=jt)
            joints[:, 0] = vj
            weights = np.zeros((V, 4), dtype=np.float32)
            weights[:, 0] = 1.0
            it, itype = (np.uint16, _USHORT) if V < 65535 else (np.uint32, _UINT)
            a_pos = b.accessor(b.view(pos, _ARRAY_BUFFER), 0, _FLOAT, V, "VEC3", pos)
            a_j = b.accessor(b.view(joints, _ARRAY_BUFFER), 0, jtype, V, "VEC4")
            a_w = b.accessor(b.view(weights, _ARRAY_BUFFER), 0, _FLOAT, V, "VEC4")
            a_i = b.accessor(b.view(idx.astype(it), _ELEMENT_ARRAY_BUFFER), 0, itype,
                             idx.shape[0], "SCALAR")
            doc["meshes"] = [{"name": "bones", "primitives": [{
                "attributes": {"POSITION": a_pos, "JOINTS_0": a_j, "WEIGHTS_0": a_w},
                "indices": a_i, "material": 0}]}]
            doc["materials"] = [{"name": "bone", "doubleSided": True, "pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0,
                "roughnessFactor": 0.8}}]
            nodes.append({"name": "bones", "mesh": 0, "skin": 0})
            doc["scenes"][0]["nodes"].append(len(nodes) - 1)
    if N:
        times = (np.arange(N, dtype=np.float64) * frame_time).astype(np.float32)
        a_t = b.accessor(b.view(times), 0, _FLOAT, N, "SCALAR", times[:, None])
        rot_j = [j for j in range(J) if j == 0 or "rotation" in sk.channels[j]]
        tr_j = [0] + [int(j) for j in sk.trans_joints]
        # consecutive keys on the short arc, as float32 first (a contiguous cast), then one
        # track per joint, x y z w (strided float32 copies: 8x faster than from float64)
        q32 = quat.continuous(rot).astype(np.float32)
        if len(rot_j) < J:
            q32 = q32[:, rot_j]
        qt = q32.transpose(1, 0, 2)
        q = np.empty((len(rot_j), N, 4), dtype=np.float32)
        q[:, :, :3] = qt[:, :, 1:]
        q[:, :, 3] = qt[:, :, 0]
        tr = np.empty((len(tr_j), N, 3), dtype=np.float32)
        tr[0] = root_pos
        if len(tr_j) > 1:
            tr[1:] = trans.astype(np.float32).transpose(1, 0, 2)
        v_q, v_t = b.view(q), b.view(tr)
        samplers, channels = [], []
        for k, j in enumerate(tr_j):
            a = b.accessor(v_t, k * N * 12, _FLOAT, N, "VEC3")
            samplers.append({"input": a_t, "output": a, "interpolation": "LINEAR"})
            channels.append({"sampler": len(samplers) - 1,
                             "target": {"node": j, "path": "translation"}})
        for k, j in enumerate(rot_j):
            a = b.accessor(v_q, k * N * 16, _FLOAT, N, "VEC4")
            samplers.append({"input": a_t, "output": a, "interpolation": "LINEAR"})
            channels.append({"sampler": len(samplers) - 1,
                             "target": {"node": j, "path": "rotation"}})
        doc["animations"] = [{"name": "motion", "samplers": samplers, "channels": channels,
                              "extras": {"mlayer": {
                                  "frame_time": frame_time, "channels": list(sk.channels),
                                  "source_up": up, "source_units": units,
                                  "metres_per_unit": mpu}}}]
    doc["bufferViews"], doc["accessors"] = b.views, b.accessors
    if binary:
        doc["buffers"] = [{"byteLength": b.size}]
        js = json.dumps(doc, separators=(",", ":"), allow_nan=False).encode("utf-8")
        js += b" " * ((-len(js)) % 4)
        total = 12 + 8 + len(js) + 8 + b.size
        return [struct.pack("<4sII", _GLB_MAGIC, 2, total),
                struct.pack("<II", len(js), _CHUNK_JSON), js,
                struct.pack("<II", b.size, _CHUNK_BIN), *b.parts]
    doc["buffers"] = [{"byteLength": b.size, "uri": "data:application/octet-stream;base64,"
                       + base64.b64encode(b.data()).decode("ascii")}]
    return [json.dumps(doc, separators=(",", ":"), allow_nan=False).encode("utf-8")]


def write_gltf(motion: Motion, path: str | os.PathLike[str], *, up: str | None = None,
               units: str | None = None, mesh: bool = True) -> None:
    """Write ``motion`` as a glTF 2.0 file, atomically (the old file, if any, stays intact when
    writing fails).

    Parameters
    ----------
    motion : Motion
        The clip.
    path : str or os.PathLike
        Ends in ``.glb`` (binary glTF) or ``.gltf`` (JSON with the buffer embedded as base64).
    up : {"x", "y", "z"} or None
        The clip's up axis (default: :attr:`Motion.up_axis`); the file is turned to Y-up.
    units : {"m", "cm", "mm", "in", "ft"} or None
        The clip's length unit (default: :attr:`Motion.units`); the file is in metres. When
        neither says (CMU's converted files), the values are written unchanged with a
        :class:`~mlayer.MlayerWarning`.
    mesh : bool
        Add the skinned "bones" mesh (default), so that viewers show the skeleton.

    Raises
    ------
    InvalidArgumentError
        For another extension, a motion with non-finite values, bad ``up`` / ``units``.
    MlayerIOError
        When the file cannot be written.

    See the module docstring for what the file holds.
    """
    path = os.fspath(path)
    ext = os.path.splitext(os.fsdecode(path))[1].lower()
    if ext not in (".glb", ".gltf"):
        raise InvalidArgumentError(f"mlayer.write_gltf: {os.fsdecode(path)}: the path must end "
                                   "in .glb or .gltf")
    parts = _gltf_parts(motion, ext == ".glb", up, units, mesh)
    try:
        with atomic_output(path) as tmp, open(tmp, "wb") as f:
            for p in parts:
                f.write(p)
    except OSError as e:
        raise MlayerIOError(f"mlayer.write_gltf({os.fsdecode(path)}): {e.strerror or e}") from e


# ---- reading: the container ------------------------------------------------------------------

class _Bad(Exception):
    """A reason the file is not usable (turned into ParseError with the file name)."""


def _need(cond: bool, reason: str) -> None:
    if not cond:
        raise _Bad(reason)


def _index(obj: dict, key: str, n: int, where: str, required: bool = True) -> Any:
    """obj[key] as an index into a list of n items."""
    v = obj.get(key)
    if v is None:
        _need(not required, f"{where} has no {key}")
        return None
    _need(isinstance(v, int) and not isinstance(v, bool) and 0 <= v < n,
          f"{where}.{key} = {v!r} is not an index of the {n} items it refers to")
    return v


def _list(doc: dict, key: str) -> list:
    v = doc.get(key, [])
    _need(isinstance(v, list) and all(isinstance(x, dict) for x in v),
          f"'{key}' is not a list of objects")
    return v


def _container(data: bytes) -> tuple[dict, memoryview | None]:
    """The JSON document and the GLB BIN chunk (None for a .gltf)."""
    if data[:4] == _GLB_MAGIC:
        _need(len(data) >= 20, f"truncated GLB: {len(data)} bytes, not even a header and chunk")
        _, version, length = struct.unpack_from("<4sII", data, 0)
        _need(version == 2, f"GLB version {version}: only glTF 2.0 is read")
        _need(length <= len(data), f"truncated GLB: the header says {length} bytes, the file "
                                   f"has {len(data)}")
        pos = 12
        js: memoryview | None = None
        binary: memoryview | None = None
        while pos + 8 <= length:
            clen, ctype = struct.unpack_from("<II", data, pos)
            _need(pos + 8 + clen <= length, f"truncated GLB: a chunk of {clen} bytes at byte "
                                            f"{pos} runs past the end ({length} bytes)")
            chunk = memoryview(data)[pos + 8: pos + 8 + clen]  # no copy of the BIN chunk
            if js is None:
                _need(ctype == _CHUNK_JSON, "GLB: the first chunk is not JSON")
                js = chunk
            elif ctype == _CHUNK_BIN and binary is None:
                binary = chunk
            pos += 8 + clen + ((-clen) % 4 if pos + 8 + clen < length else 0)
        if js is None:
            raise _Bad("GLB without a JSON chunk")
        text: bytes | memoryview = js
    else:
        text, binary = data, None
    try:
        doc = json.loads(bytes(text).decode("utf-8-sig"))
    except UnicodeDecodeError as e:
        raise _Bad(f"not glTF: neither a GLB nor UTF-8 JSON ({e.reason} at byte "
                   f"{e.start})") from None
    except json.JSONDecodeError as e:
        raise _Bad(f"broken JSON at line {e.lineno} column {e.colno}: {e.msg}") from None
    except RecursionError:
        raise _Bad("JSON nested too deep (no glTF document nests more than a few levels)") \
            from None
    _need(isinstance(doc, dict), "the JSON is not an object: not a glTF document")
    asset = doc.get("asset")
    _need(isinstance(asset, dict) and isinstance(asset.get("version"), str),
          "no asset.version: not a glTF document")
    _need(asset["version"].split(".")[0] == "2",
          f"glTF version {asset['version']}: only glTF 2.x is read")
    return doc, binary


class _Data:
    """Buffers (loaded on first use) and typed accessor reads."""

    _COMP = {5120: (np.int8, 127.0), 5121: (np.uint8, 255.0), 5122: (np.int16, 32767.0),
             5123: (np.uint16, 65535.0), 5125: (np.uint32, None), 5126: (np.float32, None)}
    _NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}

    def __init__(self, doc: dict, binary: memoryview | None, directory: str | None) -> None:
        self.doc, self.binary, self.dir = doc, binary, directory
        self.buffers = _list(doc, "buffers")
        self.views = _list(doc, "bufferViews")
        self.accessors = _list(doc, "accessors")
        self.cache: dict[int, bytes | memoryview] = {}

    def buffer(self, i: int) -> bytes | memoryview:
        if i in self.cache:
            return self.cache[i]
        b = self.buffers[i]
        uri = b.get("uri")
        data: bytes | memoryview
        if uri is None:
            if i != 0 or self.binary is None:
                raise _Bad(f"buffers[{i}] has no uri and there is no GLB BIN chunk")
            data = self.binary
        else:
            _need(isinstance(uri, str), f"buffers[{i}].uri is not a string")
            if uri.startswith("data:"):
                head, sep, payload = uri.partition(",")
                _need(bool(sep) and head.endswith(";base64"),
                      f"buffers[{i}]: a data: URI that is not base64")
                try:
                    data = base64.b64decode(payload, validate=True)
                except (binascii.Error, ValueError) as e:
                    raise _Bad(f"buffers[{i}]: broken base64 ({e})") from None
            else:
                data = self._external(i, uri, b.get("byteLength"))
        n = b.get("byteLength")
        _need(isinstance(n, int) and not isinstance(n, bool) and n >= 0,
              f"buffers[{i}].byteLength is missing or not a count")
        _need(len(data) >= n, f"buffers[{i}] is truncated: byteLength {n}, {len(data)} bytes "
                              "present")
        self.cache[i] = data
        return data

    def _external(self, i: int, uri: str, n: Any) -> bytes:
        """buffers[i]'s file: only a regular file inside the glTF's own folder (after
        URL-decoding and resolving symlinks: no "..", no absolute path, no device, FIFO or link
        leading out), only its first byteLength bytes read, after its size was checked."""
        rel = urllib.parse.unquote(uri)
        where = f"buffers[{i}].uri {uri!r}"
        if (self.dir is None or "://" in rel or "\0" in rel or os.path.isabs(rel) or
                rel.startswith(("/", "\\")) or ".." in rel.replace("\\", "/").split("/")):
            raise _Bad(f"{where}: only data: URIs and files inside the glTF file's folder are "
                       "read")
        _need(isinstance(n, int) and not isinstance(n, bool) and n >= 0,
              f"buffers[{i}].byteLength is missing or not a count")
        folder = os.path.realpath(self.dir)
        full = os.path.realpath(os.path.join(folder, rel))
        if os.path.commonpath([folder, full]) != folder:
            raise _Bad(f"{where} leads outside the glTF file's folder (through a link)")
        try:
            # O_NONBLOCK: a FIFO does not hang the open; fstat then refuses it
            fd = os.open(full, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) |
                         getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0))
        except OSError as e:
            raise _Bad(f"buffers[{i}]: cannot read {rel}: {e.strerror or e}") from None
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):  # a folder, a device, a FIFO: before fdopen reads it
            os.close(fd)
            raise _Bad(f"{where} is not a regular file")
        with os.fdopen(fd, "rb") as f:
            _need(st.st_size >= n, f"buffers[{i}] is truncated: byteLength {n}, {st.st_size} "
                                   f"bytes in {rel}")
            data = f.read(n)
        _need(len(data) == n, f"buffers[{i}]: {rel} shrank while it was read")
        return data

    def _raw(self, view_i: int, offset: int, dtype: Any, count: int, ncomp: int,
             where: str) -> np.ndarray:
        v = self.views[view_i]
        bi = _index(v, "buffer", len(self.buffers), f"bufferViews[{view_i}]")
        _need(not v.get("extensions", {}).keys() & {"EXT_meshopt_compression",
                                                    "KHR_meshopt_compression"},
              f"bufferViews[{view_i}] is meshopt-compressed: not supported")
        buf = self.buffer(bi)
        vo, vl = v.get("byteOffset", 0), v.get("byteLength")
        _need(isinstance(vo, int) and isinstance(vl, int) and vo >= 0 and vl >= 0 and
              vo + vl <= len(buf), f"bufferViews[{view_i}] lies outside its buffer")
        esize = np.dtype(dtype).itemsize * ncomp
        stride = v.get("byteStride") or esize
        _need(isinstance(stride, int) and stride >= esize,
              f"bufferViews[{view_i}].byteStride {stride!r} is smaller than an element")
        _need(isinstance(offset, int) and offset >= 0, f"{where}.byteOffset is not a count")
        _need(offset + stride * (count - 1) + esize <= vl if count else True,
              f"{where}: {count} elements do not fit in bufferViews[{view_i}] "
              f"({vl} bytes)")
        _need((vo + offset) % np.dtype(dtype).itemsize == 0, f"{where} is not aligned")
        return np.ndarray((count, ncomp), dtype=np.dtype(dtype).newbyteorder("<"), buffer=buf,
                          offset=vo + offset, strides=(stride, np.dtype(dtype).itemsize))

    def read(self, i: int, where: str, types: tuple, floats_only: bool = True) -> np.ndarray:
        """Accessor i as float64 (count, ncomp); normalized integers dequantized."""
        a = self.accessors[i]
        where = f"{where} (accessors[{i}])"
        atype, ctype, count = a.get("type"), a.get("componentType"), a.get("count")
        _need(atype in types, f"{where} has type {atype!r}, expected {' or '.join(types)}")
        _need(ctype in self._COMP, f"{where} has componentType {ctype!r}: not a glTF type")
        _need(isinstance(count, int) and not isinstance(count, bool) and count >= 1,
              f"{where}.count {count!r} is not a positive count")
        dtype, norm = self._COMP[ctype]
        normalized = bool(a.get("normalized", False))
        _need(ctype == _FLOAT or (not floats_only and normalized and norm is not None),
              f"{where} has componentType {ctype}: expected float (5126)"
              + ("" if floats_only else " or normalized integers"))
        ncomp = self._NCOMP[atype]
        if a.get("bufferView") is not None:
            vi = _index(a, "bufferView", len(self.views), where)
            out = self._raw(vi, a.get("byteOffset", 0), dtype, count, ncomp, where)
        else:
            _need(count * ncomp <= _MAX_VALUES, f"{where}: {count} elements without a "
                                                "bufferView: too many")
            out = np.zeros((count, ncomp), dtype=dtype)
        sp = a.get("sparse")
        if sp is not None:
            out = out.copy()  # a view of the file until here
            _need(isinstance(sp, dict), f"{where}.sparse is not an object")
            n = sp.get("count")
            _need(isinstance(n, int) and 1 <= n <= count, f"{where}.sparse.count is bad")
            ix, vals = sp.get("indices"), sp.get("values")
            _need(isinstance(ix, dict) and isinstance(vals, dict),
                  f"{where}.sparse needs indices and values")
            ict = ix.get("componentType")
            _need(ict in (_UBYTE, _USHORT, _UINT), f"{where}.sparse.indices has a bad type")
            ivi = _index(ix, "bufferView", len(self.views), f"{where}.sparse.indices")
            idx = self._raw(ivi, ix.get("byteOffset", 0), self._COMP[ict][0], n, 1,
                            f"{where}.sparse.indices")[:, 0].astype(np.int64)
            _need(bool(np.all((idx >= 0) & (idx < count))),
                  f"{where}.sparse.indices out of range")
            vvi = _index(vals, "bufferView", len(self.views), f"{where}.sparse.values")
            out[idx] = self._raw(vvi, vals.get("byteOffset", 0), dtype, n, ncomp,
                                 f"{where}.sparse.values")
        out = out.astype(np.float64)
        if ctype != _FLOAT:
            out = np.maximum(out / norm, -1.0)
        _need(bool(np.all(np.isfinite(out))), f"{where} holds NaN or infinite values")
        return out


# ---- reading: the node tree and the animation ------------------------------------------------

def _quat_of_matrix(R: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion of a 3x3 rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] > R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    out = np.asarray(q)
    return out / np.linalg.norm(out)


def _rot_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _num_list(v: Any, n: int, where: str) -> np.ndarray:
    _need(isinstance(v, list) and len(v) == n and
          all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v),
          f"{where} is not a list of {n} numbers")
    a = np.asarray(v, dtype=np.float64)
    _need(bool(np.all(np.isfinite(a))), f"{where} holds non-finite values")
    return a


def _uniform_scale(s: np.ndarray, where: str) -> float:
    """The one factor of a (..., 3) scale that is uniform and constant within SCALE_TOLERANCE
    (its mean), else refuse."""
    c = float(np.mean(s))
    if not (c > 0 and np.all(np.abs(s - c) <= SCALE_TOLERANCE * c)):
        raise UnsupportedError(f"{where}: a non-uniform, animated or non-positive scale "
                               f"(from {np.min(s):.6g} to {np.max(s):.6g}, beyond "
                               f"{SCALE_TOLERANCE:g} of uniform); a mlayer Motion has no "
                               "scale, so this is not read")
    return c


def _node_trs(node: dict, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Static translation, rotation (w, x, y, z) and scale of a node (from TRS or a matrix)."""
    where = f"nodes[{i}]"
    if "matrix" in node:
        m = _num_list(node["matrix"], 16, f"{where}.matrix").reshape(4, 4).T  # column-major
        _need(np.allclose(m[3], [0, 0, 0, 1]), f"{where}.matrix is not an affine transform")
        A = m[:3, :3]
        s = np.linalg.norm(A, axis=0)
        _need(bool(np.all(s > 0)), f"{where}.matrix is singular")
        R = A / s
        _need(np.allclose(R.T @ R, np.eye(3), atol=1e-5) and np.linalg.det(R) > 0,
              f"{where}.matrix has a shear or a mirror: not a rotation and scale")
        return m[:3, 3].copy(), _quat_of_matrix(R), s
    t = _num_list(node["translation"], 3, f"{where}.translation") if "translation" in node \
        else np.zeros(3)
    r = _num_list(node["rotation"], 4, f"{where}.rotation")[[3, 0, 1, 2]] if "rotation" in \
        node else np.array([1.0, 0.0, 0.0, 0.0])
    n = np.linalg.norm(r)
    _need(bool(n > 0), f"{where}.rotation is a zero quaternion")
    s = _num_list(node["scale"], 3, f"{where}.scale") if "scale" in node else np.ones(3)
    return t, r / n, s


def _sample(keys: np.ndarray, values: np.ndarray, mode: str, t: np.ndarray,
            rotation: bool) -> np.ndarray:
    """A sampler's values at times t: values (K, C) at keys (K,) for LINEAR / STEP, or
    (K, 3, C) (in-tangent, value, out-tangent) for CUBICSPLINE; held before the first key and
    after the last."""
    K = keys.shape[0]
    v = values[:, 1] if mode == "CUBICSPLINE" else values
    if K == 1:
        return np.broadcast_to(v[0], (t.shape[0],) + v.shape[1:]).copy()
    if mode != "CUBICSPLINE" and (keys is t or np.array_equal(keys, t)):
        return v
    if mode == "STEP":
        return v[np.clip(np.searchsorted(keys, t, side="right") - 1, 0, K - 1)]
    i = np.clip(np.searchsorted(keys, t, side="right") - 1, 0, K - 2)
    dt = keys[i + 1] - keys[i]
    u = np.clip((t - keys[i]) / np.where(dt > 0, dt, 1.0), 0.0, 1.0)
    if mode == "LINEAR":
        if rotation:
            return quat.slerp(v[i], v[i + 1], u)
        return v[i] + (v[i + 1] - v[i]) * u[:, None]
    u2, u3 = u * u, u * u * u
    h00, h10, h01, h11 = 2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2
    out = (h00[:, None] * v[i] + (h10 * dt)[:, None] * values[i, 2]
           + h01[:, None] * v[i + 1] + (h11 * dt)[:, None] * values[i + 1, 0])
    if rotation:
        out = quat.normalize(out)
    return out


def _joint_names(nodes: list, order: list[int]) -> list[str]:
    """Node names made valid and unique as joint names."""
    out, seen = [], set()
    for i in order:
        n = nodes[i].get("name")
        n = n if isinstance(n, str) else ""
        n = "".join("_" if (ord(c) < 0x20 or c in "{}\x7f") else c for c in n).strip()
        n = n or f"node{i}"
        base, k = n, 2
        while n in seen:
            n, k = f"{base}_{k}", k + 1
        seen.add(n)
        out.append(n)
    return out


def _read_doc(doc: dict, data: _Data, animation: int, fps: float | None, name: str,
              max_bytes: int = 1 << 30) -> Motion:
    nodes = _list(doc, "nodes")
    _need(len(nodes) > 0, "no nodes: nothing to read")
    parent = [-1] * len(nodes)
    for i, nd in enumerate(nodes):
        ch = nd.get("children", [])
        _need(isinstance(ch, list), f"nodes[{i}].children is not a list")
        for c in ch:
            _need(isinstance(c, int) and not isinstance(c, bool) and 0 <= c < len(nodes),
                  f"nodes[{i}].children holds {c!r}, not a node index")
            _need(parent[c] == -1 and c != i, f"nodes[{c}] has two parents or is its own child:"
                                              " not a tree")
            parent[c] = i
    # no cycles, in linear time (each node has one parent at most: walk up from each node
    # until a node already known to reach a root; one met again on this walk closes a cycle;
    # the walk per node made a chain of 40,000 nodes take 157 s)
    state = [0] * len(nodes)  # 0 unseen, 1 on this walk, 2 reaches a root
    for i in range(len(nodes)):
        walk, a = [], i
        while a >= 0 and state[a] == 0:
            state[a] = 1
            walk.append(a)
            a = parent[a]
        _need(a < 0 or state[a] == 2, f"nodes[{i}] lies on a cycle of children: not a tree")
        for w in walk:
            state[w] = 2
    anims = _list(doc, "animations")
    _need(len(anims) > 0, "no animations: nothing to read as a motion")
    if not (isinstance(animation, int) and not isinstance(animation, bool)
            and 0 <= animation < len(anims)):
        raise InvalidArgumentError(f"mlayer.read_gltf: animation={animation!r}, but {name} has "
                                   f"{len(anims)} animation(s) (0 .. {len(anims) - 1})")
    an = anims[animation]
    aw = f"animations[{animation}]"
    samplers = an.get("samplers", [])
    channels = an.get("channels", [])
    _need(isinstance(samplers, list) and isinstance(channels, list),
          f"{aw} has no samplers or channels lists")
    tracks: dict[tuple[int, str], tuple[np.ndarray, np.ndarray, str]] = {}
    key_cache: dict[int, np.ndarray] = {}
    for c_i, ch in enumerate(channels):
        cw = f"{aw}.channels[{c_i}]"
        _need(isinstance(ch, dict) and isinstance(ch.get("target"), dict), f"{cw} has no target")
        path = ch["target"].get("path")
        if path not in ("translation", "rotation", "scale"):
            continue  # morph weights, KHR_animation_pointer: not a skeleton's
        node = _index(ch["target"], "node", len(nodes), f"{cw}.target", required=False)
        if node is None:
            continue
        s_i = _index(ch, "sampler", len(samplers), cw)
        smp = samplers[s_i]
        sw = f"{aw}.samplers[{s_i}]"
        _need(isinstance(smp, dict), f"{sw} is not an object")
        mode = smp.get("interpolation", "LINEAR")
        _need(mode in ("LINEAR", "STEP", "CUBICSPLINE"),
              f"{sw}.interpolation {mode!r}: not LINEAR, STEP or CUBICSPLINE")
        ki = _index(smp, "input", len(data.accessors), sw)
        if ki not in key_cache:  # the samplers of a clip mostly share one accessor of times
            k_ = data.read(ki, f"{sw}.input", ("SCALAR",))[:, 0]
            _need(bool(np.all(k_[1:] > k_[:-1])), f"{sw}.input: key times are not increasing")
            key_cache[ki] = k_
        keys = key_cache[ki]
        rot = path == "rotation"
        vals = data.read(_index(smp, "output", len(data.accessors), sw), f"{sw}.output",
                         ("VEC4",) if rot else ("VEC3",), floats_only=not rot)
        K = keys.shape[0]
        want = 3 * K if mode == "CUBICSPLINE" else K
        _need(vals.shape[0] == want, f"{sw}: {vals.shape[0]} output values for {K} key times "
                                     f"({mode} needs {want})")
        if rot:
            vals = vals[:, [3, 0, 1, 2]]
            if mode != "CUBICSPLINE":
                n = np.sqrt(np.einsum("ij,ij->i", vals, vals))
                _need(bool(np.all(n > 0)), f"{sw}.output holds a zero quaternion")
                vals /= n[:, None]
        if mode == "CUBICSPLINE":
            vals = vals.reshape(K, 3, -1)
        _need((node, path) not in tracks, f"{aw} animates {path} of nodes[{node}] twice")
        tracks[(node, path)] = (keys, vals, mode)
    animated = sorted({n for n, _ in tracks})
    _need(bool(animated), f"{aw} animates no node's translation, rotation or scale")

    # the joints: the skin that holds most animated nodes, else the animated nodes
    skins = _list(doc, "skins")
    best, best_n = None, 0
    for s_i, sk in enumerate(skins):
        js = sk.get("joints")
        _need(isinstance(js, list) and all(isinstance(j, int) and not isinstance(j, bool) and
                                           0 <= j < len(nodes) for j in js),
              f"skins[{s_i}].joints is not a list of node indices")
        k = len(set(js) & set(animated))
        if k > best_n:
            best, best_n = s_i, k
    members = set(animated) | (set(skins[best]["joints"]) if best is not None else set())

    def chain(i: int) -> list[int]:
        out = []
        while i >= 0:
            out.append(i)
            i = parent[i]
        return out[::-1]

    # each node's root and depth, memoized (linear in the nodes)
    top, depth_of = [-1] * len(nodes), [-1] * len(nodes)
    for i in range(len(nodes)):
        walk, a = [], i
        while a >= 0 and depth_of[a] < 0:
            walk.append(a)
            a = parent[a]
        rt, d = (top[a], depth_of[a]) if a >= 0 else (walk[-1], -1)
        for w in reversed(walk):
            d += 1
            top[w], depth_of[w] = rt, d
    tops: dict[int, list[int]] = {}
    for i in sorted(members):
        tops.setdefault(top[i], []).append(i)
    group = max(tops.values(), key=len)  # the tree with the most joints
    # the closest common root: the deepest node whose subtree holds every joint of the group
    # (the members below each node counted up the tree, deepest nodes first)
    below = [0] * len(nodes)
    for i in group:
        below[i] += 1
    for i in sorted(range(len(nodes)), key=lambda k: -depth_of[k]):
        if parent[i] >= 0 and below[i]:
            below[parent[i]] += below[i]
    common = [i for i in range(len(nodes)) if below[i] == len(group)]
    root = max(common, key=lambda k: depth_of[k])
    on_path = {i for i in range(len(nodes))
               if below[i] and top[i] == top[root] and depth_of[i] >= depth_of[root]}
    joint_set = set(group)
    while root not in joint_set:  # a static node above: folded in while it has one branch
        kids = [c for c in nodes[root].get("children", []) if c in on_path]
        if len(kids) != 1:
            break
        root = kids[0]
    order: list[int] = []
    stack = [root]
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed([c for c in nodes[i].get("children", []) if c in on_path]))
    J = len(order)
    _need(J <= 100000, f"{J} joints: too many")
    jidx = {n: k for k, n in enumerate(order)}

    # static transforms; the base: the world transform above the root (static)
    trs = {i: _node_trs(nodes[i], i) for i in order}
    Bt, Bq, Bs = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), 1.0
    for a in chain(root)[:-1]:
        t, r, s = _node_trs(nodes[a], a)
        sa = _uniform_scale(s, f"{name}: nodes[{a}] (above the skeleton)")
        Bt = Bt + Bs * (_rot_matrix(Bq) @ t)
        Bq = quat.mul(Bq, r)
        Bs = Bs * sa

    # the frame times
    key_sets = {id(tracks[(n, p)][0]): tracks[(n, p)][0] for n in order
                for p in ("translation", "rotation", "scale") if (n, p) in tracks}
    _need(bool(key_sets), f"{aw} animates none of the skeleton's nodes")
    allk = next(iter(key_sets.values())) if len(key_sets) == 1 else \
        np.unique(np.concatenate(list(key_sets.values())))
    # keys of different accessors a few float32 steps apart are one key; a key time may be
    # off its frame by as much (the uniformity test below)
    e32 = 8 * float(np.finfo(np.float32).eps)
    keep = np.concatenate([[True], np.diff(allk) > e32 * np.maximum(np.abs(allk[1:]),
                                                                    np.abs(allk[:-1]))])
    allk = allk[keep]
    tol = e32 * float(np.max(np.abs(allk)))
    extras = an.get("extras", {})
    mx = extras.get("mlayer", {}) if isinstance(extras, dict) else {}
    mx = mx if isinstance(mx, dict) else {}
    ft_hint = mx.get("frame_time")
    ft_hint = float(ft_hint) if isinstance(ft_hint, (int, float)) and not \
        isinstance(ft_hint, bool) and math.isfinite(ft_hint) and ft_hint > 0 else None
    if fps is not None:
        frame_time = 1.0 / float(fps)
        n_out = int(math.floor((allk[-1] - allk[0]) / frame_time + 1e-9)) + 1
        if n_out > _MAX_FRAMES or n_out * J * _FRAME_BYTES > max_bytes:
            raise InvalidArgumentError(
                f"mlayer.read_gltf: fps={fps!r} makes {n_out} frames of "
                f"{allk[-1] - allk[0]:.6g} s for {J} joints ({n_out * J * _FRAME_BYTES} bytes; "
                f"at most {_MAX_FRAMES} frames and max_bytes={max_bytes})")
        times = allk[0] + np.arange(n_out) * frame_time
    elif allk.shape[0] == 1:
        frame_time, times = ft_hint or 1.0 / 30.0, allk
    else:
        dt = (allk[-1] - allk[0]) / (allk.shape[0] - 1)
        grid = allk[0] + np.arange(allk.shape[0]) * dt
        if float(np.max(np.abs(allk - grid))) <= 1e-3 * dt + tol:
            frame_time, times = dt, allk  # uniform: the keys are the frames
            if ft_hint is not None and abs(ft_hint - dt) <= 1e-4 * dt:
                frame_time = ft_hint
        else:
            frame_time = float(np.median(np.diff(allk)))
            n_out = int(math.floor((allk[-1] - allk[0]) / frame_time + 1e-9)) + 1
            _need(n_out <= max(100 * allk.shape[0], 10000),
                  f"{aw}: key times too uneven to resample at their median interval "
                  f"({frame_time:.3g} s over {allk[-1] - allk[0]:.6g} s); pass fps=")
            times = allk[0] + np.arange(n_out) * frame_time
    N = times.shape[0]
    _need(N * J * _FRAME_BYTES <= max_bytes,
          f"{aw}: {N} frames of {J} joints take {N * J * _FRAME_BYTES} bytes, more than "
          f"max_bytes={max_bytes} (pass a larger max_bytes to read it)")
    _need(frame_time >= MIN_FRAME_TIME, f"{aw}: key times {frame_time:.3g} s apart: below "
                                        f"{MIN_FRAME_TIME:g} s, not frames of a motion")
    _need(frame_time <= MAX_FRAME_TIME, f"{aw}: key times {frame_time:.3g} s apart: above "
                                        f"{MAX_FRAME_TIME:g} s, not frames of a motion")

    # sample every joint's translation, rotation and scale (a track per joint, contiguous)
    T: list[np.ndarray] = []  # (N, 3) where animated, else the static (3,)
    Q = np.empty((J, N, 4))
    S = np.empty(J)
    moving = np.zeros(J, dtype=bool)
    for k, n in enumerate(order):
        t0, r0, s0 = trs[n]
        tt = tracks.get((n, "translation"))
        if tt is None:
            T.append(t0 if k else np.broadcast_to(t0, (N, 3)))
        else:
            T.append(_sample(tt[0], tt[1], tt[2], times, False))
            moving[k] = bool(np.any(T[k] != T[k][0]))
        rr = tracks.get((n, "rotation"))
        Q[k] = r0 if rr is None else _sample(rr[0], rr[1], rr[2], times, True)
        ss = tracks.get((n, "scale"))
        sv = s0[None] if ss is None else _sample(ss[0], ss[1], ss[2], times, False)
        S[k] = _uniform_scale(sv, f"{name}: nodes[{n}] ({nodes[n].get('name', 'unnamed')})")
    # fold the scales into the translations: a joint's translation is scaled by its ancestors'
    par = np.array([-1] + [jidx[parent[n]] for n in order[1:]], dtype=np.int32)
    C = np.empty(J)  # accumulated scale down to and including each joint
    for k in range(J):
        C[k] = (Bs if k == 0 else C[par[k]]) * S[k]
    for k in range(1, J):
        if C[par[k]] != 1.0:
            T[k] = T[k] * C[par[k]]
    root_pos = T[0] @ _rot_matrix(Bq).T * Bs + Bt if (Bs != 1.0 or np.any(Bt) or
                                                     Bq[0] != 1.0) else T[0].copy()
    if Bq[0] != 1.0:
        Q[0] = quat.mul(Bq, Q[0])
    # End Sites: leaf children outside the skeleton with nothing else to them
    end_par, end_off = [], []
    for k, n in enumerate(order):
        for c in nodes[n].get("children", []):
            nc = nodes[c]
            if c in jidx or nc.get("children") or any(x in nc for x in ("mesh", "camera",
                                                                         "skin")):
                continue
            if any((c, p) in tracks for p in ("translation", "rotation", "scale")):
                continue
            end_par.append(k)
            end_off.append(C[k] * _node_trs(nc, c)[0])
    # position channels: on the joints whose translation moves, and on those the channel
    # layout written by write_gltf gives them (when the file animates their translation)
    hint = mx.get("channels")
    if not (isinstance(hint, list) and len(hint) == J and all(isinstance(c, str) for c in hint)):
        hint = None
    for k in range(1, J):
        if hint is not None and "position" in hint[k] and (order[k], "translation") in tracks:
            moving[k] = True
    trans_k = [k for k in range(1, J) if moving[k]]
    # a translation animated to a constant: that constant
    offsets = np.array([T[k] if T[k].ndim == 1 else T[k][0] for k in range(J)])
    for k in trans_k:  # with position channels: the node's own translation, the rest pose
        offsets[k] = C[par[k]] * trs[order[k]][0]
    offsets[0] = root_pos[0]
    default = [DEFAULT_ROOT_CHANNELS] + [_TRANS_CHANNELS if moving[k] else
                                         DEFAULT_JOINT_CHANNELS for k in range(1, J)]
    names = _joint_names(nodes, order)
    chans = default
    if hint is not None and ["position" in c for c in hint[1:]] == list(moving[1:]):
        chans = hint
    try:
        skel = Skeleton(names, par, offsets, chans, np.asarray(end_par, dtype=np.int32),
                        np.asarray(end_off).reshape(-1, 3))
    except InvalidArgumentError:
        skel = Skeleton(names, par, offsets, default, np.asarray(end_par, dtype=np.int32),
                        np.asarray(end_off).reshape(-1, 3))
    trans = np.stack([T[k] for k in trans_k], axis=1) if trans_k else np.zeros((N, 0, 3))
    Q /= np.sqrt(np.einsum("...i,...i->...", Q, Q))[..., None]
    # the arrays are checked: finite (every accessor read is), unit rotations, their shapes
    m = Motion(skel, frame_time, np.ascontiguousarray(root_pos),
               np.ascontiguousarray(Q.transpose(1, 0, 2)), trans, _trusted=True)
    m.up_axis, m.units = "y", "m"
    return m


def read_gltf(path: str | os.PathLike[str], animation: int = 0, *, fps: float | None = None,
              up: str | None = None, units: str | None = None,
              max_bytes: int = MAX_BYTES) -> Motion:
    """Read one skeletal animation of a glTF 2.0 file (``.glb`` or ``.gltf``) as a Motion.

    Parameters
    ----------
    path : str or os.PathLike
        The file; GLB or JSON is told by its first bytes, not its name. A ``.gltf`` may keep
        its buffers in ``data:`` URIs or in files inside its own folder: a buffer ``uri``
        (URL-decoded, symlinks resolved) that leads out of it (``..``, an absolute path, a link),
        or to anything but a regular file (a device, a FIFO), is a ``ParseError``, and only the
        buffer's ``byteLength`` bytes are read, after the file's size was checked.
    animation : int
        Which of the file's animations (default the first).
    fps : float or None
        Resample to this frame rate. None: the keyframe times are the frames when they are
        uniform (the rate follows from them; a file written by :func:`write_gltf` gives back
        its exact frame time), else the median key interval sets the rate.
    up : {"x", "y", "z"} or None
        The up axis of the motion returned (default "y", the file's): a Z-up clip for tools
        that want one.
    units : {"m", "cm", "mm", "in", "ft"} or None
        The length unit of the motion returned (default "m", the file's).
    max_bytes : int
        The most memory the motion's frames may take (frames x joints x 112 bytes: the sampled
        rotations and translations and the Motion's copies), checked before they are
        allocated: a file of a few kilobytes can name millions of key times over hundreds of
        joints. Default 1 GiB (two hours of a 60-joint rig at 30 fps).

    Returns
    -------
    Motion
        The skeleton (the skin's joints, or the animated nodes' tree, in depth-first order;
        leaf nodes outside it become End Sites), its frames, ``up_axis`` and ``units`` set.
        Joints whose translation is animated get position channels; the channel layout
        written by :func:`write_gltf` is restored.

    Raises
    ------
    ParseError
        When the file is not a usable glTF 2.0 file (broken JSON, a truncated GLB, accessors of
        the wrong type or out of range, no animation, ...): the message names the file and the
        reason.
    UnsupportedError
        For an animated or non-uniform scale on a joint, beyond :data:`SCALE_TOLERANCE` (a
        scale within it is read as its mean, uniform and static).
    InvalidArgumentError
        For an ``animation`` the file does not have, a bad ``fps``, ``up`` or ``units``.
    OSError
        When the file cannot be read.
    """
    path = os.fspath(path)
    name = os.fsdecode(path)
    up = axis_name(up, "mlayer.read_gltf") or "y"
    units = units_arg(units, "mlayer.read_gltf") or "m"
    if fps is not None and not (isinstance(fps, (int, float)) and not isinstance(fps, bool)
                                and math.isfinite(fps) and fps > 0):
        raise InvalidArgumentError(f"mlayer.read_gltf: fps must be finite and > 0, got {fps!r}")
    if not (isinstance(max_bytes, int) and not isinstance(max_bytes, bool) and max_bytes > 0):
        raise InvalidArgumentError(f"mlayer.read_gltf: max_bytes must be a positive int, got "
                                   f"{max_bytes!r}")
    with open(path, "rb") as f:
        raw = f.read()
    try:
        doc, binary = _container(raw)
        data = _Data(doc, binary, os.path.dirname(os.path.abspath(name)))
        m = _read_doc(doc, data, animation, fps, name, max_bytes)
    except _Bad as e:
        raise ParseError(f"{name}: {e}", path=name) from None
    except InvalidArgumentError as e:
        if str(e).startswith("mlayer.read_gltf:"):
            raise  # the caller's arguments (animation=, fps=)
        # what the file describes is not a skeleton mlayer takes (a name, a count)
        raise ParseError(f"{name}: {e}", path=name) from None
    except (KeyError, IndexError, TypeError, ValueError, AttributeError, struct.error) as e:
        # a safety net: every check above names its reason; this keeps a case they missed a
        # ParseError too, never a bare KeyError or IndexError
        raise ParseError(f"{name}: malformed glTF ({type(e).__name__}: {e})",
                         path=name) from None
    if up != "y" or units != "m":
        m = reframe(m, _TO_Y[up].T, 1.0 / UNITS[units])
        m.up_axis, m.units = up, units
    return m
