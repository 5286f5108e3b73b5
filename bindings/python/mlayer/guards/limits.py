"""Joint limits (paper 1, section 6.1): a range per joint that style modulation may exaggerate
into and not past, applied with a soft saturation that keeps the motion C1.

    lim = mlayer.joint_limits(motion)            # learned from the clip (and the human table)
    lim.set_range("LeftLeg", lo=0.0, hi=2.4)     # explicit ranges by joint name (radians)
    out, report = mlayer.guards.limits.apply_limits(stylized, lim, alphas)

The model lives in the C core (include/mlayer/mlr_limits.h): knees and elbows are hinges
(never bent the other way beyond the input's own reversal, never folded past 150 degrees or
the input's largest angle); other joints get a swing cone and a twist range about their mean
rotation, from published human ranges of motion on human rigs and from the input (widened by
|alpha|) elsewhere.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, NoReturn, SupportsIndex

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._handles import ReadOnlyAttributes, refuse_copy
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..model._rig import c_rig
from ..model.motion import Motion


KINDS = {lib.MLR_LIMITS_FREE: "free", lib.MLR_LIMITS_HINGE: "hinge",
         lib.MLR_LIMITS_SWING_TWIST: "swing-twist"}
_KIND_CODES = {v: k for k, v in KINDS.items()}
SOURCES = {lib.MLR_LIMITS_SOURCE_NONE: "-", lib.MLR_LIMITS_SOURCE_TABLE: "table",
           lib.MLR_LIMITS_SOURCE_INPUT: "input", lib.MLR_LIMITS_SOURCE_USER: "user"}


class JointLimits(ReadOnlyAttributes):
    """Ranges per joint for one skeleton (a handle on the C model). Angles in radians.

    Made by :func:`joint_limits`. Streams and syntheses borrow the C model, so it has no
    ``close()``: it is freed with the last reference. ``copy.copy``, ``copy.deepcopy`` and
    pickling raise TypeError (a copy that shared the model would see the other's
    :meth:`set_range`; make another with :func:`joint_limits`).

    Parameters
    ----------
    handle : cffi ``mlr_limits *``
        The C model (owned, with its finalizer).
    joint_names : iterable of str
        The skeleton's joint names.
    """

    _readonly = ("_h", "_names")

    def __init__(self, handle: Any, joint_names: Iterable[str]) -> None:
        self._h = handle
        self._names = tuple(joint_names)

    @property
    def joint_names(self) -> list[str]:
        """The skeleton's joint names."""
        return list(self._names)

    def __copy__(self) -> NoReturn:
        raise refuse_copy(self, hint="make another with mlayer.joint_limits")

    def __deepcopy__(self, memo: dict[int, Any]) -> NoReturn:
        raise refuse_copy(self, hint="make another with mlayer.joint_limits")

    def __reduce_ex__(self, protocol: SupportsIndex) -> NoReturn:
        raise refuse_copy(self, "pickle", hint="make another with mlayer.joint_limits")

    @property
    def n_joints(self) -> int:
        """The number of joints J."""
        return len(self._names)

    @property
    def human(self) -> bool:
        """Whether the rig was taken as human (ranges from the published table)."""
        return bool(lib.mlr_limits_is_human(self._h))

    def _index(self, joint: str | int, name: str = "joint") -> int:
        if isinstance(joint, str):
            try:
                return self._names.index(joint)
            except ValueError:
                raise InvalidArgumentError(f"{name}: no joint named {joint!r}") from None
        if isinstance(joint, (int, np.integer)) and 0 <= int(joint) < self.n_joints:
            return int(joint)
        raise InvalidArgumentError(f"{name}: expected a joint name or an index in "
                                   f"[0, {self.n_joints}), got {joint!r}")

    def range(self, joint: str | int) -> dict[str, Any]:
        """The range of a joint.

        Parameters
        ----------
        joint : str or int
            A joint name or index.

        Returns
        -------
        dict
            ``kind`` ("free", "hinge", "swing-twist"), ``lo``/``hi`` (hinge), ``swing``/
            ``twist`` (swing-twist), ``widen`` (bool), ``source``.
        """
        j = self._index(joint)
        r = ffi.new("mlr_limits_range *")
        check(lib.mlr_limits_get_range(self._h, j, r), "JointLimits.range")
        return {"kind": KINDS[r.kind], "lo": r.lo, "hi": r.hi, "swing": r.swing,
                "twist": r.twist, "widen": bool(r.widen), "source": SOURCES[r.source]}

    def geometry(self, joint: str | int) -> dict[str, Any]:
        """The learned geometry of a joint.

        Parameters
        ----------
        joint : str or int
            A joint name or index.

        Returns
        -------
        dict
            ``centre`` (4,), ``axis`` (3,: the hinge axis in the parent frame; zero when
            none), ``bone_in`` (3,), ``bone_out`` (3,), and the input's stats ``min_angle``,
            ``max_angle`` (hinge angle), ``max_swing``, ``max_twist`` (largest |twist|).
            ``min_angle`` and ``max_angle`` are measured on the hinge candidates only (the
            joints with an axis named as hinges: knee, elbow; every joint but the root when
            the rig has no names) and are 0 on every other joint.
        """
        j = self._index(joint)
        c, ax, bi, bo, st = (np.empty(4), np.empty(3), np.empty(3), np.empty(3), np.empty(4))
        check(lib.mlr_limits_get_geometry(self._h, j, _arrays.ptr_out(c), _arrays.ptr_out(ax),
                                          _arrays.ptr_out(bi), _arrays.ptr_out(bo),
                                          _arrays.ptr_out(st)), "JointLimits.geometry")
        return {"centre": c, "axis": ax, "bone_in": bi, "bone_out": bo,
                "min_angle": st[0], "max_angle": st[1], "max_swing": st[2], "max_twist": st[3]}

    def hinges(self) -> list[int]:
        """Indices of the hinge joints.

        Returns
        -------
        list of int
            The joints whose range kind is "hinge".
        """
        return [j for j in range(self.n_joints) if self.range(j)["kind"] == "hinge"]

    def set_range(self, joint: str | int, *, kind: str | None = None, lo: float | None = None,
                  hi: float | None = None, swing: float | None = None,
                  twist: float | None = None, widen: bool | None = None) -> None:
        """Set a joint's range explicitly; unspecified fields keep their current values.

        Parameters
        ----------
        joint : str or int
            A joint name or index.
        kind : {"free", "hinge", "swing-twist"}, optional
            The kind of range.
        lo, hi : float, optional
            Hinge bounds, radians.
        swing, twist : float, optional
            Swing-twist bounds, radians.
        widen : bool, optional
            Whether the bounds widen with the synthesis' alpha.

        Raises
        ------
        mlayer.InvalidArgumentError
            For an unknown joint or kind, or values the C core refuses.
        """
        j = self._index(joint)
        cur = self.range(j)
        r = ffi.new("mlr_limits_range *")
        k = cur["kind"] if kind is None else kind
        if k not in _KIND_CODES:
            raise InvalidArgumentError(f"kind must be one of {sorted(_KIND_CODES)}, got {kind!r}")
        r.kind = _KIND_CODES[k]
        for field, v in (("lo", lo), ("hi", hi), ("swing", swing), ("twist", twist)):
            setattr(r, field, cur[field] if v is None else _arrays.finite(v, field))
        r.widen = int(cur["widen"] if widen is None else bool(widen))
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_limits_set_range(self._h, j, r, diag),
              f"JointLimits.set_range({self.joint_names[j]!r})", diag)

    def table(self) -> str:
        """A readable table of the ranges per joint (degrees).

        Returns
        -------
        str
            One line per joint after a header.
        """
        rows = [f"{'joint':<18} {'kind':<11} {'range (deg)':<28} {'source':<6}"]
        for j, n in enumerate(self.joint_names):
            r = self.range(j)
            if r["kind"] == "hinge":
                txt = f"{math.degrees(r['lo']):7.1f} .. {math.degrees(r['hi']):6.1f}"
            elif r["kind"] == "swing-twist":
                txt = (f"swing {math.degrees(r['swing']):5.1f} twist "
                       f"{math.degrees(r['twist']):5.1f}" + (" *|a|" if r["widen"] else ""))
            else:
                txt = "-"
            rows.append(f"{n:<18} {r['kind']:<11} {txt:<28} {r['source']:<6}")
        return "\n".join(rows)

    def __repr__(self) -> str:
        kinds = [self.range(j)["kind"] for j in range(self.n_joints)]
        return (f"<JointLimits {self.n_joints} joints, {'human' if self.human else 'non-human'}"
                f", {kinds.count('hinge')} hinges, {kinds.count('swing-twist')} swing-twist>\n"
                + self.table())

    def apply(self, rot: ArrayLike, alphas: float | ArrayLike = 1.0
              ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Limit local rotations.

        Parameters
        ----------
        rot : array_like, shape (N, J, 4)
            Local rotations.
        alphas : float or array_like, optional
            A number, J or 1 + J values: the synthesis' alphas the ranges widen with.

        Returns
        -------
        rotations : numpy.ndarray, shape (N, J, 4)
            The limited rotations.
        counts : numpy.ndarray of int64, shape (J,)
            Frames limited per joint.
        """
        rot = _arrays.as_f64(rot, "rot", ndim=3, last=(4,))
        if rot.shape[1] != self.n_joints:
            raise InvalidArgumentError(f"rot: expected {self.n_joints} joints, got "
                                       f"{rot.shape[1]}")
        a = self._alphas(alphas)
        out = np.empty_like(rot)
        counts = ffi.new("size_t[]", self.n_joints)
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_limits_apply(self._h, rot.shape[0], _arrays.ptr(rot), _arrays.ptr_out(out),
                                   _arrays.ptr(a), a.size, counts, self.n_joints, diag),
              "apply_limits", diag)
        return out, np.array([counts[j] for j in range(self.n_joints)], dtype=np.int64)

    def _alphas(self, alphas: float | ArrayLike) -> NDArray[np.float64]:
        a = np.atleast_1d(_arrays.as_f64(alphas, "alphas"))
        if a.ndim != 1 or a.size not in (1, self.n_joints, 1 + self.n_joints):
            raise InvalidArgumentError(f"alphas: expected a number, J = {self.n_joints} or "
                                       f"1 + J values, got shape {np.shape(alphas)}")
        if not np.all(np.isfinite(a)):
            raise InvalidArgumentError("alphas must be finite")
        if a.size == self.n_joints:
            a = np.concatenate([[1.0], a])
        return np.ascontiguousarray(a)


def joint_limits(motions: Motion | Iterable[Motion], *, human: bool | None = None,
                 fold_degrees: float = 150.0, soft: float = 0.15,
                 reversal_soft_degrees: float = 10.0,
                 ranges: Mapping[str, Mapping[str, Any]] | None = None) -> JointLimits:
    """Joint limits for the skeleton of a motion (or a list of motions of one skeleton).

    Parameters
    ----------
    motions : Motion or iterable of Motion
        The clips the ranges are learned from.
    human : bool, optional
        None: decide from the names and proportions; True/False: force.
    fold_degrees : float, optional
        The fold bound of knees and elbows (raised to the input's largest), in (0, 180].
    soft : float, optional
        Soft width as a fraction of a bound, in (0, 1).
    reversal_soft_degrees : float, optional
        Soft width at a hinge's reversal bound, in (0, 90].
    ranges : dict, optional
        Joint name -> dict of :meth:`JointLimits.set_range` arguments.

    Returns
    -------
    JointLimits
        The model.

    Raises
    ------
    mlayer.InvalidArgumentError
        For bad arguments, skeletons that differ, non-finite data.
    """
    ms = [motions] if isinstance(motions, Motion) else list(motions)
    if not ms or not all(isinstance(m, Motion) for m in ms):
        raise InvalidArgumentError("motions: expected a Motion or a non-empty list of Motions")
    first = ms[0]
    for k, m in enumerate(ms[1:], 1):
        if m.skeleton != first.skeleton:
            raise InvalidArgumentError(f"motions[{k}]: skeleton differs from motions[0]")
    opts = []
    if human is not None:
        opts.append((lib.MLR_LIMITS_OPT_HUMAN, 1.0 if human else 0.0))
    # C takes fold and reversal_soft in radians: the degree ranges are checked here, by the
    # Python names (docs/OPTIONS.md); soft goes to C as it is, which checks it by that name
    for name, v, hi in (("fold_degrees", fold_degrees, 180.0),
                        ("reversal_soft_degrees", reversal_soft_degrees, 90.0)):
        if not 0.0 < _arrays.finite(v, name) <= hi:
            raise InvalidArgumentError(f"{name} must be in (0, {hi:g}], got {v!r}")
    opts.append((lib.MLR_LIMITS_OPT_FOLD, math.radians(fold_degrees)))
    opts.append((lib.MLR_LIMITS_OPT_SOFT, _arrays.number(soft, "soft")))
    opts.append((lib.MLR_LIMITS_OPT_REVERSAL_SOFT, math.radians(reversal_soft_degrees)))
    copts = ffi.new("mlr_limits_option[]", len(opts))
    for k, (key, v) in enumerate(opts):
        copts[k].key, copts[k].value = key, v
    rig, keep = c_rig(first.skeleton)
    clips = ffi.new("mlr_limits_clip[]", len(ms))
    arrays = []
    for k, m in enumerate(ms):
        _, rot, trans = m._frames()
        arrays.append((rot, trans))
        clips[k].n_frames = m.n_frames
        clips[k].rot = _arrays.ptr(rot)
        clips[k].trans = _arrays.ptr(trans) if trans.size else ffi.NULL
    out = ffi.new("mlr_limits **")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_limits_create(rig, clips, len(ms), copts, len(opts), ffi.NULL, out, diag),
          "joint_limits", diag)
    lim = JointLimits(ffi.gc(out[0], lib.mlr_limits_destroy), first.joint_names)
    if ranges:
        for name, kw in ranges.items():
            if not isinstance(kw, dict):
                raise InvalidArgumentError(f"ranges[{name!r}]: expected a dict of set_range "
                                           f"arguments, got {kw!r}")
            lim._index(name, "ranges")
            lim.set_range(name, **kw)
    return lim


def apply_limits(motion: Motion, limits: JointLimits, alphas: float | ArrayLike = 1.0
                 ) -> tuple[Motion, dict[str, int]]:
    """Limit a (synthesized) motion's local rotations.

    Parameters
    ----------
    motion : Motion
        The motion.
    limits : JointLimits
        Made for its skeleton.
    alphas : float or array_like, optional
        As for :meth:`JointLimits.apply`.

    Returns
    -------
    motion : Motion
        The limited motion.
    report : dict of str to int
        Joint name -> frames limited (joints never limited left out), plus ``"frames"``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For something else than a Motion and JointLimits, or limits of another skeleton.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"motion: expected a Motion, got {type(motion).__name__}")
    if not isinstance(limits, JointLimits):
        raise InvalidArgumentError(f"limits: expected JointLimits, got {type(limits).__name__}")
    if motion.joint_names != limits.joint_names:
        raise InvalidArgumentError("limits: made for another skeleton")
    rot, counts = limits.apply(motion.rot, alphas)
    report = {n: int(c) for n, c in zip(limits.joint_names, counts) if c}
    report["frames"] = motion.n_frames
    return motion.with_frames(rot=rot), report
