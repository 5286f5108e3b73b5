"""Plausibility guards of generated motion (paper 2 synthesis, :mod:`mlayer.manifold.primitives`).

Motion generated from a manifold has no input clip of its own: its contacts, floor and joint
limits come from the training clips.

* contacts: each generated frame comes from a manifold point; the training frames nearest to it
  on the manifold (:func:`contacts_along`) vote on each contact point (a foot is in contact
  where most of them had it in contact), then gaps shorter than 0.05 s are closed and contacts
  shorter than 0.08 s dropped, as :func:`mlayer.detect_contacts` does;
* floor: the training clips' floor (:func:`mlayer.guards.cleanup.floor_height` of their contacts);
* joint limits: :func:`mlayer.joint_limits` of the training clips, always applied (alpha 1).

:func:`guard_motion` runs the C guards (``mlr_guards.h``) on the generated motion itself with
``MLR_GUARDS_OPT_FOLLOW = 0``: each contact point is pinned at its mean position over the
contact (the generated feet skate, so there is no trajectory to follow), two-bone IK reaches
it, the corrections blended in time; no foot point goes below the floor. The composition
follows :class:`mlayer.pipeline.pipeline.Synthesis`.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..guards.contacts import _point
from ..guards.limits import JointLimits
from ..model._rig import c_rig, motion_axis
from ..model.motion import Motion
from ..pipeline.pipeline import GuardReport


__all__ = ["contacts_along", "guard_motion", "clean_contacts", "split_drifting"]

_GAP = 0.05          # seconds: contact gaps closed (as mlr_contacts_detect)
_MIN_CONTACT = 0.08  # seconds: shorter contacts dropped (as mlr_contacts_detect)


def _runs(col: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """(start, end) of the runs of True in a bool column, end exclusive."""
    d = np.diff(np.r_[0, col.astype(np.int8), 0])
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def clean_contacts(contacts: ArrayLike, fps: float, *, gap: float = _GAP,
                   min_duration: float = _MIN_CONTACT) -> NDArray[np.bool_]:
    """Contacts with short gaps closed, then short contacts dropped.

    Parameters
    ----------
    contacts : array_like of bool, shape (N, C)
        The contacts.
    fps : float
        The frame rate.
    gap : float, optional
        Gaps shorter than this many seconds are closed.
    min_duration : float, optional
        Contacts shorter than this many seconds (at least 2 frames) are dropped.

    Returns
    -------
    numpy.ndarray of bool, shape (N, C)
        The cleaned contacts.
    """
    c = np.array(contacts, dtype=bool)
    g = int(round(gap * fps))
    m = max(2, int(math.ceil(min_duration * fps - 1e-9)))
    for k in range(c.shape[1]):
        col = c[:, k]
        runs = _runs(col)
        for (_, b0), (a1, _) in zip(runs[:-1], runs[1:]):
            if a1 - b0 <= g:
                col[b0:a1] = True
        for a, b in _runs(col):
            if b - a < m:
                col[a:b] = False
    return c


def contacts_along(points: ArrayLike, traj: ArrayLike, contacts: ArrayLike, fps: float, *,
                   neighbours: int = 8) -> NDArray[np.bool_]:
    """Contacts of generated frames from the training frames nearest on the manifold.

    Per frame, the ``neighbours`` training frames nearest on the manifold vote with equal
    weight (every training frame tied with the farthest of them counts too, so the SOM's
    shared units vote whole); in contact where more than half of them were. Then
    :func:`clean_contacts`.

    Parameters
    ----------
    points : array_like, shape (N, 2)
        The training frames' manifold points.
    traj : array_like, shape (n, 2)
        The generated frames' manifold points.
    contacts : array_like of bool, shape (N, C)
        The training frames' contacts.
    fps : float
        The frame rate.
    neighbours : int, optional
        Voters per frame.

    Returns
    -------
    numpy.ndarray of bool, shape (n, C)
        The generated frames' contacts.
    """
    pts = np.asarray(points, dtype=np.float64)
    t = np.asarray(traj, dtype=np.float64)
    c = np.asarray(contacts, dtype=bool)
    if c.ndim != 2 or c.shape[0] != pts.shape[0]:
        raise InvalidArgumentError(f"contacts: expected ({pts.shape[0]}, C), got {c.shape}")
    n = t.shape[0]
    if c.shape[1] == 0 or n == 0:
        return np.zeros((n, c.shape[1]), dtype=bool)
    pts, t = pts.reshape(pts.shape[0], -1), t.reshape(n, -1)
    k = int(min(max(1, neighbours), pts.shape[0]))
    cf = c.astype(np.float64)
    out = np.zeros((n, c.shape[1]), dtype=bool)
    # exact distances in blocks of generated frames (numpy only: generation needs no scipy;
    # scipy's cKDTree, used before, gave the same votes)
    block = max(1, (1 << 22) // max(1, pts.shape[0] * pts.shape[1]))
    for s in range(0, n, block):
        diff = t[s:s + block, None, :] - pts[None, :, :]
        d = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
        radius = np.partition(d, k - 1, axis=1)[:, k - 1] * (1.0 + 1e-9) + 1e-12
        near = d <= radius[:, None]
        out[s:s + block] = (near @ cf) / near.sum(axis=1)[:, None] > 0.5
    return clean_contacts(out, fps)


def split_drifting(contacts: ArrayLike, positions: ArrayLike, radius: float, gap: int
                   ) -> NDArray[np.bool_]:
    """Contacts cut where a pin cannot hold.

    Within each contact run of a point, a new run starts where the point's horizontal
    position has drifted more than ``radius`` from where the current run started; the ``gap``
    frames before the cut leave contact (the foot lifts and re-plants). Runs shorter than 2
    frames are dropped. The contacts come from training frames in which the body may have
    stood still, while the generated body walks through the same poses: one pin over such a
    run would drag the foot behind the body.

    Parameters
    ----------
    contacts : array_like of bool, shape (N, C)
        The contacts.
    positions : array_like, shape (N, C, 3)
        The contact points' positions in the generated motion before the guards (X-Z is
        horizontal).
    radius : float
        Largest drift of a pin.
    gap : int
        Frames out of contact before a cut.

    Returns
    -------
    numpy.ndarray of bool, shape (N, C)
        The cut contacts.
    """
    c = np.array(contacts, dtype=bool)
    p = np.asarray(positions, dtype=np.float64)[:, :, [0, 2]]
    gap = max(1, int(gap))
    for k in range(c.shape[1]):
        for a, b in _runs(c[:, k]):
            start = a
            t = a + 1
            while t < b:
                if np.linalg.norm(p[t, k] - p[start, k]) > radius:
                    c[max(start + 1, t - gap):t, k] = False
                    start = t
                t += 1
        for a, b in _runs(c[:, k]):
            if b - a < 2:
                c[a:b, k] = False
    return c


def _i32(a: NDArray[np.int32]) -> Any:
    return ffi.cast("const int32_t *", ffi.from_buffer(a))


def guard_motion(motion: Motion, names: Sequence[str], contacts: ArrayLike, *,
                 limits: JointLimits | None = None, floor: float | None = None,
                 up: str | int | None = None) -> tuple[Motion, GuardReport]:
    """The C guards on a generated motion with given contacts.

    Each contact point is pinned at its mean position over the contact
    (``MLR_GUARDS_OPT_FOLLOW = 0``); no reference motion.

    Parameters
    ----------
    motion : Motion
        The generated motion.
    names : sequence of str
        C contact point names (``"Joint"`` or ``"Joint/End"``); C may be 0 (no pinning).
    contacts : array_like of bool, shape (N, C)
        Contacts of the motion's frames.
    limits : JointLimits, optional
        Applied always, alpha 1; None: no joint limits.
    floor : float, optional
        The floor height along ``up`` (finite); None: no floor guard.
    up : {"x", "y", "z"}, optional
        The up axis; default the motion's.

    Returns
    -------
    motion : Motion
        The guarded motion.
    report : GuardReport
        What the guards did.

    Raises
    ------
    mlayer.InvalidArgumentError
        For bad arguments.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"motion: expected a mlayer.Motion, got "
                                   f"{type(motion).__name__}")
    names = [names] if isinstance(names, str) else list(names)
    c = np.asarray(contacts)
    if c.dtype != np.bool_ or c.shape != (motion.n_frames, len(names)):
        raise InvalidArgumentError(f"contacts: expected a bool array ({motion.n_frames}, "
                                   f"{len(names)}), got {c.dtype} {c.shape}")
    if limits is not None and not isinstance(limits, JointLimits):
        raise InvalidArgumentError(f"limits: expected a JointLimits or None, got {limits!r}")
    if limits is not None and limits.joint_names != motion.joint_names:
        raise InvalidArgumentError("limits: made for another skeleton than the motion's")
    if floor is not None:
        if isinstance(floor, bool):
            raise InvalidArgumentError(f"floor: expected a height or None, got {floor!r}")
        floor = float(floor)
        if not math.isfinite(floor):
            raise InvalidArgumentError(f"floor: the height must be finite, got {floor!r}")
    up_ax = motion_axis(motion, up, "up")
    opts = [(lib.MLR_GUARDS_OPT_UP, up_ax),
            (lib.MLR_GUARDS_OPT_LIMITS, lib.MLR_GUARDS_LIMITS_ALWAYS if limits is not None
             else lib.MLR_GUARDS_LIMITS_OFF),
            (lib.MLR_GUARDS_OPT_KEEP_CONTACTS, 1.0 if names else 0.0),
            (lib.MLR_GUARDS_OPT_FLOOR, 1.0 if floor is not None else 0.0),
            (lib.MLR_GUARDS_OPT_FOLLOW, 0.0)]
    if floor is not None:
        opts.append((lib.MLR_GUARDS_OPT_FLOOR_HEIGHT, floor))
    copts = ffi.new("mlr_guards_option[]", len(opts))
    for k, (key, v) in enumerate(opts):
        copts[k].key, copts[k].value = key, v
    root, rot, trans = motion._frames()
    rig, keep = c_rig(motion.skeleton)
    out = ffi.new("mlr_guards **")
    diag = ffi.new("mlr_diag *")
    tptr = _arrays.ptr(trans) if trans.size else ffi.NULL
    inp = ffi.new("mlr_guards_input *")
    inp.rig, inp.fps = rig, motion.fps
    inp.frames = (motion.n_frames, _arrays.ptr(root), _arrays.ptr(rot), tptr)
    inp.opts, inp.n_opts = copts, len(opts)
    check(lib.mlr_guards_create_from(inp, ffi.NULL, out, diag), "guards", diag)
    g = ffi.gc(out[0], lib.mlr_guards_destroy)
    pts = [_point(motion.skeleton, n) for n in names]
    j = np.array([p[0] for p in pts], dtype=np.int32).reshape(-1)
    e = np.array([p[1] for p in pts], dtype=np.int32).reshape(-1)
    cu = np.ascontiguousarray(c, dtype=np.uint8)
    if names:
        check(lib.mlr_guards_set_contacts(g, len(pts), _i32(j), _i32(e),
                                          ffi.cast("const uint8_t *", ffi.from_buffer(cu)),
                                          diag), "contacts", diag)
    if limits is not None:
        check(lib.mlr_guards_set_limits(g, limits._h, diag), "limits", diag)
    a = np.ones(1)
    r, q, t = root.copy(), rot.copy(), trans.copy()
    J = motion.n_joints
    limited = np.zeros(J, dtype=np.uintp)
    rep = ffi.new("mlr_guards_report *")
    job = ffi.new("mlr_guards_job *")
    job.alpha, job.n_alpha = _arrays.ptr(a), 1
    job.root_pos, job.rot = _arrays.ptr_out(r), _arrays.ptr_out(q)
    job.trans, job.body_on_trans = (_arrays.ptr_out(t) if t.size else ffi.NULL), 1
    job.limited, job.n_limited = ffi.cast("size_t *", ffi.from_buffer(limited)), J
    job.report = rep
    check(lib.mlr_guards_run(g, job, diag), "guards", diag)
    del keep
    report = GuardReport(
        limited={n: int(k) for n, k in zip(motion.joint_names, limited) if k},
        limits_applied=bool(rep.limits_applied), contact_frames=int(rep.contact_frames),
        floor_frames=int(rep.floor_frames), floor_height=float(rep.floor_height),
        root_shift_max=float(rep.root_shift_max), floor_raised=int(rep.floor_raised))
    return motion.with_frames(root_pos=r, rot=q, trans=t), report
