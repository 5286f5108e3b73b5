"""Foot contacts: detection on a motion, and spacetime cleanup after synthesis (paper 1, 4.3).

Detection (:func:`detect_contacts`, in the C core: mlr_contacts.h) marks, per foot joint
(ankle, and toe where the skeleton has one), the frames where the joint is slow and low, with
hysteresis and a minimum duration, on any up axis.
Every threshold is relative to the body size (:func:`mlayer.metrics.body_height`) and to
seconds, so the defaults work in any length unit and at any frame rate. Height is measured above
the joint's own local floor level (its lowest height within +-0.75 s), so an ankle that sits
above the sole, a dog's raised hock, slopes and a lying phase need no calibration.

Cleanup (:func:`fix_contacts`) implements eq. 18, ``M* = M' (+) delta_e``. Targets: on the
frames where a foot touches, it follows the original's own contact trajectory (smoothed over
0.02 s to drop capture noise), shifted horizontally by one offset per contact toward where the
synthesized foot is, at the original's heights; so the foot keeps the original's heel roll and
settling and slides no more than the original did. The root moves by a smoothed correction
only where a leg would have to stretch beyond 98% of its length; analytic two-bone IK on each
leg (:mod:`mlayer.ik`) reaches the targets on the contact frames (a toe is placed by turning
its ankle), and the resulting changes of the hip, knee and ankle rotations are spread over
the neighbouring frames by the LGS as a displacement map on rotation vectors (interpolating
the contact frames, back to zero 0.3 s away), so the rotations stay smooth and nothing pops
at contact boundaries. Y is up.
"""
from __future__ import annotations

import re

import numpy as np

from . import ik, quat
from ._arrays import as_f64, ptr, ptr_out
from ._native import ffi, lib
from ._rig import axis, c_rig
from .errors import InvalidArgumentError, check
from .lgs import lgs
from .metrics import body_height

__all__ = ["find_feet", "detect_contacts", "fix_contacts", "keep_contacts", "contact_intervals",
           "keep_contacts_retimed",
           "contact_positions", "END_SUFFIX",
           "FOOT_PATTERN", "TOE_PATTERN", "HAND_PATTERN"]

#: joint names taken as ankles (case-insensitive search): CMU "LeftFoot"/"LeftAnkle", Daz
#: "lFoot", Bandai "Foot_L", MakeHuman "lfoot", animal rigs "paw"/"hoof"
FOOT_PATTERN = re.compile(r"foot|ankle|paw|hoof", re.IGNORECASE)
#: toe joints below an ankle: CMU "LeftToeBase", LaFAN1 "LeftToe", Bandai "Toes_L", "ball"
TOE_PATTERN = re.compile(r"toe|ball", re.IGNORECASE)
#: front feet of quadrupeds named as hands (AI4Animation dog "LeftHand"); used only when low
HAND_PATTERN = re.compile(r"hand|wrist", re.IGNORECASE)

# detection defaults (body heights, seconds), as in the C core (mlr_contacts.h)
_SPEED_ON = 0.25     # body heights per second
_HEIGHT_ON = 0.06    # body heights above the local floor level
_MIN_CONTACT = 0.08  # seconds


def _has_ancestor_in(parents, j: int, group) -> bool:
    p = int(parents[j])
    while p >= 0:
        if p in group:
            return True
        p = int(parents[p])
    return False


END_SUFFIX = "/End"


def _end_site_of(sk, j: int) -> int:
    """Index of the first End Site below joint j, or -1."""
    hits = np.flatnonzero(sk.end_site_parents == j)
    return int(hits[0]) if hits.size else -1


def _check_motion(motion, where: str):
    from .motion import Motion
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"{where}: motion must be a mlayer.Motion")


def _positions_arg(motion, positions, name: str, last: int) -> np.ndarray:
    shape = (motion.n_frames, motion.n_joints, last)
    a = as_f64(positions, name)
    if a.shape != shape:
        raise InvalidArgumentError(f"{name}: expected shape {shape}, got {a.shape}")
    return a


def _c_feet(motion, pos, up: int) -> list[tuple[int, int]]:
    """Contact points (joint, End Site or -1) of the feet, ankle then toe, by the C core;
    (-1, -1) for a foot without a toe."""
    sk = motion.skeleton
    J = sk.n_joints
    rig, keep = c_rig(sk)
    joints = np.empty(2 * J, dtype=np.int32)
    ends = np.empty(2 * J, dtype=np.int32)
    n_feet = ffi.new("size_t *")
    diag = ffi.new("mlr_diag *")
    N = pos.shape[0] if pos is not None else 0
    code = lib.mlr_contacts_find_feet(
        rig, N, ptr(pos, "const double *") if N else ffi.NULL, up, J,
        ffi.cast("int32_t *", ffi.from_buffer(joints, require_writable=True)),
        ffi.cast("int32_t *", ffi.from_buffer(ends, require_writable=True)), n_feet, ffi.NULL,
        diag)
    del keep
    try:
        check(code, "find_feet", diag)
    except InvalidArgumentError as e:
        if "no feet found" not in str(e):
            raise
        names = sk.joint_names
        raise InvalidArgumentError(
            f"{e}. Name the contact joints yourself: joints=['LeftFoot', 'LeftToeBase', ...] "
            "(Python) or --joints LeftFoot,LeftToeBase (command line). Joints of this "
            "skeleton: " + ", ".join(names[:40]) + (" ..." if len(names) > 40 else ""),
            e.code) from None
    n = 2 * int(n_feet[0])
    return list(zip(joints[:n].tolist(), ends[:n].tolist()))


def _point_name(sk, j: int, e: int) -> str:
    return sk.joint_names[j] + (END_SUFFIX if e >= 0 else "")


def find_feet(motion, positions: np.ndarray | None = None, *,
              up="y") -> list[tuple[str, str | None]]:
    """The feet of a skeleton found by joint name: a list of (ankle, toe or None) names.

    Ankles: the topmost joint of each chain whose name matches :data:`FOOT_PATTERN`. A toe:
    the child of that ankle matching :data:`TOE_PATTERN` (the one with the longest OFFSET when
    there are several, as MakeHuman's five toes; also one behind zero-length joints); without
    one, the ankle's End Site, named ``"<ankle>/End"`` (the toe tip of the Daz skeletons, the
    paw of the AI4Animation dog). Joints matching :data:`HAND_PATTERN` are feet too when they
    stay low (median height along ``up`` within 0.2 body heights of the feet's: a quadruped's
    front feet); positions (N, J, 3) are the motion's own when not given. up: the up axis,
    "x", "y" or "z" or 0..2. Raises InvalidArgumentError naming the patterns and the
    skeleton's joints when no foot is found. The rules run in the C core
    (``mlr_contacts_find_feet``).
    """
    _check_motion(motion, "find_feet")
    ax = axis(up, "find_feet")
    if motion.n_frames:
        pos = motion.positions() if positions is None else \
            _positions_arg(motion, positions, "find_feet: positions", 3)
    else:
        pos = None
    sk = motion.skeleton
    pts = _c_feet(motion, pos, ax)
    return [(sk.joint_names[pts[i][0]],
             None if pts[i + 1][0] < 0 else _point_name(sk, *pts[i + 1]))
            for i in range(0, len(pts), 2)]


def _point(sk, name) -> tuple[int, int]:
    """(joint, End Site or -1) of a contact point name ("Joint" or "Joint/End") or index."""
    if isinstance(name, (int, np.integer)):
        if not 0 <= int(name) < sk.n_joints:
            raise InvalidArgumentError(f"joint index {name} out of range for {sk.n_joints} joints")
        return int(name), -1
    if not isinstance(name, str):
        raise InvalidArgumentError(f"contact joints: expected names or indices, got {name!r}")
    names = sk.joint_names
    if name in names:
        return names.index(name), -1
    if name.endswith(END_SUFFIX) and name[:-len(END_SUFFIX)] in names:
        j = names.index(name[:-len(END_SUFFIX)])
        e = _end_site_of(sk, j)
        if e >= 0:
            return j, e
        raise InvalidArgumentError(f"{name!r}: joint {names[j]!r} has no End Site")
    raise InvalidArgumentError(
        f"no joint named {name!r} ('Joint/End' names a joint's End Site); joints of this "
        "skeleton: " + ", ".join(names))


def _point_arrays(pts):
    joints = np.ascontiguousarray([j for j, _ in pts], dtype=np.int32)
    ends = np.ascontiguousarray([e for _, e in pts], dtype=np.int32)
    return joints, ends


def contact_positions(motion, names, pos=None, wrot=None) -> np.ndarray:
    """(N, C, 3) world positions of contact points: joints, or End Sites ("Joint/End"), by
    the C core (``mlr_rig_point_positions``). pos (N, J, 3) and wrot (N, J, 4): the motion's
    forward kinematics when already at hand."""
    _check_motion(motion, "contact_positions")
    sk = motion.skeleton
    names = [names] if isinstance(names, str) else list(names)
    pts = [_point(sk, n) for n in names]
    if pos is None or (wrot is None and any(e >= 0 for _, e in pts)):
        pos, wrot = motion.forward_kinematics()
    pos = _positions_arg(motion, pos, "contact_positions: pos", 3)
    if wrot is not None:
        wrot = _positions_arg(motion, wrot, "contact_positions: wrot", 4)
    N = pos.shape[0]
    out = np.empty((N, len(pts), 3))
    if N == 0 or not pts:
        return out
    joints, ends = _point_arrays(pts)
    rig, keep = c_rig(sk)
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_rig_point_positions(
        rig, N, ptr(pos, "const double *"),
        ptr(wrot, "const double *") if wrot is not None else ffi.NULL, len(pts),
        ffi.cast("const int32_t *", ffi.from_buffer(joints)),
        ffi.cast("const int32_t *", ffi.from_buffer(ends)), ptr_out(out), diag)
    del keep
    check(code, "contact_positions", diag)
    return out


def _runs(mask: np.ndarray):
    """(starts, ends) of the True runs of a 1-D bool array, ends exclusive."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def contact_intervals(contacts_column) -> list[tuple[int, int]]:
    """The contact intervals [start, end) of one column of a contact array."""
    s, e = _runs(np.asarray(contacts_column, dtype=bool))
    return list(zip(s.tolist(), e.tolist()))


def _resolve_names(motion, joints) -> list[str]:
    sk = motion.skeleton
    if isinstance(joints, str):
        joints = [x for x in joints.replace(",", " ").split() if x]
    joints = list(joints)
    if not joints:
        raise InvalidArgumentError("joints: empty list")
    out = []
    for n in joints:
        j, e = _point(sk, n)
        out.append(sk.joint_names[j] + (END_SUFFIX if e >= 0 else ""))
    if len(set(out)) != len(out):
        raise InvalidArgumentError(f"joints: a joint is listed twice: {out}")
    return out


def detect_contacts(motion, joints=None, *, speed: float = _SPEED_ON,
                    height: float = _HEIGHT_ON, min_duration: float = _MIN_CONTACT, up="y"):
    """Foot contacts of a motion: ``(names, contacts)``, contacts a bool array (N, C).

    joints: the contact points: joint names or indices, or "Joint/End" for a joint's End Site (a
    string may list names separated by commas); default: every foot of :func:`find_feet`,
    ankle then toe (or the ankle's End Site when the skeleton has no toe joint).
    A joint enters contact where its speed is below ``speed`` body heights per second and its
    height along ``up`` above its local floor level (the lowest height within +-0.75 s) below
    ``height`` body heights; it leaves where the speed exceeds twice ``speed`` or the height
    1.5 times ``height`` (hysteresis). Gaps shorter than 0.05 s are closed, then contacts
    shorter than ``min_duration`` seconds dropped. Speeds are central differences over about
    1/30 s, so the same defaults hold at 25-120 fps; body height is the median extent of the
    joints along ``up`` (:func:`mlayer.metrics.body_height` for Y). up: "x", "y" (default) or
    "z", or 0..2. The detection runs in the C core (``mlr_contacts_detect``).
    """
    _check_motion(motion, "detect_contacts")
    ax = axis(up, "detect_contacts")
    opts = []
    for key, v, name in ((lib.MLR_CONTACTS_OPT_SPEED, speed, "speed"),
                         (lib.MLR_CONTACTS_OPT_HEIGHT, height, "height"),
                         (lib.MLR_CONTACTS_OPT_MIN_DURATION, min_duration, "min_duration")):
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise InvalidArgumentError(f"detect_contacts: {name} must be a number, got {v!r}") \
                from None
        if not (np.isfinite(v) and v > 0):
            raise InvalidArgumentError(f"detect_contacts: {name} must be finite and > 0, got {v}")
        opts.append((key, v))
    N = motion.n_frames
    if N < 3:
        raise InvalidArgumentError(f"detect_contacts needs at least 3 frames, got {N}")
    sk = motion.skeleton
    pos, wrot = motion.forward_kinematics()
    if joints is None:
        pts = [p for p in _c_feet(motion, pos, ax) if p[0] >= 0]
    else:
        pts = [_point(sk, n) for n in _resolve_names(motion, joints)]
    names = [_point_name(sk, j, e) for j, e in pts]
    jts, ends = _point_arrays(pts)
    copts = ffi.new("mlr_contacts_option[]", len(opts))
    for i, (key, v) in enumerate(opts):
        copts[i].key, copts[i].value = key, v
    out = np.zeros((N, len(pts)), dtype=np.uint8)
    rig, keep = c_rig(sk)
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_contacts_detect(
        rig, motion.fps, ax, N, ptr(pos, "const double *"), ptr(wrot, "const double *"),
        len(pts), ffi.cast("const int32_t *", ffi.from_buffer(jts)),
        ffi.cast("const int32_t *", ffi.from_buffer(ends)), copts, len(opts),
        ffi.cast("uint8_t *", ffi.from_buffer(out, require_writable=True)), ffi.NULL, diag)
    del keep
    check(code, "detect_contacts", diag)
    return names, out.view(np.bool_)


_SPREAD = 0.3        # seconds: displacements fade to zero this far from a contact
_ROOT_SMOOTH = 0.1   # seconds: time scale of the root correction's smoothing
_PIN_SMOOTH = 0.005  # seconds: time scale of the displacement map's smoothing
_REF_SMOOTH = 0.02   # seconds: smoothing of the reference's contact trajectories
_REACH = 0.98        # the root moves where a leg would need more than this of its length
_ROOT_ITERATIONS = 5  # the smoothed root correction is repeated on what it left
_PASSES = 2          # IK + spread passes (the second removes what the smoothing left)


def _feet_of(sk, names) -> list[tuple[int, list[int], list[int]]]:
    """Group contact points into feet: (ankle joint, columns of the ankle itself (0 or 1),
    columns of points placed by turning the ankle: toes, End Sites)."""
    pts = [_point(sk, n) for n in names]
    listed = {j for j, e in pts if e < 0}
    feet: dict[int, tuple[list[int], list[int]]] = {}
    for c, (j, e) in enumerate(pts):
        if e < 0 and not _has_ancestor_in(sk.parents, j, listed):
            feet.setdefault(j, ([], []))[0].append(c)
    for c, (j, e) in enumerate(pts):
        if e < 0 and j in feet and c in feet[j][0]:
            continue
        # the topmost listed ancestor-or-self of the point's joint, else the joint itself
        anchor, p = (j if e >= 0 else -1), (j if e >= 0 else int(sk.parents[j]))
        while p >= 0:
            if p in feet:
                anchor = p
            p = int(sk.parents[p])
        if anchor < 0:
            anchor = int(sk.parents[j])
        feet.setdefault(anchor, ([], []))[1].append(c)
    return [(a, own, toes) for a, (own, toes) in sorted(feet.items())]


def _spread(frames: np.ndarray, values: np.ndarray, n: int, fps: float) -> np.ndarray:
    """A smooth displacement map over n frames through values (k, m) at the sorted frames,
    returning to zero farther than _SPREAD seconds from them: the LGS (order 2, time scale
    _PIN_SMOOTH: near interpolation) with zero observations added away from the constraints."""
    far = int(round(_SPREAD * fps))
    dist = np.full(n, np.iinfo(np.int64).max // 4, dtype=np.int64)
    idx = np.arange(n)
    near = np.searchsorted(frames, idx)
    left = frames[np.clip(near - 1, 0, len(frames) - 1)]
    right = frames[np.clip(near, 0, len(frames) - 1)]
    dist = np.minimum(np.abs(idx - left), np.abs(idx - right))
    zeros = idx[dist >= far]
    t = np.concatenate([frames, zeros])
    y = np.concatenate([values, np.zeros((zeros.size, values.shape[1]))])
    order = np.argsort(t, kind="stable")
    return lgs(y[order], lam=(_PIN_SMOOTH * fps) ** 2, t=t[order].astype(np.float64), n_out=n)


def _runs_list(mask) -> list[tuple[int, int]]:
    s, e = _runs(mask)
    return list(zip(s.tolist(), e.tolist()))


def _foot_targets(c, cols, own, P, Pr, pos, pos_ref, ankle):
    """Per-frame targets of one foot on the frames U where any of its points is in contact:
    (U, ankle target (N, 3), target of its first placed point (N, 3) or None).

    With a reference, each run of U gets one horizontal offset o (the mean over the run's contact
    samples of motion minus reference); the points then follow the reference's own trajectory
    shifted by o: ankle ``pos_ref + o``, toe ``Pr + o``, so the foot keeps the reference's small
    motion (roll, settling) and its rigid shape, and the heights are the reference's. Without a
    reference each point is pinned to its mean over its contact frames (height too), and an
    ankle not in contact itself moves with its points' mean displacement."""
    N = c.shape[0]
    U = c[:, cols].any(axis=1)
    at = pos[:, ankle].copy()
    toes = [k for k in cols if k not in own]
    tt = P[:, toes[0]].copy() if toes else None
    for a, b in _runs_list(U):
        cc = c[a:b][:, cols]
        if Pr is not None:
            d = (P[a:b][:, cols] - Pr[a:b][:, cols])[cc]
            o = d.mean(axis=0)
            o[1] = 0.0
            at[a:b] = pos_ref[a:b, ankle] + o
            if toes:
                tt[a:b] = Pr[a:b, toes[0]] + o
            continue
        delta = np.zeros((b - a, len(cols), 3))
        for i, col in enumerate(cols):
            for s, e in _runs_list(c[a:b, col]):
                delta[s:e, i] = P[a + s:a + e, col].mean(axis=0) - P[a + s:a + e, col]
        w = cc.sum(axis=1)
        mean_d = (delta * cc[..., None]).sum(axis=1) / np.maximum(w, 1)[:, None]
        if own:
            i = cols.index(own[0])
            mean_d = np.where(cc[:, i, None], delta[:, i], mean_d)
        at[a:b] += mean_d
        if toes:
            i = cols.index(toes[0])
            tt[a:b] += np.where(cc[:, i, None], delta[:, i], mean_d)
    return U, at, tt


def _spread_rotations(rot, new, joints, U, fps):
    """Spread the local-rotation corrections ``new * inv(rot)`` of ``joints``, known on the
    frames U, smoothly over time with the LGS (:func:`_spread`, a displacement map on rotation
    vectors) and apply them to ``rot`` in place."""
    frames = np.flatnonzero(U)
    off = np.concatenate([quat.log(quat.mul(new[frames, j], quat.conj(rot[frames, j])))
                          for j in joints], axis=1)
    smooth = _spread(frames, off, rot.shape[0], fps)
    for i, j in enumerate(joints):
        rot[:, j] = quat.normalize(quat.mul(quat.exp(smooth[:, 3 * i:3 * i + 3]), rot[:, j]))




def fix_contacts(motion, contacts, names, reference=None):
    """Pin the feet of a synthesized motion during its contacts (paper 1, eq. 18).

    motion: the synthesized Motion (after stylize, denoise, resample, ...); contacts, names:
    bool (N, C) and C contact point names as from :func:`detect_contacts` (usually detected on
    the original motion); reference: an optional Motion with the same frames, normally the
    original before synthesis.

    Targets, per foot (an ankle and the points placed by turning it, toe or End Site) on the
    frames where any of its points is in contact: with a reference, each such run gets one
    horizontal offset (the mean of motion minus reference over the run's contact samples) and
    the foot follows the reference's own trajectory (LGS-smoothed over 0.02 s against capture
    noise) shifted by it, so it keeps the original's small motion within the contact (heel
    roll, settling), its shape and its heights; without
    one, each point is pinned to its mean position over its contact interval.

    Correction: the root moves (a smoothed correction, only where needed) where a leg would have
    to stretch beyond 98% of its length; per frame, two-bone IK on each leg (hip, knee,
    ankle, found by walking up the parents) reaches the ankle target and a turn of the ankle
    the toe target. The changes of the local rotations of hip, knee and ankle, known on the
    contact frames, are spread over the other frames as a displacement map on rotation vectors
    solved with the LGS (near-interpolating, back to zero 0.3 s from any contact), so rotations
    stay smooth and nothing pops at contact boundaries; a second pass removes what the
    smoothing left. Returns a new Motion; bone lengths are unchanged.
    """
    from .motion import Motion
    if not isinstance(motion, Motion):
        raise InvalidArgumentError("fix_contacts: motion must be a mlayer.Motion")
    names = [names] if isinstance(names, str) else list(names)
    N = motion.n_frames
    c = np.asarray(contacts)
    if c.dtype != np.bool_ or c.shape != (N, len(names)):
        raise InvalidArgumentError(
            f"fix_contacts: contacts must be a bool array ({N}, {len(names)}) (frames x "
            f"names), got {c.dtype} {c.shape}")
    sk = motion.skeleton
    names = _resolve_names(motion, names) if names else []
    if reference is not None:
        if not isinstance(reference, Motion):
            raise InvalidArgumentError("fix_contacts: reference must be a mlayer.Motion")
        if reference.n_frames != N:
            raise InvalidArgumentError(
                f"fix_contacts: reference has {reference.n_frames} frames, motion {N}")
        for n in names:
            _point(reference.skeleton, n)
    if N < 2 or not c.any():
        return motion.copy()
    fps = motion.fps
    pos, wrot = motion.forward_kinematics()
    P = contact_positions(motion, names, pos, wrot)
    Pr = pos_ref = None
    if reference is not None:
        pos_ref, wrot_ref = reference.forward_kinematics()
        Pr = contact_positions(reference, names, pos_ref, wrot_ref)
    feet = _feet_of(sk, names)
    if reference is not None and _REF_SMOOTH > 0:
        # the reference's contact trajectories without their capture noise (LGS smoothing)
        lam = (_REF_SMOOTH * fps) ** 2
        Pr = lgs(Pr.reshape(N, -1), lam=lam).reshape(Pr.shape)
        ankles = [a for a, _, _ in feet]
        pos_ref = pos_ref.copy()
        pos_ref[:, ankles] = lgs(pos_ref[:, ankles].reshape(N, -1), lam=lam).reshape(
            N, len(ankles), 3)
    legs = []
    for ankle, own, toes in feet:
        cols = own + toes
        if not c[:, cols].any():
            continue
        U, at, tt = _foot_targets(c, cols, own, P, Pr, pos, pos_ref, ankle)
        legs.append((ankle, ik.leg_chain(sk, ankle), U, at,
                     None if tt is None else (toes[0], tt)))
    if not legs:
        return motion.copy()
    root = motion.root_pos + _root_shift(pos, legs, fps)
    rot = motion.rot.copy()
    for _ in range(_PASSES):
        m1 = motion.with_frames(root_pos=root, rot=rot)
        pos1, wrot1 = m1.forward_kinematics()
        new = rot.copy()
        for ankle, chain, U, at, _toe in legs:
            ik.apply_leg(new, pos1, wrot1, sk.parents, chain, np.where(U[:, None], at,
                                                                       pos1[:, ankle]))
        if any(toe is not None for *_, toe in legs):
            m2 = motion.with_frames(root_pos=root, rot=new)
            pos2, wrot2 = m2.forward_kinematics()
            now = contact_positions(m2, names, pos2, wrot2)
            for ankle, chain, U, at, toe in legs:
                if toe is not None:
                    col, target = toe
                    r = ik.from_to(now[:, col] - pos2[:, ankle], target - pos2[:, ankle])
                    ik.rotate_to(new, wrot2, sk.parents, ankle, r)
        for ankle, (h, k, e), U, at, toe in legs:
            _spread_rotations(rot, new, [h, k] + ([e] if toe is not None else []), U, fps)
    return motion.with_frames(root_pos=root, rot=rot)


def _root_shift(pos, legs, fps) -> np.ndarray:
    """A smooth root translation (N, 3) that keeps every ankle target within _REACH of its
    leg's length (or the leg's current extension, up to 99.9%, where it is straighter already)
    on the frames where the foot is in contact (zero where no leg needs it)."""
    N = pos.shape[0]
    shift = np.zeros((N, 3))
    lam = (_ROOT_SMOOTH * fps) ** 2
    half = max(1, int(round(_ROOT_SMOOTH * fps)))
    for _ in range(_ROOT_ITERATIONS):
        need = np.zeros((N, 3))
        for ankle, (h, k, e), U, at, _toe in legs:
            length = (np.linalg.norm(pos[:, k] - pos[:, h], axis=1)
                      + np.linalg.norm(pos[:, e] - pos[:, k], axis=1))
            # a leg already straighter than _REACH may stay so (up to 99.9%)
            now = np.linalg.norm(pos[:, e] - pos[:, h], axis=1)
            reach = np.maximum(_REACH * length, np.minimum(now, 0.999 * length))
            v = at - (pos[:, h] + shift)
            dist = np.linalg.norm(v, axis=1)
            excess = np.where(U, np.maximum(dist - reach, 0.0), 0.0)
            cand = v * (excess / np.maximum(dist, 1e-12))[:, None]
            bigger = np.linalg.norm(cand, axis=1) > np.linalg.norm(need, axis=1)
            need[bigger] = cand[bigger]
        if not need.any():
            break
        # widen each need to the smoothing's time scale first (the largest need within
        # +-_ROOT_SMOOTH), so the smoothed correction covers a need of a single frame
        size = np.linalg.norm(need, axis=1)
        win = np.lib.stride_tricks.sliding_window_view(np.pad(size, half), 2 * half + 1)
        src = np.arange(N) - half + np.argmax(win, axis=1)
        shift += lgs(need[src], lam=lam)
    return shift


def keep_contacts_retimed(original, retimed, reference, source_frames, joints=None):
    """``retimed`` (resampled or time-warped from ``original``) with the feet pinned during the
    contacts detected on ``original``, carried to the output frames: output frame k takes the
    contacts of input frame ``round(source_frames[k])`` (its fractional input frame).
    ``reference`` is the original at the output frames without smoothing (a SLERP resampling
    on the same time map), whose contact trajectories the feet follow. Skeletons without
    recognisable feet (and no ``joints``) and clips of fewer than 3 frames come back
    unchanged, as in :func:`keep_contacts`."""
    if original.n_frames < 3 or retimed.n_frames < 2:
        return retimed
    if joints is None:
        try:
            find_feet(original)
        except InvalidArgumentError:
            return retimed
    names, c = detect_contacts(original, joints)
    k = np.clip(np.rint(np.asarray(source_frames, dtype=np.float64)), 0, original.n_frames - 1)
    return fix_contacts(retimed, c[k.astype(np.int64)], names, reference=reference)


def keep_contacts(original, synthesized, joints=None):
    """``synthesized`` with the feet pinned during the contacts detected on ``original`` (same
    frames): :func:`detect_contacts` then :func:`fix_contacts` with ``original`` as reference.
    A skeleton without recognisable feet (and no ``joints``), or a clip of fewer than 3
    frames, is returned unchanged: this is the default step of stylize/denoise, which also
    work on skeletons that have no feet."""
    if original.n_frames < 3:
        return synthesized
    if joints is None:
        try:
            find_feet(original)
        except InvalidArgumentError:
            return synthesized
    names, c = detect_contacts(original, joints)
    return fix_contacts(synthesized, c, names, reference=original)
