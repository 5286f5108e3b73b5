"""Cleanup of a synthesized motion in the C core (mlr_cleanup.h): feet pinned during the
contacts detected on the original, and kept above the original's floor.

:func:`fix_contacts` wraps ``mlr_cleanup_contacts``: per foot (an ankle and the points placed by
turning it: toe or End Site), on the frames where any of its points is in contact, targets follow
the reference's own contact trajectories shifted by one horizontal offset per contact (without a
reference: each point pinned to its mean); the root moves only where a leg cannot reach; two-bone
IK (:mod:`mlayer.guards.ik`) reaches the targets, and the rotation changes are spread in time by a
displacement map that blends to zero within ``blend`` seconds of the constrained frames (then
smoothed outside them, the constrained frames held), so frames farther from every contact keep
the synthesized motion.

Floor (``floor="auto"``, the default): a flat floor at :func:`floor_height` of the reference (the
5% quantile of the contact points' heights on their contact frames); no foot point goes below
min(floor, the reference's own height of that point in that frame); a foot that would is raised
by IK on its leg, spread in time like the contact correction. ``floor=None`` turns it off, a
number sets the height. The up axis is the motion's (:attr:`Motion.up_axis`) unless ``up``
says otherwise.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..model._rig import c_rig, motion_axis
from ..model.motion import Motion
from .contacts import _point, _resolve_names, detect_contacts, find_feet

if TYPE_CHECKING:
    from ..model.motion import Motion, Skeleton

__all__ = ["fix_contacts", "keep_contacts", "keep_contacts_retimed", "floor_height"]

_OPT = {"blend": lib.MLR_CLEANUP_OPT_BLEND, "reach": lib.MLR_CLEANUP_OPT_REACH,
        "passes": lib.MLR_CLEANUP_OPT_PASSES, "floor_quantile": lib.MLR_CLEANUP_OPT_FLOOR_QUANTILE,
        "ref_smooth": lib.MLR_CLEANUP_OPT_REF_SMOOTH, "pin_smooth": lib.MLR_CLEANUP_OPT_PIN_SMOOTH,
        "root": lib.MLR_CLEANUP_OPT_ROOT, "max_fold": lib.MLR_CLEANUP_OPT_MAX_FOLD,
        "keep_stiller": lib.MLR_CLEANUP_OPT_KEEP_STILLER,
        "keep_total": lib.MLR_CLEANUP_OPT_KEEP_TOTAL, "pin_detail": lib.MLR_CLEANUP_OPT_PIN_DETAIL,
        "ramp_track": lib.MLR_CLEANUP_OPT_RAMP_TRACK, "root_bob": lib.MLR_CLEANUP_OPT_ROOT_BOB,
        "straight_slack": lib.MLR_CLEANUP_OPT_STRAIGHT_SLACK,
        "soft_reach": lib.MLR_CLEANUP_OPT_SOFT_REACH}


def _points(skeleton: Skeleton, names: Sequence[str | int]
            ) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    pts = [_point(skeleton, n) for n in names]
    j = np.array([p[0] for p in pts], dtype=np.int32)
    e = np.array([p[1] for p in pts], dtype=np.int32)
    return j, e


def _contacts(contacts: ArrayLike, n: int, names: Sequence[str], where: str
              ) -> NDArray[np.uint8]:
    c = np.asarray(contacts)
    if c.dtype != np.bool_ or c.shape != (n, len(names)):
        raise InvalidArgumentError(
            f"{where}: contacts must be a bool array ({n}, {len(names)}) (frames x names), got "
            f"{c.dtype} {c.shape}")
    return np.ascontiguousarray(c.astype(np.uint8))


def _i32(a: NDArray[np.int32]) -> Any:
    return ffi.cast("const int32_t *", ffi.from_buffer(a)) if a.size else ffi.NULL


def _frames(m: Motion) -> list[NDArray[np.float64]]:
    return m._frames()  # checked against m's skeleton and frame count


def floor_height(motion: Motion, contacts: ArrayLike | None = None,
                 names: str | Sequence[str] | None = None, *, quantile: float = 0.05,
                 up: str | int | None = None) -> float:
    """The floor height of a motion along the up axis (``mlr_cleanup_floor_height``).

    The ``quantile`` quantile of the heights of its contact points on their contact frames.

    Parameters
    ----------
    motion : Motion
        The motion.
    contacts : array_like of bool, shape (N, C), optional
        As from :func:`mlayer.detect_contacts`; detected here when not given.
    names : str or sequence of str, optional
        The C contact point names that go with ``contacts``.
    quantile : float, optional
        In [0, 1].
    up : {"x", "y", "z", 0, 1, 2}, optional
        The up axis; None: the motion's :attr:`~mlayer.Motion.up_axis`.

    Returns
    -------
    float
        The height; NaN when nothing touches.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a bad motion, contacts array or quantile.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError("floor_height: motion must be a mlayer.Motion")
    if contacts is None or names is None:
        names, contacts = detect_contacts(motion, names)
    names = [names] if isinstance(names, str) else list(names)
    c = _contacts(contacts, motion.n_frames, names, "floor_height")
    if not (np.isfinite(quantile) and 0.0 <= quantile <= 1.0):
        raise InvalidArgumentError(f"floor_height: quantile must be in [0, 1], got {quantile}")
    j, e = _points(motion.skeleton, names)
    rig, keep = c_rig(motion.skeleton)
    root, rot, trans = _frames(motion)
    out = ffi.new("double *")
    diag = ffi.new("mlr_diag *")
    job = ffi.new("mlr_cleanup_job *")
    job.rig, job.up = rig, motion_axis(motion, up, "floor_height")
    job.motion = (motion.n_frames, _arrays.ptr(root), _arrays.ptr(rot),
                  _arrays.ptr(trans) if trans.size else ffi.NULL)
    job.points = (len(names), _i32(j), _i32(e), ffi.cast("const uint8_t *", ffi.from_buffer(c)))
    check(lib.mlr_cleanup_job_floor_height(job, float(quantile), out, ffi.NULL, diag),
          "floor_height", diag)
    del keep
    return float(out[0])


@overload
def fix_contacts(motion: Motion, contacts: ArrayLike, names: str | Sequence[str],
                 reference: Motion | None = None, *, floor: str | float | None = "auto",
                 up: str | int | None = None, return_report: Literal[False] = False,
                 **options: Any) -> Motion: ...
@overload
def fix_contacts(motion: Motion, contacts: ArrayLike, names: str | Sequence[str],
                 reference: Motion | None = None, *, floor: str | float | None = "auto",
                 up: str | int | None = None, return_report: Literal[True],
                 **options: Any) -> tuple[Motion, dict[str, float]]: ...
def fix_contacts(motion: Motion, contacts: ArrayLike, names: str | Sequence[str],
                 reference: Motion | None = None, *, floor: str | float | None = "auto",
                 up: str | int | None = None, return_report: bool = False,
                 **options: Any) -> Motion | tuple[Motion, dict[str, float]]:
    """Pin the feet of a synthesized motion during its contacts (paper 1, eq. 18).

    Also keeps them above the floor (``mlr_cleanup_contacts``). Bone lengths and the
    translations of non-root joints are unchanged.

    Parameters
    ----------
    motion : Motion
        The synthesized motion.
    contacts : array_like of bool, shape (N, C)
        As from :func:`mlayer.detect_contacts` (usually detected on the original).
    names : str or sequence of str
        The C contact point names.
    reference : Motion, optional
        A motion with the same frames (normally the original before synthesis, or its
        denoised version) whose contact trajectories and heights the feet follow.
    floor : "auto", None or float, optional
        ``"auto"`` (the reference's :func:`floor_height`, or the motion's without one), None
        (off) or a finite height.
    up : {"x", "y", "z", 0, 1, 2}, optional
        The up axis; None: the motion's :attr:`~mlayer.Motion.up_axis`.
    return_report : bool, optional
        Also return a dict of what was done (``floor_height``, ``contact_frames``,
        ``floor_frames``, ``root_shift_max``).
    **options : float
        blend (seconds, 0.2), reach (0.98), passes (2), floor_quantile (0.05), ref_smooth
        (seconds, 0.02), pin_smooth (seconds, 0.02), root (True), max_fold, keep_stiller,
        pin_detail (0: a pinned foot follows the reference's smoothed path; 1: it keeps the
        synthesis' own fast motion, the reference's capture noise left out),
        keep_total (False: with keep_stiller, the feet slide in all at most as much as the
        reference's; the kept contacts that slide most beyond it follow it instead),
        ramp_track (True: the frames around a contact cross-fade from the reference's motion
        to the synthesis's, so the foot meets its contact with the contact's velocity;
        False: they carry the contact's offset at its edge alone), root_bob (seconds, 0: the
        vertical part of the root's shift spread over +- this, so that a body whose bob was
        scaled keeps it; stylize passes 0.5 when the body's alpha is not 1), straight_slack
        (leg lengths, 0: on a leg within about a degree of straight, a correction along the
        hip-ankle line taken softly, l x^2 / (1 + x^2) with x = l / straight_slack, so that a
        straight leg asked to shorten by a hair does not bend its knee; the guards pass 0.002),
        soft_reach (leg lengths, 0: a target farther from the hip than b = L (1 - soft_reach)
        drawn in to b + soft_reach L (1 - exp(-(d - b) / (soft_reach L))), no nearer than the
        leg's extension, so that a knee straightens smoothly as its target nears full reach;
        the guards pass 0.02).

    Returns
    -------
    Motion or (Motion, dict)
        The new motion, with the report when ``return_report`` is true.

    Raises
    ------
    mlayer.InvalidArgumentError
        For bad arguments, an unknown option or an option out of range.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError("fix_contacts: motion must be a mlayer.Motion")
    names = [names] if isinstance(names, str) else list(names)
    N = motion.n_frames
    c = _contacts(contacts, N, names, "fix_contacts")
    names = _resolve_names(motion, names) if names else []
    if reference is not None:
        if not isinstance(reference, Motion):
            raise InvalidArgumentError("fix_contacts: reference must be a mlayer.Motion")
        if reference.n_frames != N:
            raise InvalidArgumentError(
                f"fix_contacts: reference has {reference.n_frames} frames, motion {N}")
        if reference.skeleton.n_joints != motion.skeleton.n_joints or \
                reference.trans.shape != motion.trans.shape:
            raise InvalidArgumentError("fix_contacts: reference has another skeleton")
    opts = []
    for k, v in options.items():
        if k not in _OPT:
            raise InvalidArgumentError(f"fix_contacts: unknown option {k!r} (known: "
                                       + ", ".join(sorted(_OPT)) + ")")
        opts.append((_OPT[k], float(v)))  # the range is checked in C (named by k)
    if floor is None:
        opts.append((lib.MLR_CLEANUP_OPT_FLOOR, 0.0))
    elif isinstance(floor, str):
        if floor != "auto":
            raise InvalidArgumentError(f"floor: expected 'auto', None or a height, got {floor!r}")
    else:
        try:
            h = float(floor)
        except (TypeError, ValueError):
            raise InvalidArgumentError(f"floor: expected 'auto', None or a height, got {floor!r}")
        if not np.isfinite(h):
            raise InvalidArgumentError(f"floor: the height must be finite, got {h}")
        opts.append((lib.MLR_CLEANUP_OPT_FLOOR_HEIGHT, h))
    copts = ffi.new("mlr_cleanup_option[]", max(1, len(opts)))
    for i, (k, v) in enumerate(opts):
        copts[i].key, copts[i].value = k, v
    j, e = _points(motion.skeleton, names) if names else (np.zeros(0, np.int32),) * 2
    rig, keep = c_rig(motion.skeleton)
    root, rot, trans = _frames(motion)
    P = trans.shape[1]
    out_root, out_rot = np.empty_like(root), np.empty_like(rot)
    rep = ffi.new("mlr_cleanup_report *")
    diag = ffi.new("mlr_diag *")
    job = ffi.new("mlr_cleanup_job *")
    job.rig, job.fps, job.up = rig, float(motion.fps), motion_axis(motion, up, "fix_contacts")
    job.motion = (N, _arrays.ptr(root), _arrays.ptr(rot), _arrays.ptr(trans) if P else ffi.NULL)
    if reference is not None:
        rr, rq, rt = _frames(reference)
        job.reference = (N, _arrays.ptr(rr), _arrays.ptr(rq), _arrays.ptr(rt) if P else ffi.NULL)
    job.points = (len(names), _i32(j), _i32(e),
                  ffi.cast("const uint8_t *", ffi.from_buffer(c)) if c.size else ffi.NULL)
    job.opts, job.n_opts = copts, len(opts)
    job.out_root_pos, job.out_rot = _arrays.ptr_out(out_root), _arrays.ptr_out(out_rot)
    job.report = rep
    check(lib.mlr_cleanup_job_run(job, ffi.NULL, diag), "fix_contacts", diag)
    del keep
    out = motion.with_frames(root_pos=out_root, rot=out_rot)
    if return_report:
        return out, {"floor_height": rep.floor_height, "contact_frames": rep.contact_frames,
                     "floor_frames": rep.floor_frames, "root_shift_max": rep.root_shift_max}
    return out


def _has_feet(original: Motion, joints: Any) -> bool:
    if joints is not None:
        return True
    try:
        find_feet(original)
    except InvalidArgumentError:
        return False
    return True


def keep_contacts_retimed(original: Motion, retimed: Motion, reference: Motion,
                          source_frames: ArrayLike,
                          joints: str | Sequence[str | int] | None = None, *,
                          floor: str | float | None = "auto",
                          contacts: tuple[list[str], NDArray[np.bool_] | None] | None = None
                          ) -> Motion:
    """A retimed motion with the feet pinned during the contacts of the original.

    Output frame k takes the contacts of input frame ``round(source_frames[k])`` (its
    fractional input frame). Skeletons without recognisable feet (and no ``joints``) and clips
    of fewer than 3 frames come back unchanged, as in :func:`keep_contacts`.

    Parameters
    ----------
    original : Motion
        The input of the retiming.
    retimed : Motion
        Resampled or time-warped from ``original``.
    reference : Motion
        The original at the output frames without smoothing (a SLERP resampling on the same
        time map), whose contact trajectories, smoothed over half an output frame (at least
        0.02 s), the feet follow.
    source_frames : array_like, shape (N_out,)
        The fractional input frame of each output frame.
    joints : str or sequence, optional
        The contact points (as for :func:`mlayer.detect_contacts`).
    floor : "auto", None or float, optional
        As for :func:`fix_contacts`.
    contacts : (list of str, numpy.ndarray), optional
        ``(names, contacts)`` of ``original`` when already at hand
        (:attr:`mlayer.pipeline.pipeline.Clip.contacts`), instead of detecting them here.

    Returns
    -------
    Motion
        The cleaned retimed motion (``retimed`` itself when there is nothing to pin).
    """
    if original.n_frames < 3 or retimed.n_frames < 2:
        return retimed
    if contacts is not None:
        names, c = contacts
        if not names or c is None:
            return retimed
    elif not _has_feet(original, joints):
        return retimed
    else:
        names, c = detect_contacts(original, joints)
    k = np.clip(np.rint(np.asarray(source_frames, dtype=np.float64)), 0, original.n_frames - 1)
    # the reference is a SLERP retiming, without the low-pass of the retimed motion (resample
    # filters at 0.38 of the new Nyquist when downsampling): its contact trajectories are
    # smoothed over half an output frame (at least the default 0.02 s), or the feet would carry
    # the aliased capture noise the rest of the body does not (jitter 1.11x on lafan1 at 15 fps)
    smooth = max(0.02, 0.5 * float(retimed.frame_time))
    # the ramps into the contacts carry the edge's offset alone: following the SLERP
    # reference's motion there took in its kinks between frames (jitter 1.13x on lafan1 at
    # 15 fps, 1.08x so)
    return fix_contacts(retimed, c[k.astype(np.int64)], names, reference=reference, floor=floor,
                        ref_smooth=smooth, ramp_track=False)


def keep_contacts(original: Motion, synthesized: Motion,
                  joints: str | Sequence[str | int] | None = None, *,
                  reference: Motion | None = None, floor: str | float | None = "auto",
                  **options: Any) -> Motion:
    """A synthesized motion with the feet pinned during the contacts of the original.

    :func:`mlayer.detect_contacts` then :func:`fix_contacts`. stylize/denoise pass the
    denoised motion as the reference (with ref_smooth=0): its feet carry no capture noise, so
    an input that does not slide comes out of denoise as it went in. A skeleton without
    recognisable feet (and no ``joints``), or a clip of fewer than 3 frames, is returned
    unchanged: this is the default step of stylize/denoise, which also work on skeletons that
    have no feet.

    Parameters
    ----------
    original : Motion
        The motion the contacts are detected on.
    synthesized : Motion
        A motion of the same frames.
    joints : str or sequence, optional
        The contact points (as for :func:`mlayer.detect_contacts`).
    reference : Motion, optional
        Default: ``original``.
    floor : "auto", None or float, optional
        As for :func:`fix_contacts`.
    **options : float
        As for :func:`fix_contacts`.

    Returns
    -------
    Motion
        The cleaned motion (``synthesized`` itself when there is nothing to pin).
    """
    if original.n_frames < 3 or not _has_feet(original, joints):
        return synthesized
    names, c = detect_contacts(original, joints)
    return fix_contacts(synthesized, c, names,
                        reference=original if reference is None else reference, floor=floor,
                        **options)
