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

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._native import ffi, lib
from ..model._rig import c_rig
from ..errors import InvalidArgumentError, check

if TYPE_CHECKING:
    from ..model.motion import Skeleton

__all__ = ["leg_chain", "two_bone", "from_to", "apply_leg", "rotate_to", "bend_axis_local"]

_EPS = 1e-12


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _i32(a: NDArray[np.int32]) -> Any:
    return ffi.cast("const int32_t *", ffi.from_buffer(a))


def leg_chain(skeleton: Skeleton, end: int) -> tuple[int, int, int]:
    """(hip, knee, end) joint indices for a two-bone chain ending at joint ``end``.

    The knee is the nearest ancestor of ``end`` at a non-zero distance from it (bone lengths
    from the skeleton's OFFSETs), the hip the nearest ancestor at a non-zero distance from the
    knee.

    Parameters
    ----------
    skeleton : Skeleton
        The skeleton.
    end : int
        The end joint (an ankle, or any joint that should reach a target).

    Returns
    -------
    tuple of int
        ``(hip, knee, end)``.

    Raises
    ------
    mlayer.InvalidArgumentError
        When the chain does not exist (a joint too close to the root).
    """
    rig, keep = c_rig(skeleton)
    hip, knee = ffi.new("int32_t *"), ffi.new("int32_t *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_leg_chain(rig, int(end), hip, knee, diag), "leg_chain", diag)
    del keep
    return int(hip[0]), int(knee[0]), int(end)


def _vec3(x: ArrayLike, name: str, n: int | None = None) -> NDArray[np.float64]:
    a = _arrays.as_f64(x, name, ndim=2)
    if a.shape[1] != 3 or (n is not None and a.shape[0] != n):
        raise InvalidArgumentError(f"{name}: expected an (N, 3) array, got {a.shape}")
    return a


def from_to(u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Shortest-arc unit quaternions turning direction ``u`` into direction ``v``.

    Identity where either vector is zero; for opposite vectors, a half turn about an axis
    perpendicular to ``u``.

    Parameters
    ----------
    u, v : array_like, shape (..., 3)
        Directions, of one shape.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        Scalar-first unit quaternions.

    Raises
    ------
    mlayer.InvalidArgumentError
        When the shapes differ.
    """
    u = np.asarray(u, dtype=np.float64)
    shape = u.shape[:-1]
    u = np.ascontiguousarray(u.reshape(-1, 3))
    v = np.ascontiguousarray(np.asarray(v, dtype=np.float64).reshape(-1, 3))
    if u.shape != v.shape:
        raise InvalidArgumentError(f"from_to: u and v must have one shape, got {u.shape}, "
                                   f"{v.shape}")
    out = np.empty((u.shape[0], 4))
    check(lib.mlr_ik_from_to(u.shape[0], _arrays.ptr(u), _arrays.ptr(v), _arrays.ptr_out(out)),
          "from_to")
    return out.reshape(shape + (4,))


def two_bone(hip: ArrayLike, knee: ArrayLike, end: ArrayLike, target: ArrayLike,
             bend_axis: ArrayLike | None = None, *, max_extension: float = 0.9999
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World-space rotation deltas (r_hip, r_knee) for a two-bone chain (``mlr_ik_two_bone``).

    The knee turns about the hinge axis (made perpendicular to the shin) by the angle that puts
    the end at the target's distance from the hip; of the two such angles the one with the knee
    bent forward is taken (so a knee bent backwards past straight comes out bent forward, and a
    target at the current distance leaves a forward-bent knee unchanged). Then ``r_hip`` turns
    the whole leg about the hip by the shortest arc onto the target. The end reaches the target
    exactly when the distance is reachable with that hinge (for a hinge perpendicular to the
    thigh: between ``|l1 - l2|`` and ``max_extension * (l1 + l2)``; a leg already straighter
    than that is not bent). Otherwise the end stops at the nearest reachable distance on the
    hip-target line.

    Parameters
    ----------
    hip, knee, end, target : array_like, shape (N, 3)
        World positions, finite.
    bend_axis : array_like, shape (N, 3) or (3,), optional
        The knee hinge axis, oriented like ``cross(end - knee, hip - knee)`` of a normally
        bent leg (a positive turn about it bends the knee further). Default: that cross
        product itself, frame by frame (undefined for a straight leg: give an axis for legs
        that straighten).
    max_extension : float, optional
        The largest reach as a fraction of ``l1 + l2``.

    Returns
    -------
    r_hip, r_knee : numpy.ndarray, shape (N, 4)
        Deltas applied on the left of the joints' current world rotations.

    Raises
    ------
    mlayer.InvalidArgumentError
        For arrays of other shapes or with NaN or infinite values.
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


def _nj(arr: ArrayLike, name: str, last: int) -> NDArray[np.float64]:
    a = _arrays.as_f64(arr, name, ndim=3)
    if a.shape[2] != last:
        raise InvalidArgumentError(f"{name}: expected (N, J, {last}), got {a.shape}")
    return a


def bend_axis_local(hip_wrot: ArrayLike, hip: ArrayLike, knee: ArrayLike, end: ArrayLike
                    ) -> NDArray[np.float64]:
    """The knee's bend axis in the hip joint's frame (``mlr_ik_bend_axis_local``).

    The mean over frames of ``inv(G_hip) cross(end - knee, hip - knee)``, weighted by how bent
    the leg is.

    Parameters
    ----------
    hip_wrot : array_like, shape (N, 4)
        The hip's world rotations ``G_hip``.
    hip, knee, end : array_like, shape (N, 3)
        World positions.

    Returns
    -------
    numpy.ndarray, shape (3,)
        A unit axis; zeros when the leg never bends.
    """
    g = np.ascontiguousarray(np.asarray(hip_wrot, dtype=np.float64).reshape(-1, 1, 4))
    pos = np.ascontiguousarray(np.stack([np.asarray(x, dtype=np.float64)
                                         for x in (hip, knee, end)], axis=1))
    n = pos.shape[0]
    g3 = np.ascontiguousarray(np.broadcast_to(g, (n, 3, 4)))
    out = ffi.new("double[3]")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_bend_axis_local(n, 3, _arrays.ptr(pos), _arrays.ptr(g3), 0, 1, 2, out, diag),
          "bend_axis_local", diag)
    return np.array([out[0], out[1], out[2]])


def rotate_to(rot: NDArray[np.float64], wrot: ArrayLike, parents: ArrayLike, joint: int,
              r_world: ArrayLike) -> None:
    """Apply a world-space delta to one joint's local rotations (``mlr_ik_rotate_to``).

    ``L' = inv(G_parent) * r * G``.

    Parameters
    ----------
    rot : numpy.ndarray, shape (N, J, 4)
        Local rotations, C-contiguous float64, modified in place.
    wrot : array_like, shape (N, J, 4)
        The current world rotations.
    parents : array_like of int, shape (J,)
        The skeleton's parents.
    joint : int
        The joint to turn.
    r_world : array_like, shape (N, 4)
        The world-space delta ``r``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For arrays of the wrong type or shape.
    """
    if not (isinstance(rot, np.ndarray) and rot.dtype == np.float64 and rot.flags.c_contiguous):
        raise InvalidArgumentError("rotate_to: rot must be a C-contiguous float64 (N, J, 4) array")
    n, J = rot.shape[0], rot.shape[1]
    w = np.ascontiguousarray(_nj(wrot, "wrot", 4))
    r = np.ascontiguousarray(np.asarray(r_world, dtype=np.float64).reshape(n, 4))
    par = np.ascontiguousarray(parents, dtype=np.int32)
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_ik_rotate_to(n, J, _i32(par), _arrays.ptr_out(rot), _arrays.ptr(w),
                               int(joint), _arrays.ptr(r), diag), "rotate_to", diag)


def apply_leg(rot: NDArray[np.float64], pos: ArrayLike, wrot: ArrayLike, parents: ArrayLike,
              chain: Sequence[int], target: ArrayLike, bend_axis: ArrayLike | None = None
              ) -> None:
    """Solve a two-bone chain toward a target, in place (``mlr_ik_apply_leg``).

    Writes the new local rotations of the hip and the knee into ``rot``.

    Parameters
    ----------
    rot : numpy.ndarray, shape (N, J, 4)
        Local rotations, C-contiguous float64, modified in place.
    pos, wrot : array_like, shape (N, J, 3) and (N, J, 4)
        Current world positions and rotations of the motion ``rot`` belongs to.
    parents : array_like of int, shape (J,)
        The skeleton's parents.
    chain : sequence of int
        ``(hip, knee, end)``, as from :func:`leg_chain`.
    target : array_like, shape (N, 3)
        Where the end should go.
    bend_axis : array_like, shape (N, 3), optional
        World knee axis for straight legs; default: the clip's own mean bend axis in the
        hip's frame (:func:`bend_axis_local`).

    Raises
    ------
    mlayer.InvalidArgumentError
        For arrays of the wrong type or shape.
    """
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
