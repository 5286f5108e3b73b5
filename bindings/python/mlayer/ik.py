"""Analytic two-bone inverse kinematics, vectorized over frames (the C core, mlr_ik.h).

A leg is a chain ``hip -> knee -> end`` (end: the ankle, or any joint that should reach a
target). :func:`two_bone` returns two world-space rotations per frame: ``r_knee`` turns the
knee-to-end segment about the knee (changing only the knee angle, in the leg's bend plane),
then ``r_hip`` turns the whole leg about the hip so that the end lands on the target. Both are
deltas applied on the left of the joints' current world rotations; :func:`apply_leg` turns them
into new local rotations (``L' = inv(G_parent) * r * G``), so bone lengths never change.

:func:`leg_chain` finds the hip and knee of an end joint by walking up the parents, skipping
joints that sit on top of their parent (zero-length bones, as in the CMU skeletons'
``LHipJoint``).

Conventions: quaternions scalar-first (w, x, y, z), positions (N, 3); everything is float64.
"""
from __future__ import annotations

import numpy as np

from . import _arrays
from ._native import ffi, lib
from ._rig import c_rig
from .errors import InvalidArgumentError, check

__all__ = ["leg_chain", "two_bone", "from_to", "apply_leg", "rotate_to", "bend_axis_local"]

_EPS = 1e-12


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _i32(a):
    return ffi.cast("const int32_t *", ffi.from_buffer(a))


def leg_chain(skeleton, end: int) -> tuple[int, int, int]:
    """(hip, knee, end) joint indices for a two-bone chain ending at joint ``end``.

    The knee is the nearest ancestor of ``end`` at a non-zero distance from it (bone lengths
    from the skeleton's OFFSETs), the hip the nearest ancestor at a non-zero distance from the
    knee. Raises InvalidArgumentError when the chain does not exist (a joint too close to the
    root).
    """
    rig, keep = c_rig(skeleton)
    hip, knee = ffi.new("int32_t *"), ffi.new("int32_t *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_leg_chain(rig, int(end), hip, knee, diag), "leg_chain", diag)
    del keep
    return int(hip[0]), int(knee[0]), int(end)


def _vec3(x, name, n=None):
    a = _arrays.as_f64(x, name, ndim=2)
    if a.shape[1] != 3 or (n is not None and a.shape[0] != n):
        raise InvalidArgumentError(f"{name}: expected an (N, 3) array, got {a.shape}")
    return a


def from_to(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Shortest-arc unit quaternions turning direction u into direction v, (N, 3) -> (N, 4).

    Identity where either vector is zero; for opposite vectors, a half turn about an axis
    perpendicular to u.
    """
    u = np.asarray(u, dtype=np.float64)
    shape = u.shape[:-1]
    u = np.ascontiguousarray(u.reshape(-1, 3))
    v = np.ascontiguousarray(np.asarray(v, dtype=np.float64).reshape(-1, 3))
    if u.shape != v.shape:
        raise InvalidArgumentError(f"from_to: u and v must have one shape, got {u.shape}, {v.shape}")
    out = np.empty((u.shape[0], 4))
    check(lib.mlr_ik_from_to(u.shape[0], _arrays.ptr(u), _arrays.ptr(v), _arrays.ptr_out(out)),
          "from_to")
    return out.reshape(shape + (4,))


def two_bone(hip, knee, end, target, bend_axis=None, *, max_extension: float = 0.9999):
    """World-space rotation deltas (r_hip, r_knee), each (N, 4), for a two-bone chain.

    hip, knee, end, target: (N, 3) world positions. bend_axis: optional (N, 3) knee hinge axis,
    oriented like ``cross(end - knee, hip - knee)`` of a normally bent leg (a positive turn
    about it bends the knee further); default: that cross product itself, frame by frame
    (undefined for a straight leg: give an axis for legs that straighten).

    The knee turns about the hinge axis (made perpendicular to the shin) by the angle that puts
    the end at the target's distance from the hip; of the two such angles the one with the knee
    bent forward is taken (so a knee bent backwards past straight comes out bent forward, and a
    target at the current distance leaves a forward-bent knee unchanged). Then r_hip turns the
    whole leg about the hip by the shortest arc onto the target. The end reaches the target
    exactly when the distance is reachable with that hinge (for a hinge perpendicular to the
    thigh: between ``|l1 - l2|`` and ``max_extension * (l1 + l2)``; a leg already straighter
    than that is not bent). Otherwise the end stops at the nearest reachable distance on the
    hip-target line. (mlr_ik_two_bone)
    """
    arrs = [np.asarray(x, dtype=np.float64) for x in (hip, knee, end, target)]
    if not (arrs[0].shape == arrs[1].shape == arrs[2].shape == arrs[3].shape) or \
            arrs[0].ndim != 2 or arrs[0].shape[1] != 3:
        raise InvalidArgumentError(
            "two_bone: hip, knee, end and target must be (N, 3) arrays of one shape, got "
            + ", ".join(str(a.shape) for a in arrs))
    for x, name in zip(arrs, ("hip", "knee", "end", "target")):
        if not np.all(np.isfinite(x)):
            raise InvalidArgumentError(f"two_bone: {name} contains NaN or infinite values")
    a, b, c, t = (np.ascontiguousarray(x) for x in arrs)
    n = a.shape[0]
    ax = ffi.NULL
    if bend_axis is not None:
        axis = _vec3(np.broadcast_to(np.asarray(bend_axis, dtype=np.float64), (n, 3)).copy(),
                     "bend_axis", n)
        ax = _arrays.ptr(axis)
    r_hip, r_knee = np.empty((n, 4)), np.empty((n, 4))
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_two_bone(n, _arrays.ptr(a), _arrays.ptr(b), _arrays.ptr(c), _arrays.ptr(t),
                              ax, float(max_extension), _arrays.ptr_out(r_hip),
                              _arrays.ptr_out(r_knee), diag), "two_bone", diag)
    return r_hip, r_knee


def _nj(arr, name, last):
    a = _arrays.as_f64(arr, name, ndim=3)
    if a.shape[2] != last:
        raise InvalidArgumentError(f"{name}: expected (N, J, {last}), got {a.shape}")
    return a


def bend_axis_local(hip_wrot, hip, knee, end) -> np.ndarray:
    """The knee's bend axis in the hip joint's frame: the mean over frames of
    ``inv(G_hip) cross(end - knee, hip - knee)`` (unit, weighted by how bent the leg is);
    zeros when the leg never bends. (mlr_ik_bend_axis_local)"""
    g = np.ascontiguousarray(np.asarray(hip_wrot, dtype=np.float64).reshape(-1, 1, 4))
    pos = np.ascontiguousarray(np.stack([np.asarray(x, dtype=np.float64) for x in (hip, knee, end)],
                                        axis=1))
    n = pos.shape[0]
    g3 = np.ascontiguousarray(np.broadcast_to(g, (n, 3, 4)))
    out = ffi.new("double[3]")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_bend_axis_local(n, 3, _arrays.ptr(pos), _arrays.ptr(g3), 0, 1, 2, out, diag),
          "bend_axis_local", diag)
    return np.array([out[0], out[1], out[2]])


def rotate_to(rot, wrot, parents, joint: int, r_world) -> None:
    """Apply the world-space delta r_world (N, 4) to ``joint`` in the local rotations ``rot``
    (N, J, 4, modified in place), given the current world rotations ``wrot`` (N, J, 4):
    ``L' = inv(G_parent) * r * G``. (mlr_ik_rotate_to)"""
    if not (isinstance(rot, np.ndarray) and rot.dtype == np.float64 and rot.flags.c_contiguous):
        raise InvalidArgumentError("rotate_to: rot must be a C-contiguous float64 (N, J, 4) array")
    n, J = rot.shape[0], rot.shape[1]
    w = np.ascontiguousarray(_nj(wrot, "wrot", 4))
    r = np.ascontiguousarray(np.asarray(r_world, dtype=np.float64).reshape(n, 4))
    par = np.ascontiguousarray(parents, dtype=np.int32)
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_rotate_to(n, J, _i32(par), _arrays.ptr_out(rot), _arrays.ptr(w),
                               int(joint), _arrays.ptr(r), diag), "rotate_to", diag)


def apply_leg(rot, pos, wrot, parents, chain, target, bend_axis=None) -> None:
    """Solve the two-bone chain (hip, knee, end) toward ``target`` (N, 3) and write the new
    local rotations of hip and knee into ``rot`` (N, J, 4, in place). pos, wrot: current world
    positions and rotations (N, J, 3) and (N, J, 4) of the motion ``rot`` belongs to.
    bend_axis: (N, 3) world knee axis for straight legs; default: the clip's own mean bend
    axis in the hip's frame (:func:`bend_axis_local`). (mlr_ik_apply_leg)"""
    if not (isinstance(rot, np.ndarray) and rot.dtype == np.float64 and rot.flags.c_contiguous):
        raise InvalidArgumentError("apply_leg: rot must be a C-contiguous float64 (N, J, 4) array")
    n, J = rot.shape[0], rot.shape[1]
    p = np.ascontiguousarray(_nj(pos, "pos", 3))
    w = np.ascontiguousarray(_nj(wrot, "wrot", 4))
    t = _vec3(target, "target", n)
    ax = ffi.NULL
    if bend_axis is not None:
        axis = _vec3(bend_axis, "bend_axis", n)
        ax = _arrays.ptr(axis)
    par = np.ascontiguousarray(parents, dtype=np.int32)
    h, k, e = (int(x) for x in chain)
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_apply_leg(n, J, _i32(par), _arrays.ptr_out(rot), _arrays.ptr(p),
                               _arrays.ptr(w), h, k, e, _arrays.ptr(t), ax, diag), "apply_leg",
          diag)
