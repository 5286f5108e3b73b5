"""Foot contacts: detection on a motion, and spacetime cleanup after synthesis (paper 1, 4.3).

Detection (:func:`detect_contacts`) marks, per foot joint (ankle, and toe where the skeleton
has one), the frames where the joint is slow and low, with hysteresis and a minimum duration.
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
from .errors import InvalidArgumentError
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

# detection defaults (body heights, seconds)
_SPEED_ON, _SPEED_OFF = 0.25, 0.5      # body heights per second
_HEIGHT_ON, _HEIGHT_OFF = 0.06, 0.09   # body heights above the local floor level
_MIN_CONTACT, _MAX_GAP = 0.08, 0.05    # seconds
_FLOOR_WINDOW = 0.75                   # seconds each side for the local floor level
_HAND_LOW = 0.2                        # hands within this (body heights) of the feet are feet


def _has_ancestor_in(parents, j: int, group) -> bool:
    p = int(parents[j])
    while p >= 0:
        if p in group:
            return True
        p = int(parents[p])
    return False


def _descendants(parents, j: int) -> list[int]:
    out, frontier = [], {j}
    for k in range(j + 1, len(parents)):
        if int(parents[k]) in frontier:
            frontier.add(k)
            out.append(k)
    return out


END_SUFFIX = "/End"


def _end_site_of(sk, j: int) -> int:
    """Index of the first End Site below joint j, or -1."""
    hits = np.flatnonzero(sk.end_site_parents == j)
    return int(hits[0]) if hits.size else -1


def find_feet(motion, positions: np.ndarray | None = None) -> list[tuple[str, str | None]]:
    """The feet of a skeleton found by joint name: a list of (ankle, toe or None) names.

    Ankles: the topmost joint of each chain whose name matches :data:`FOOT_PATTERN`. A toe:
    the child of that ankle matching :data:`TOE_PATTERN` (the one with the longest OFFSET when
    there are several, as MakeHuman's five toes); without one, the ankle's End Site, named
    ``"<ankle>/End"`` (the toe tip of the Daz skeletons, the paw of the AI4Animation dog).
    Joints matching :data:`HAND_PATTERN` are feet too when they stay low (median height within
    0.2 body heights of the feet's: a quadruped's front feet). Raises InvalidArgumentError
    naming the patterns and the skeleton's joints when no foot is found.
    """
    sk = motion.skeleton
    names, parents = sk.joint_names, sk.parents
    found = {j for j, n in enumerate(names) if FOOT_PATTERN.search(n)}
    ankles = [j for j in sorted(found) if not _has_ancestor_in(parents, j, found)]
    if not ankles:
        raise InvalidArgumentError(
            "no feet found: no joint name matches /" + FOOT_PATTERN.pattern + "/ (case-"
            "insensitive; toes: /" + TOE_PATTERN.pattern + "/ below a foot). Name the contact "
            "joints yourself: joints=['LeftFoot', 'LeftToeBase', ...] (Python) or --joints "
            "LeftFoot,LeftToeBase (command line); 'Joint/End' names a joint's End Site. Joints "
            "of this skeleton: " + ", ".join(names[:40]) + (" ..." if len(names) > 40 else ""))
    hands = [j for j, n in enumerate(names) if HAND_PATTERN.search(n)]
    hands = [j for j in hands if not _has_ancestor_in(parents, j, set(hands))]
    if hands and motion.n_frames:
        p = motion.positions() if positions is None else positions
        H = float(np.median(p[..., 1].max(axis=1) - p[..., 1].min(axis=1))) or 1.0
        ground = p[..., 1].min(axis=1)
        foot_h = np.median(p[:, ankles, 1] - ground[:, None])
        for j in hands:
            if np.median(p[:, j, 1] - ground) <= foot_h + _HAND_LOW * H:
                ankles.append(j)
    ankles.sort()
    lengths = np.linalg.norm(sk.offsets, axis=1)
    feet = []
    for a in ankles:
        kids = [k for k in sk.children(a) if TOE_PATTERN.search(names[k])]
        if not kids:  # a toe behind a zero-length joint
            kids = [k for k in _descendants(parents, a) if TOE_PATTERN.search(names[k])
                    and all(lengths[x] <= 1e-9 for x in _path_between(parents, a, k)[:-1])]
        if kids:
            toe = names[max(kids, key=lambda k: lengths[k])]
        elif _end_site_of(sk, a) >= 0:
            toe = names[a] + END_SUFFIX
        else:
            toe = None
        feet.append((names[a], toe))
    return feet


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


def contact_positions(motion, names, pos=None, wrot=None) -> np.ndarray:
    """(N, C) world positions (N, C, 3) of contact points: joints, or End Sites ("Joint/End")."""
    sk = motion.skeleton
    pts = [_point(sk, n) for n in names]
    if pos is None or (wrot is None and any(e >= 0 for _, e in pts)):
        pos, wrot = motion.forward_kinematics()
    out = np.empty((pos.shape[0], len(pts), 3))
    for c, (j, e) in enumerate(pts):
        out[:, c] = pos[:, j]
        if e >= 0:
            out[:, c] += ik._rotate(wrot[:, j], np.broadcast_to(sk.end_site_offsets[e],
                                                                (pos.shape[0], 3)))
    return out


def _path_between(parents, a: int, k: int) -> list[int]:
    """Joints from below a down to k (inclusive)."""
    path = []
    while k != a and k >= 0:
        path.append(k)
        k = int(parents[k])
    return path[::-1]


def _moving_min(x: np.ndarray, half: int) -> np.ndarray:
    """Minimum over the window [t - half, t + half] along axis 0 (van Herk / Gil-Werman)."""
    n = x.shape[0]
    if half <= 0 or n <= 1:
        return x.copy()
    w = 2 * half + 1
    pad = np.concatenate([np.full((half,) + x.shape[1:], np.inf), x,
                          np.full((half + (-(n + 2 * half)) % w,) + x.shape[1:], np.inf)])
    blocks = pad.reshape((-1, w) + x.shape[1:])
    fwd = np.minimum.accumulate(blocks, axis=1).reshape(pad.shape)
    bwd = np.minimum.accumulate(blocks[:, ::-1], axis=1)[:, ::-1].reshape(pad.shape)
    # window starting at i (in padded coordinates) covers i .. i + w - 1
    i = np.arange(n)
    return np.minimum(bwd[i], fwd[i + w - 1])


def _runs(mask: np.ndarray):
    """(starts, ends) of the True runs of a 1-D bool array, ends exclusive."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def contact_intervals(contacts_column) -> list[tuple[int, int]]:
    """The contact intervals [start, end) of one column of a contact array."""
    s, e = _runs(np.asarray(contacts_column, dtype=bool))
    return list(zip(s.tolist(), e.tolist()))


def _hysteresis(on: np.ndarray, off: np.ndarray) -> np.ndarray:
    """Enter where `on`, leave where `off`, keep the state otherwise (per column, from False)."""
    n = on.shape[0]
    event = np.where(on, 1, np.where(off, 0, -1))
    idx = np.where(event >= 0, np.arange(n)[:, None], -1)
    last = np.maximum.accumulate(idx, axis=0)
    state = np.take_along_axis(event, np.maximum(last, 0), axis=0)
    return (state == 1) & (last >= 0)


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
                    height: float = _HEIGHT_ON, min_duration: float = _MIN_CONTACT):
    """Foot contacts of a motion: ``(names, contacts)``, contacts a bool array (N, C).

    joints: the contact points: joint names or indices, or "Joint/End" for a joint's End Site (a
    string may list names separated by commas); default: every foot of :func:`find_feet`,
    ankle then toe (or the ankle's End Site when the skeleton has no toe joint).
    A joint enters contact where its speed is below ``speed`` body heights per second and its
    height above its local floor level (the lowest height within +-0.75 s) below ``height``
    body heights; it leaves where the speed exceeds twice ``speed`` or the height 1.5 times
    ``height`` (hysteresis). Gaps shorter than 0.05 s are closed, then contacts shorter than
    ``min_duration`` seconds dropped. Speeds are central differences over about 1/30 s, so the
    same defaults hold at 25-120 fps; body height is :func:`mlayer.metrics.body_height`.
    """
    from .motion import Motion
    if not isinstance(motion, Motion):
        raise InvalidArgumentError("detect_contacts: motion must be a mlayer.Motion")
    for v, name in ((speed, "speed"), (height, "height"), (min_duration, "min_duration")):
        if not (np.isfinite(v) and v > 0):
            raise InvalidArgumentError(f"detect_contacts: {name} must be finite and > 0, got {v}")
    N = motion.n_frames
    if N < 3:
        raise InvalidArgumentError(f"detect_contacts needs at least 3 frames, got {N}")
    pos, wrot = motion.forward_kinematics()
    if joints is None:
        names = []
        for a, t in find_feet(motion, pos):
            names += [a] if t is None else [a, t]
    else:
        names = _resolve_names(motion, joints)
    H = body_height(pos)
    if not H > 0:
        raise InvalidArgumentError("detect_contacts: the motion has no vertical extent (flat "
                                   "skeleton), so no body size to scale thresholds by")
    fps = motion.fps
    p = contact_positions(motion, names, pos, wrot)
    k = max(1, int(round(fps / 60.0)))
    v = np.empty(p.shape[:2])
    if N > 2 * k:
        v[k:N - k] = np.linalg.norm(p[2 * k:] - p[:N - 2 * k], axis=-1) / (2 * k / fps)
        v[:k], v[N - k:] = v[k], v[N - k - 1]
    else:
        v[:] = np.linalg.norm(p[-1] - p[0], axis=-1) / ((N - 1) / fps)
    y = p[..., 1]
    floor = _moving_min(y, int(round(_FLOOR_WINDOW * fps)))
    h = y - floor
    on = (v < speed * H) & (h < height * H)
    off = (v > 2.0 * speed * H) | (h > 1.5 * height * H)
    c = _hysteresis(on, off)
    gap = int(round(_MAX_GAP * fps))
    shortest = max(2, int(round(min_duration * fps)))
    for col in range(c.shape[1]):
        s, e = _runs(~c[:, col])
        for a, b in zip(s, e):
            if a > 0 and b < N and b - a <= gap:
                c[a:b, col] = True
        s, e = _runs(c[:, col])
        for a, b in zip(s, e):
            if b - a < shortest:
                c[a:b, col] = False
    return names, c


# The cleanup (fix_contacts, keep_contacts, keep_contacts_retimed) lives in the C core now
# (mlr_cleanup.h), wrapped by mlayer.cleanup; re-exported here so existing imports keep working.
from .cleanup import fix_contacts, keep_contacts, keep_contacts_retimed  # noqa: E402,F401
