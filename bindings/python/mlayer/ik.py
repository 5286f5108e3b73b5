"""Analytic two-bone inverse kinematics, vectorized over frames (numpy).

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

from . import quat
from .errors import InvalidArgumentError

__all__ = ["leg_chain", "two_bone", "from_to", "apply_leg", "rotate_to", "bend_axis_local"]

_EPS = 1e-12


def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...i,...i->...", v, v))


def _unit(v: np.ndarray) -> np.ndarray:
    n = _norm(v)[..., None]
    return v / np.where(n > _EPS, n, 1.0)


def _axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Unit quaternions of rotations by ``angle`` about unit ``axis`` (right-handed)."""
    h = 0.5 * np.asarray(angle)[..., None]
    return np.concatenate([np.cos(h), np.sin(h) * axis], axis=-1)


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _bone_parent(parents, lengths, j: int) -> int:
    """The nearest ancestor of j whose position differs from j's (-1 when there is none)."""
    c = j
    while c > 0 and lengths[c] <= 1e-9:
        c = int(parents[c])
    return int(parents[c]) if c > 0 else -1


def leg_chain(skeleton, end: int) -> tuple[int, int, int]:
    """(hip, knee, end) joint indices for a two-bone chain ending at joint ``end``.

    The knee is the nearest ancestor of ``end`` at a non-zero distance from it (bone lengths
    from the skeleton's OFFSETs), the hip the nearest ancestor at a non-zero distance from the
    knee. Raises InvalidArgumentError when the chain does not exist (a joint too close to the
    root).
    """
    parents = skeleton.parents
    lengths = np.linalg.norm(skeleton.offsets, axis=1)
    knee = _bone_parent(parents, lengths, end)
    hip = _bone_parent(parents, lengths, knee) if knee >= 0 else -1
    if knee < 0 or hip < 0:
        name = skeleton.joint_names[end]
        raise InvalidArgumentError(
            f"joint {name!r} has no two-bone chain above it (needs two ancestors at non-zero "
            "distances: a hip and a knee)")
    return hip, knee, end


def from_to(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Shortest-arc unit quaternions turning direction u into direction v, (N, 3) -> (N, 4).

    Identity where either vector is zero; for opposite vectors, a half turn about an axis
    perpendicular to u.
    """
    u, v = _unit(np.asarray(u, dtype=np.float64)), _unit(np.asarray(v, dtype=np.float64))
    c = np.einsum("...i,...i->...", u, v)
    axis = np.cross(u, v)
    q = np.concatenate([(1.0 + c)[..., None], axis], axis=-1)
    opposite = c < -1.0 + 1e-12
    if np.any(opposite):
        uo = u[opposite]
        perp = np.cross(uo, np.array([1.0, 0.0, 0.0]))
        small = _norm(perp) < 1e-6
        perp[small] = np.cross(uo[small], np.array([0.0, 1.0, 0.0]))
        q[opposite] = np.concatenate([np.zeros((uo.shape[0], 1)), _unit(perp)], axis=-1)
    n = _norm(q)[..., None]
    zero = n[..., 0] < _EPS
    q = q / np.where(n > _EPS, n, 1.0)
    q[zero] = (1.0, 0.0, 0.0, 0.0)
    return q


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
    hip-target line.
    """
    a = np.asarray(hip, dtype=np.float64)
    b = np.asarray(knee, dtype=np.float64)
    c = np.asarray(end, dtype=np.float64)
    t = np.asarray(target, dtype=np.float64)
    if not (a.shape == b.shape == c.shape == t.shape) or a.ndim != 2 or a.shape[1] != 3:
        raise InvalidArgumentError(
            f"two_bone: hip, knee, end and target must be (N, 3) arrays of one shape, got "
            f"{a.shape}, {b.shape}, {c.shape}, {t.shape}")
    for x, name in ((a, "hip"), (b, "knee"), (c, "end"), (t, "target")):
        if not np.all(np.isfinite(x)):
            raise InvalidArgumentError(f"two_bone: {name} contains NaN or infinite values")
    ab, bc = b - a, c - b
    l1, l2 = _norm(ab), _norm(bc)
    d_now = _norm(c - a)
    d = _norm(t - a)
    hi = np.maximum(max_extension * (l1 + l2), d_now)
    d = np.minimum(d, hi)
    # hinge axis, perpendicular to the shin
    n = np.cross(bc, -ab) if bend_axis is None else np.asarray(bend_axis, dtype=np.float64)
    bcu = _unit(bc)
    n = n - np.einsum("ij,ij->i", n, bcu)[:, None] * bcu
    weak = _norm(n) <= 1e-9 * np.maximum(l1 * l2, _EPS)
    if np.any(weak):  # hinge along the shin: fall back to the leg's own plane, or any axis
        alt = np.cross(bc[weak], -ab[weak])
        bad = _norm(alt) <= 1e-9 * np.maximum(l1 * l2, _EPS)[weak]
        alt[bad] = np.cross(bc[weak][bad], np.array([1.0, 0.0, 0.0]))
        n[weak] = alt
    n = _unit(n)
    # |ab + R(n, phi) bc|^2 = K + 2 (P cos phi + Q sin phi) = K + 2 A cos(phi - phi0)
    w = np.cross(n, bc)
    K = l1 * l1 + l2 * l2
    P = np.einsum("ij,ij->i", ab, bc)
    Q = np.einsum("ij,ij->i", ab, w)
    A = np.hypot(P, Q)
    phi0 = np.arctan2(Q, P)  # the straightest pose
    cosb = (d * d - K) / np.maximum(2.0 * A, _EPS)
    beta = np.arccos(np.clip(cosb, -1.0, 1.0))
    phi = phi0 + beta  # the forward-bent solution
    phi = (phi + np.pi) % (2.0 * np.pi) - np.pi
    r_knee = _axis_angle(n, phi)
    c1 = b + np.cos(phi)[:, None] * bc + np.sin(phi)[:, None] * w
    r_hip = from_to(c1 - a, t - a)
    return r_hip, r_knee


def bend_axis_local(hip_wrot, hip, knee, end) -> np.ndarray:
    """The knee's bend axis in the hip joint's frame: the mean over frames of
    ``inv(G_hip) cross(end - knee, hip - knee)`` (unit, weighted by how bent the leg is);
    zeros when the leg never bends."""
    n = np.cross(end - knee, hip - knee)
    local = _rotate(quat.conj(hip_wrot), n)
    s = local.sum(axis=0)
    ns = _norm(s)
    return s / ns if ns > _EPS else np.zeros(3)


def rotate_to(rot, wrot, parents, joint: int, r_world) -> None:
    """Apply the world-space delta r_world (N, 4) to ``joint`` in the local rotations ``rot``
    (N, J, 4, modified in place), given the current world rotations ``wrot`` (N, J, 4):
    ``L' = inv(G_parent) * r * G``."""
    g = wrot[:, joint]
    p = int(parents[joint])
    new_world = quat.mul(r_world, g)
    local = quat.mul(quat.conj(wrot[:, p]), new_world) if p >= 0 else new_world
    rot[:, joint] = quat.normalize(local)


def apply_leg(rot, pos, wrot, parents, chain, target, bend_axis=None) -> None:
    """Solve the two-bone chain (hip, knee, end) toward ``target`` (N, 3) and write the new
    local rotations of hip and knee into ``rot`` (N, J, 4, in place). pos, wrot: current world
    positions and rotations (N, J, 3) and (N, J, 4) of the motion ``rot`` belongs to.
    bend_axis: (N, 3) world knee axis for straight legs; default: the clip's own mean bend
    axis in the hip's frame (:func:`bend_axis_local`)."""
    h, k, e = chain
    if bend_axis is None:
        axis = bend_axis_local(wrot[:, h], pos[:, h], pos[:, k], pos[:, e])
        if np.any(axis):
            bend_axis = _rotate(wrot[:, h], np.broadcast_to(axis, (pos.shape[0], 3)))
    r_hip, r_knee = two_bone(pos[:, h], pos[:, k], pos[:, e], target, bend_axis)
    # The knee's parent is the hip or a joint between them: its world rotation is the old one,
    # because the hip's delta rotates knee and parent alike.
    rotate_to(rot, wrot, parents, k, r_knee)
    rotate_to(rot, wrot, parents, h, r_hip)
