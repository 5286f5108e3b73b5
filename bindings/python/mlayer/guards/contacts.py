"""Foot contacts: detection on a motion, and spacetime cleanup after synthesis (paper 1, 4.3).

Detection (:func:`detect_contacts`, in the C core: mlr_contacts.h) marks, per foot joint
(ankle, and toe where the skeleton has one), the frames where the joint is slow and low, with
hysteresis and a minimum duration, on any up axis.
Every threshold is relative to the body size (:func:`mlayer.guards.metrics.body_height`) and to
seconds, so the defaults work in any length unit and at any frame rate. Height is measured above
the joint's own local floor level (its lowest height within +-0.75 s), so an ankle that sits
above the sole, a dog's raised hock, slopes and a lying phase need no calibration.

Cleanup (:func:`mlayer.guards.cleanup.fix_contacts`, in the C core: mlr_cleanup.h) implements eq.
18, ``M* = M' (+) delta_e``. Targets: on the frames where a foot touches, it follows the original's
own contact trajectory (smoothed over 0.02 s to drop capture noise), shifted horizontally by one
offset per contact toward where the synthesized foot is, at the original's heights; so the foot
keeps the original's heel roll and settling and slides no more than the original did. The root
moves by a smoothed correction only where a leg would have to stretch beyond 98% of its length;
analytic two-bone IK on each leg (:mod:`mlayer.guards.ik`) reaches the targets on the contact
frames (a toe is placed by turning its ankle), and the resulting changes of the hip, knee and ankle
rotations are spread over the neighbouring frames by the LGS as a displacement map on rotation
vectors (interpolating the contact frames, back to zero 0.3 s away), so the rotations stay
smooth and nothing pops at contact boundaries. Heights are along the motion's up axis
(:attr:`mlayer.Motion.up_axis`).
"""
from __future__ import annotations

import re
from collections.abc import Collection, Iterable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._arrays import as_f64, number, ptr, ptr_out
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..model._rig import c_rig, motion_axis
from ..model.motion import Motion

if TYPE_CHECKING:
    from ..model.motion import Motion, Skeleton

__all__ = ["find_feet", "detect_contacts", "contact_intervals", "contact_positions", "END_SUFFIX",
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


def _has_ancestor_in(parents: NDArray[np.int32], j: int, group: Collection[int]) -> bool:
    p = int(parents[j])
    while p >= 0:
        if p in group:
            return True
        p = int(parents[p])
    return False


END_SUFFIX = "/End"


def _end_site_of(sk: Skeleton, j: int) -> int:
    """Index of the first End Site below joint j, or -1."""
    hits = np.flatnonzero(sk.end_site_parents == j)
    return int(hits[0]) if hits.size else -1


def _check_motion(motion: Any, where: str) -> None:
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"{where}: motion must be a mlayer.Motion")


def _positions_arg(motion: Motion, positions: ArrayLike, name: str, last: int
                   ) -> NDArray[np.float64]:
    shape = (motion.n_frames, motion.n_joints, last)
    a = as_f64(positions, name)
    if a.shape != shape:
        raise InvalidArgumentError(f"{name}: expected shape {shape}, got {a.shape}")
    return a


def _c_feet(motion: Motion, pos: NDArray[np.float64] | None, up: int) -> list[tuple[int, int]]:
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
        rig, N, ptr(pos, "const double *") if pos is not None and N else ffi.NULL, up, J,
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


def _point_name(sk: Skeleton, j: int, e: int) -> str:
    return sk.joint_names[j] + (END_SUFFIX if e >= 0 else "")


def find_feet(motion: Motion, positions: NDArray[np.float64] | None = None, *,
              up: str | int | None = None) -> list[tuple[str, str | None]]:
    """The feet of a skeleton found by joint name.

    Ankles: the topmost joint of each chain whose name matches :data:`FOOT_PATTERN`. A toe:
    the child of that ankle matching :data:`TOE_PATTERN` (the one with the longest OFFSET when
    there are several, as MakeHuman's five toes; also one behind zero-length joints); without
    one, the ankle's End Site, named ``"<ankle>/End"`` (the toe tip of the Daz skeletons, the
    paw of the AI4Animation dog). Joints matching :data:`HAND_PATTERN` are feet too when they
    stay low (median height along ``up`` within 0.2 body heights of the feet's: a quadruped's
    front feet). The rules run in the C core (``mlr_contacts_find_feet``).

    Parameters
    ----------
    motion : Motion
        The motion.
    positions : numpy.ndarray, shape (N, J, 3), optional
        Its world positions when already at hand.
    up : {"x", "y", "z", 0, 1, 2}, optional
        The up axis; None (default): the motion's :attr:`~mlayer.Motion.up_axis`.

    Returns
    -------
    list of (str, str or None)
        (ankle, toe or None) names, one pair per foot.

    Raises
    ------
    mlayer.InvalidArgumentError
        Naming the patterns and the skeleton's joints, when no foot is found.
    """
    _check_motion(motion, "find_feet")
    ax = motion_axis(motion, up, "find_feet")
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


def _point(sk: Skeleton, name: str | int) -> tuple[int, int]:
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


def _point_arrays(pts: Sequence[tuple[int, int]]
                  ) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    joints = np.ascontiguousarray([j for j, _ in pts], dtype=np.int32)
    ends = np.ascontiguousarray([e for _, e in pts], dtype=np.int32)
    return joints, ends


def contact_positions(motion: Motion, names: str | Sequence[str | int],
                      pos: NDArray[np.float64] | None = None,
                      wrot: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """World positions of contact points, by the C core (``mlr_rig_point_positions``).

    Parameters
    ----------
    motion : Motion
        The motion.
    names : str or sequence of (str or int)
        Joints (names or indices), or End Sites (``"Joint/End"``).
    pos, wrot : numpy.ndarray, shape (N, J, 3) and (N, J, 4), optional
        The motion's forward kinematics when already at hand.

    Returns
    -------
    numpy.ndarray, shape (N, C, 3)
        The positions.

    Raises
    ------
    mlayer.InvalidArgumentError
        For an unknown joint or a joint without End Site.
    """
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


def _runs(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(starts, ends) of the True runs of a 1-D bool array, ends exclusive."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def contact_intervals(contacts_column: ArrayLike) -> list[tuple[int, int]]:
    """The contact intervals of one column of a contact array.

    Parameters
    ----------
    contacts_column : array_like of bool, shape (N,)
        One contact point's flags.

    Returns
    -------
    list of (int, int)
        The intervals [start, end), end exclusive.
    """
    s, e = _runs(np.asarray(contacts_column, dtype=bool))
    return list(zip(s.tolist(), e.tolist()))


def _resolve_names(motion: Motion, joints: str | Iterable[str | int]) -> list[str]:
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


def detect_contacts(motion: Motion, joints: str | Sequence[str | int] | None = None, *,
                    speed: float = _SPEED_ON, height: float = _HEIGHT_ON,
                    min_duration: float = _MIN_CONTACT, up: str | int | None = None,
                    pos: NDArray[np.float64] | None = None,
                    wrot: NDArray[np.float64] | None = None
                    ) -> tuple[list[str], NDArray[np.bool_]]:
    """Foot contacts of a motion.

    A joint enters contact where its speed is below ``speed`` body heights per second and its
    height along ``up`` above its local floor level (the lowest height within +-0.75 s) below
    ``height`` body heights; it leaves where the speed exceeds twice ``speed`` or the height
    1.5 times ``height`` (hysteresis). Gaps shorter than 0.05 s are closed, then contacts
    shorter than ``min_duration`` seconds dropped. Speeds are central differences over about
    1/30 s, so the same defaults hold at 25-120 fps; body height is the median extent of the
    joints along ``up`` (:func:`mlayer.guards.metrics.body_height`). The detection runs in the C
    core (``mlr_contacts_detect``).

    Parameters
    ----------
    motion : Motion
        The motion (at least 3 frames).
    joints : str or sequence of (str or int), optional
        The contact points: joint names or indices, or ``"Joint/End"`` for a joint's End Site
        (a string may list names separated by commas); default: every foot of
        :func:`find_feet`, ankle then toe (or the ankle's End Site when the skeleton has no
        toe joint).
    speed : float, optional
        Body heights per second.
    height : float, optional
        Body heights above the local floor level.
    min_duration : float, optional
        Seconds.
    up : {"x", "y", "z", 0, 1, 2}, optional
        The up axis; None (default): the motion's :attr:`~mlayer.Motion.up_axis`.
    pos, wrot : numpy.ndarray, shape (N, J, 3) and (N, J, 4), optional
        The motion's forward kinematics when already at hand (both, or neither).

    Returns
    -------
    names : list of str
        The C contact points.
    contacts : numpy.ndarray of bool, shape (N, C)
        Whether each point is in contact in each frame.

    Raises
    ------
    mlayer.InvalidArgumentError
        For fewer than 3 frames, unknown joints, thresholds out of range, or no foot found.
    """
    _check_motion(motion, "detect_contacts")
    ax = motion_axis(motion, up, "detect_contacts")
    opts = []
    for key, v, name in ((lib.MLR_CONTACTS_OPT_SPEED, speed, "speed"),
                         (lib.MLR_CONTACTS_OPT_HEIGHT, height, "height"),
                         (lib.MLR_CONTACTS_OPT_MIN_DURATION, min_duration, "min_duration")):
        opts.append((key, number(v, f"detect_contacts: {name}")))  # the range is checked in C
    N = motion.n_frames
    if N < 3:
        raise InvalidArgumentError(f"detect_contacts needs at least 3 frames, got {N}")
    sk = motion.skeleton
    if pos is None or wrot is None:
        pos, wrot = motion.forward_kinematics()
    pos = _positions_arg(motion, pos, "detect_contacts: pos", 3)
    wrot = _positions_arg(motion, wrot, "detect_contacts: wrot", 4)
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
