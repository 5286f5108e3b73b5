"""Resampling and time warping through the LGS (paper 1, section 5.3), and the SLERP baseline.

Every function takes a :class:`~mlayer.Motion` and returns a new one on the same skeleton, so
retiming composes with everything else that takes a motion (e.g. retime, then stylize).

- :func:`resample`: a new frame rate (``fps``) or frame count (``n_frames``). Input frame i is
  placed at its fractional position on the output grid; the root translation, the per-joint
  translations and the joint quaternions are solved by one order-2 LGS (quaternions made
  sign-continuous by second-order prediction first, renormalized after). Downsampling
  low-passes by construction (no aliasing); upsampling sparse keys follows a spin in its true
  direction where SLERP takes the short way round. ``return_var=True`` also gives the posterior
  variance per output frame (relative to one observation's for ``sigma=1``): it grows where
  observations are sparse.
- :func:`timewarp`: the same solve with a non-uniform time map: automatic (paper Figure 9:
  intervals of large motion slow down, with easing in and out) or given by the user.
  :func:`timewarp_map` and :func:`timewarp_speed` expose the automatic map and the per-frame
  motion magnitude it is built from.
- :func:`slerp_resample`: the classic baseline (SLERP of rotations between the two nearest
  input frames, linear interpolation of translations).

The first frame always stays put; with ``n_frames`` (and time maps) the last one too, while
``fps`` keeps the exact rate: output frame k at time k / fps, ending at the last such time
within the input (up to one output frame before the input's last frame). Factors beyond 100x
(either way, or any local
step of a time map) are refused unless ``allow_extreme=True``: they are usually a unit mistake.
"""
from __future__ import annotations

import math
from typing import Any, Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._args import integer
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..guards.cleanup import keep_contacts_retimed
from ..guards.metrics import body_height
from ..model.motion import Motion
from .pipeline import Clip


__all__ = ["resample", "slerp_resample", "timewarp", "timewarp_map", "timewarp_speed",
           "MAX_FACTOR"]

#: The largest resampling factor (either way) accepted without ``allow_extreme=True``.
MAX_FACTOR = 100.0
_SLACK = 1e-9  # as the C core: a factor of exactly 100 passes despite rounding


def _motion(motion: Any, where: str) -> Motion:
    if not isinstance(motion, Motion):
        raise TypeError(f"{where}: expected a mlayer.Motion, got {type(motion).__name__}")
    if motion.n_frames < 2:
        raise InvalidArgumentError(
            f"{where}: needs a motion of at least 2 frames, got {motion.n_frames}")
    return motion


def _flags(allow_extreme: bool, nearest_sign: bool = False) -> int:
    return (lib.MLR_RESAMPLE_ALLOW_EXTREME if allow_extreme else 0) | \
        (lib.MLR_RESAMPLE_NEAREST_SIGN if nearest_sign else 0)


def _factor_check(factor: float, what: str, where: str, allow_extreme: bool) -> None:
    if allow_extreme:
        return
    f = factor if factor >= 1.0 else 1.0 / factor
    if f > MAX_FACTOR * (1.0 + _SLACK):
        raise InvalidArgumentError(
            f"{where}: {what} is a factor of {f:.6g}, beyond {MAX_FACTOR:g}x (usually a unit "
            "mistake, e.g. a frame time given as a frame rate); set the flag allow_extreme if "
            "this is intended")


def _out_memory(motion: Motion, n_out: int, name: str, where: str) -> int:
    """n_out, after checking that its output frames (and the solver's copy of them) fit in
    memory: MemoryError naming the argument before anything is allocated."""
    m = 3 + 4 * motion.n_joints + 3 * motion.skeleton.trans_joints.shape[0]
    _arrays.check_memory(16.0 * n_out * m, f"{where}: {name} ({n_out} output frames)")
    return n_out


def _frame_count(n: Any, name: str, where: str) -> int:
    return integer(n, f"{where}: {name}", 2)


def _target(motion: Motion, fps: float | None, n_frames: int | None, allow_extreme: bool,
            where: str) -> tuple[int, float, NDArray[np.float64] | None]:
    """(n_out, frame_time, t) for exactly one of fps / n_frames. fps: the exact grid of the
    rate (C mlr_resample_rate_map): t[i] = i fps / motion.fps, output frame k at time k / fps
    after the first frame, ending at the last such time within the input (pass t with
    MLR_RESAMPLE_OPEN_END). n_frames: t None, the uniform map that keeps the first and last
    frames, so the duration of frames 0..N-1 stays (the frame time changes)."""
    if (fps is None) == (n_frames is None):
        raise InvalidArgumentError(f"{where}: give exactly one of fps or n_frames")
    N = motion.n_frames
    if fps is not None:
        try:
            fps = float(fps)
        except (TypeError, ValueError):
            raise InvalidArgumentError(f"{where}: fps must be a number, got {fps!r}") from None
        if not (math.isfinite(fps) and fps > 0):
            raise InvalidArgumentError(f"{where}: fps must be finite and > 0, got {fps:g}")
        _factor_check(fps / motion.fps, f"{motion.fps:.6g} -> {fps:.6g} fps", where,
                      allow_extreme)
        n = ffi.new("size_t *")
        t = np.empty(N)
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_resample_rate_map(N, motion.fps, fps, _flags(allow_extreme),
                                         _arrays.ptr_out(t), n, diag), where, diag)
        return _out_memory(motion, int(n[0]), "fps", where), 1.0 / fps, t
    n_out = _frame_count(n_frames, "n_frames", where)
    _factor_check((n_out - 1) / (N - 1), f"{N} -> {n_out} frames", where, allow_extreme)
    _out_memory(motion, n_out, "n_frames", where)
    return n_out, motion.frame_time * (N - 1) / (n_out - 1), None


def frames_at_rate(n_frames: int, fps_in: float, fps_out: float) -> int:
    """How many frames ``resample(m, fps=fps_out)`` gives for a clip of ``n_frames`` at
    ``fps_in``: the output frames k / fps_out within the input's duration (the C core's count,
    any factor)."""
    n = ffi.new("size_t *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_resample_n_out(int(n_frames), float(fps_in), float(fps_out),
                                  lib.MLR_RESAMPLE_OPEN_END | lib.MLR_RESAMPLE_ALLOW_EXTREME, n,
                                  diag), "frames_at_rate", diag)
    return int(n[0])


def _grid_flags(t: NDArray[np.float64] | None) -> int:
    """MLR_RESAMPLE_OPEN_END for the exact grid of a rate (a time map from _target)."""
    return 0 if t is None else lib.MLR_RESAMPLE_OPEN_END


def _lam_sigma(lam: float | None, sigma: float | None, where: str) -> tuple[float, float]:
    if lam is None:
        lam = -1.0  # MLR_RESAMPLE_AUTO
    else:
        lam = float(lam)
        if not (math.isfinite(lam) and lam >= 0):
            raise InvalidArgumentError(
                f"{where}: lam must be finite and >= 0 (None for the automatic smoothness), "
                f"got {lam:g}")
    sigma = 1.0 if sigma is None else float(sigma)
    if not (math.isfinite(sigma) and sigma > 0):
        raise InvalidArgumentError(f"{where}: sigma must be finite and > 0, got {sigma:g}")
    return lam, sigma


def _time_map(time_map: ArrayLike, N: int, n_frames: int | None, allow_extreme: bool,
              where: str) -> tuple[NDArray[np.float64], int]:
    """The user's map as float64 and the output count (n_frames, or t[-1] + 1)."""
    t = _arrays.as_f64(time_map, "time_map", ndim=1)
    if t.shape[0] != N:
        raise InvalidArgumentError(
            f"{where}: time_map must hold one output position per input frame ({N}), "
            f"got {t.shape[0]}")
    _arrays.require_finite(t, f"{where}: time_map")
    if n_frames is None:
        last = float(t[-1])
        if not (last >= 1 and last == round(last)):
            raise InvalidArgumentError(
                f"{where}: time_map[-1] must be the last output frame (an integer >= 1), got "
                f"{last:g}; or give n_frames")
        n_out = int(last) + 1
    else:
        n_out = _frame_count(n_frames, "n_frames", where)
    _factor_check((n_out - 1) / (N - 1), f"{N} -> {n_out} frames", where, allow_extreme)
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_timemap_validate(_arrays.ptr(t), N, n_out, _flags(allow_extreme), diag),
           where, diag)
    return t, n_out


def _stylized(motion: Motion, style: float | dict[str, Any] | None, where: str
              ) -> tuple[Clip, Motion]:
    """``(clip, motion)``: the input as a :class:`mlayer.pipeline.pipeline.Clip` (its forward
    kinematics and contacts computed once for the style and the contacts' retiming) and the motion
    with its style scaled first (:meth:`Clip.stylize`), when style is given: an alpha, or a dict of
    stylize's arguments ({"alpha": 2, "joints": {"Left*": 3}, ...})."""
    clip = Clip(motion)
    if style is None:
        return clip, motion
    if isinstance(style, dict):
        kw = dict(style)
        if "alpha" not in kw:
            raise InvalidArgumentError(f"{where}: a style dict needs an 'alpha' entry")
        alpha = kw.pop("alpha")
        return clip, clip.stylize(alpha, kw.pop("joints", None),
                                  root_alpha=kw.pop("root_alpha", None), **kw)[0]
    try:
        alpha = float(style)
    except (TypeError, ValueError):
        raise InvalidArgumentError(
            f"{where}: style must be an alpha or a dict of stylize arguments, got {style!r}") \
            from None
    return clip, clip.stylize(alpha)[0]


def _solve(motion: Motion, t: NDArray[np.float64] | None, n_out: int, frame_time: float,
           lam: float, sigma: float, flags: int, want_var: bool, where: str) -> Any:
    root, rot, trans = motion._frames()
    # (the C core checks every value: non-finite data is reported with its frame and joint)
    N, J, P = motion.n_frames, motion.n_joints, trans.shape[1]
    root_out, rot_out = np.empty((n_out, 3)), np.empty((n_out, J, 4))
    trans_out = np.empty((n_out, P, 3))
    var = np.empty(n_out) if want_var else None
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_resample_arrays(
        N, J, P, _arrays.ptr(root), _arrays.ptr(rot), _arrays.ptr(trans),
        ffi.NULL if t is None else _arrays.ptr(t), n_out, lam, sigma, flags,
        _arrays.ptr_out(root_out), _arrays.ptr_out(rot_out), _arrays.ptr_out(trans_out),
        _arrays.ptr_out(var) if var is not None else ffi.NULL, ffi.NULL, diag)
    check(code, where, diag)
    out = Motion(motion.skeleton, frame_time, root_out, rot_out, trans_out, _trusted=True)
    return (out, var) if want_var else out


@overload
def resample(motion: Motion, *, fps: float | None = None, n_frames: int | None = None,
             lam: float | None = None, sigma: float | None = None,
             return_var: Literal[False] = False, allow_extreme: bool = False,
             nearest_sign: bool = False, style: float | dict[str, Any] | None = None,
             keep_contacts: bool = True) -> Motion: ...
@overload
def resample(motion: Motion, *, fps: float | None = None, n_frames: int | None = None,
             lam: float | None = None, sigma: float | None = None, return_var: Literal[True],
             allow_extreme: bool = False, nearest_sign: bool = False,
             style: float | dict[str, Any] | None = None,
             keep_contacts: bool = True) -> tuple[Motion, NDArray[np.float64]]: ...
def resample(motion: Motion, *, fps: float | None = None, n_frames: int | None = None,
             lam: float | None = None, sigma: float | None = None, return_var: bool = False,
             allow_extreme: bool = False, nearest_sign: bool = False,
             style: float | dict[str, Any] | None = None,
             keep_contacts: bool = True) -> Motion | tuple[Motion, NDArray[np.float64]]:
    """Resample ``motion`` to a new frame rate or frame count through the LGS.

    Parameters
    ----------
    motion : Motion
        The clip (at least 2 frames).
    fps : float
        The new frame rate, exactly: output frame k lies at time ``k / fps`` after the input's
        first frame, and the output ends at the last such time within the input, so it has
        ``floor((N-1) fps / motion.fps) + 1`` frames (a value within 1e-9 below an integer
        counts as that integer) of frame time ``1 / fps``. The last input frame may fall
        between two output frames; then the output ends up to one output frame earlier than
        the input. Round trips (120 -> 30 -> 120 fps) do not drift, and two cuts of one clip
        resampled separately have the same frames at the same times.
    n_frames : int
        The new frame count (>= 2); the frame time is scaled so that the first and last frames
        keep their times (the duration fits exactly). Give exactly one of ``fps`` and
        ``n_frames``.
    lam, sigma : float, optional
        Smoothness and observation noise. ``lam=None`` (default) picks the smoothness from the
        factor (C ``MLR_RESAMPLE_AUTO``: low-pass at 0.38 of the new Nyquist when downsampling,
        near-interpolation of the keys when upsampling). ``sigma`` (default 1) scales the
        variance only.
    return_var : bool
        Also return the posterior variance per output frame, shape ``(n_out,)``, in units of
        ``sigma**2`` (the same for every channel).
    allow_extreme : bool
        Accept factors beyond 100x.
    nearest_sign : bool
        Make quaternions continuous by the nearest sign only (no prediction), for comparison.
    style : float or dict, optional
        Retime and stylize in one call: the style is scaled first, at the input's frame rate
        (``mlayer.stylize(motion, style)``, or ``mlayer.stylize(motion, **style)`` for a dict
        with ``alpha`` and stylize's other arguments), then the result is resampled. The
        other order is ``mlayer.stylize(mlayer.resample(motion, ...), alpha)``.
    keep_contacts : bool
        Pin the feet during the contacts detected on ``motion``, carried to the new frames
        (:func:`mlayer.guards.cleanup.keep_contacts_retimed`, following the SLERP resampling of
        ``motion``); False skips it. Skeletons without recognisable feet are left as they are.

    Returns
    -------
    Motion or (Motion, numpy.ndarray)
        The new motion (same skeleton), or ``(motion, var)`` with ``return_var``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For fewer than 2 frames, fps <= 0, both or neither of fps / n_frames, factors over
        100x without ``allow_extreme``, non-finite data.
    """
    where = "mlayer.resample"
    motion = _motion(motion, where)
    n_out, frame_time, t = _target(motion, fps, n_frames, allow_extreme, where)
    lam, sigma = _lam_sigma(lam, sigma, where)
    clip, motion = _stylized(motion, style, where)
    original = clip.motion
    res = _solve(motion, t, n_out, frame_time, lam, sigma,
                 _flags(allow_extreme, nearest_sign) | _grid_flags(t), return_var, where)
    if not keep_contacts:
        return res
    if t is None:
        src = np.arange(n_out) * ((original.n_frames - 1) / max(n_out - 1, 1))
        ref = slerp_resample(original, n_frames=n_out, allow_extreme=allow_extreme)
    else:  # the input frame (fractional) at each output frame's time
        assert fps is not None  # a grid of times comes from fps
        src = np.arange(n_out) * (original.fps / fps)
        ref = slerp_resample(original, fps=fps, allow_extreme=allow_extreme)
    return _pinned(clip, res, ref, src)


def _pinned(clip: Clip, res: Any, reference: Motion, source_frames: NDArray[Any]
            ) -> Any:
    """res (a motion, or a tuple starting with one) with the feet pinned during the contacts
    of the input (a :class:`mlayer.pipeline.pipeline.Clip`), carried to the new frames."""
    original = clip.motion
    contacts = clip.contacts if original.n_frames >= 3 else ([], None)
    if isinstance(res, tuple):
        return (keep_contacts_retimed(original, res[0], reference, source_frames,
                                      contacts=contacts), *res[1:])
    return keep_contacts_retimed(original, res, reference, source_frames, contacts=contacts)


def slerp_resample(motion: Motion, *, fps: float | None = None, n_frames: int | None = None,
                   time_map: ArrayLike | None = None, allow_extreme: bool = False) -> Motion:
    """The baseline resampling: SLERP of the two input frames around every output frame.

    Rotations take the shorter arc, translations are linearly interpolated; no smoothing, no
    anti-aliasing.

    Parameters
    ----------
    motion : Motion
        The clip.
    fps, n_frames, allow_extreme
        As for :func:`resample` (``fps``: output frame k at time ``k / fps`` after the first
        frame, up to the last such time within the input).
    time_map : array_like, shape (N,), optional
        As in :func:`timewarp`: retimes the same way as the LGS does with that map (not with
        ``fps``).

    Returns
    -------
    Motion
        The resampled motion (same skeleton).

    Raises
    ------
    mlayer.InvalidArgumentError
        As for :func:`resample`, or for both ``fps`` and ``time_map``.
    """
    where = "mlayer.slerp_resample"
    motion = _motion(motion, where)
    t: NDArray[np.float64] | None
    if time_map is not None:
        if fps is not None:
            raise InvalidArgumentError(f"{where}: give fps or time_map, not both")
        t, n_out = _time_map(time_map, motion.n_frames, n_frames, allow_extreme, where)
        _out_memory(motion, n_out, "time_map / n_frames", where)
        frame_time, grid = motion.frame_time, 0
    else:
        n_out, frame_time, t = _target(motion, fps, n_frames, allow_extreme, where)
        grid = _grid_flags(t)
    root, rot, trans = motion._frames()
    # (the C core checks every value: non-finite data is reported with its frame and joint)
    N, J, P = motion.n_frames, motion.n_joints, trans.shape[1]
    root_out, rot_out = np.empty((n_out, 3)), np.empty((n_out, J, 4))
    trans_out = np.empty((n_out, P, 3))
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_slerp_resample_arrays(
        N, J, P, _arrays.ptr(root), _arrays.ptr(rot), _arrays.ptr(trans),
        ffi.NULL if t is None else _arrays.ptr(t), n_out, _flags(allow_extreme) | grid,
        _arrays.ptr_out(root_out), _arrays.ptr_out(rot_out), _arrays.ptr_out(trans_out), diag)
    check(code, where, diag)
    return Motion(motion.skeleton, frame_time, root_out, rot_out, trans_out, _trusted=True)


def _speed_args(motion: Motion, root_weight: float, joint_weights: ArrayLike | None,
                where: str) -> tuple[float, NDArray[np.float64] | None]:
    rw = float(root_weight)
    if not (math.isfinite(rw) and rw >= 0):
        raise InvalidArgumentError(f"{where}: root_weight must be finite and >= 0, got {rw:g}")
    if rw > 0:
        h = body_height(motion) if motion.n_frames else 0.0
        root_w = rw / (h if h > 0 and math.isfinite(h) else 1.0)
    else:
        root_w = 0.0
    if joint_weights is None:
        return root_w, None
    w = _arrays.as_f64(joint_weights, "joint_weights", ndim=1)
    if w.shape[0] != motion.n_joints:
        raise InvalidArgumentError(
            f"{where}: joint_weights must hold {motion.n_joints} values, got {w.shape[0]}")
    return root_w, w


def timewarp_speed(motion: Motion, *, root_weight: float = 1.0,
                   joint_weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """Per-frame motion magnitude that drives the automatic time warp.

    The (weighted) mean rotation angle of the joints' local rotation change per frame
    (radians, central differences) plus ``root_weight`` times the root's displacement per
    frame measured in body heights (:func:`mlayer.guards.metrics.body_height`; 1 length unit for a
    body with no height), so no length unit is involved.

    Parameters
    ----------
    motion : Motion
        The clip.
    root_weight : float, optional
        Finite, >= 0.
    joint_weights : array_like, shape (J,), optional
        Weights >= 0 (default equal).

    Returns
    -------
    numpy.ndarray, shape (N,)
        The magnitude per frame.
    """
    where = "mlayer.timewarp_speed"
    motion = _motion(motion, where)
    root_w, w = _speed_args(motion, root_weight, joint_weights, where)
    root, rot, _ = motion._frames()
    speed = np.empty(motion.n_frames)
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_timewarp_speed(motion.n_frames, motion.n_joints, _arrays.ptr(root),
                                  _arrays.ptr(rot), ffi.NULL if w is None else _arrays.ptr(w),
                                  root_w, _arrays.ptr_out(speed), diag), where, diag)
    return speed


def timewarp_map(motion: Motion, *, strength: float = 1.0, n_frames: int | None = None,
                 smooth_seconds: float = 0.25, root_weight: float = 1.0,
                 joint_weights: ArrayLike | None = None,
                 allow_extreme: bool = False) -> NDArray[np.float64]:
    """The automatic time map of :func:`timewarp`.

    The output frames spent per input frame are proportional to ``exp(strength * s)`` with s
    the log of the motion magnitude (:func:`timewarp_speed`, relative to its clip mean)
    smoothed over about ``smooth_seconds`` (the easing in and out).

    Parameters
    ----------
    motion : Motion
        The clip.
    strength : float, optional
        In [0, 10]: 0 is the uniform map, 1 makes the dwell time follow the motion magnitude,
        more exaggerates.
    n_frames : int, optional
        The target length (default: the input's count).
    smooth_seconds : float, optional
        The easing, >= 0.
    root_weight, joint_weights
        As for :func:`timewarp_speed`.
    allow_extreme : bool, optional
        Accept factors beyond 100x.

    Returns
    -------
    numpy.ndarray, shape (N,)
        ``t``: the output frame (fractional) at which each input frame lands; ``t[0] == 0``,
        ``t[-1] == n_frames - 1``, strictly increasing.

    Raises
    ------
    mlayer.InvalidArgumentError
        For parameters out of range.
    """
    where = "mlayer.timewarp_map"
    motion = _motion(motion, where)
    N = motion.n_frames
    n_out = N if n_frames is None else _frame_count(n_frames, "n_frames", where)
    _factor_check((n_out - 1) / (N - 1), f"{N} -> {n_out} frames", where, allow_extreme)
    strength = float(strength)
    if not (math.isfinite(strength) and 0 <= strength <= 10):
        raise InvalidArgumentError(f"{where}: strength must be in [0, 10], got {strength:g}")
    smooth_seconds = float(smooth_seconds)
    if not (math.isfinite(smooth_seconds) and smooth_seconds >= 0):
        raise InvalidArgumentError(
            f"{where}: smooth_seconds must be finite and >= 0, got {smooth_seconds:g}")
    root_w, w = _speed_args(motion, root_weight, joint_weights, where)
    root, rot, _ = motion._frames()
    t = np.empty(N)
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_timewarp_map(N, motion.n_joints, _arrays.ptr(root), _arrays.ptr(rot),
                                ffi.NULL if w is None else _arrays.ptr(w), root_w, strength,
                                max(1.0, smooth_seconds * motion.fps), n_out,
                                _flags(allow_extreme), _arrays.ptr_out(t), ffi.NULL, diag),
           where, diag)
    return t


def timewarp(motion: Motion, *, strength: float = 1.0, n_frames: int | None = None,
             time_map: ArrayLike | None = None, lam: float | None = None,
             sigma: float | None = None, return_var: bool = False, return_map: bool = False,
             smooth_seconds: float = 0.25, root_weight: float = 1.0,
             joint_weights: ArrayLike | None = None, allow_extreme: bool = False,
             style: float | dict[str, Any] | None = None, keep_contacts: bool = True
             ) -> Any:
    """Retime ``motion`` along a monotone time map, solved by the LGS; the frame rate stays.

    Automatic (default): :func:`timewarp_map` with ``strength`` (0 uniform, 1 natural, more
    exaggerated), ``smooth_seconds`` (easing), ``root_weight`` (how much the root's travel
    counts, per body size and frame, against the joints' radians per frame) and
    ``joint_weights``. Intervals of large motion slow down, calm ones speed up; with
    ``n_frames`` larger than the input the whole clip is slowed down and the extra time goes
    mostly to the large motion.

    Explicit: ``time_map`` of shape ``(N,)``, the output frame of each input frame, strictly
    increasing from 0 to ``n_frames - 1`` (default ``n_frames = time_map[-1] + 1``). ``strength``
    and the automatic options are not used then.

    ``lam``/``sigma``/``allow_extreme`` as in :func:`resample` (the automatic smoothness takes
    the mean factor ``(n_frames-1)/(N-1)``). Returns the new motion, followed by the variance
    per output frame with ``return_var`` and the time map with ``return_map``
    (``(motion, var, t)`` with both). ``style`` stylizes in the same call, as in
    :func:`resample` (the time map is taken from the original motion).

    The first and the last frame stay put; boundaries between slow and fast intervals are
    eased, so there are no jumps. ``keep_contacts`` (default True) pins the feet during the
    contacts detected on ``motion``, carried through the time map
    (:func:`mlayer.guards.cleanup.keep_contacts_retimed`, following the SLERP retiming of
    ``motion``).

    Parameters
    ----------
    motion : Motion
        The clip.
    strength, n_frames, smooth_seconds, root_weight, joint_weights
        The automatic map's (:func:`timewarp_map`).
    time_map : array_like, shape (N,), optional
        An explicit map.
    lam, sigma, allow_extreme
        As in :func:`resample`.
    return_var : bool, optional
        Also return the variance per output frame.
    return_map : bool, optional
        Also return the time map.
    style : float or dict, optional
        As in :func:`resample`.
    keep_contacts : bool, optional
        Pin the feet (default True).

    Returns
    -------
    Motion or tuple
        The new motion, or ``(motion, var)``, ``(motion, t)`` or ``(motion, var, t)``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a bad map, parameters out of range, factors over 100x without ``allow_extreme``.
    """
    where = "mlayer.timewarp"
    motion = _motion(motion, where)
    if time_map is not None:
        t, n_out = _time_map(time_map, motion.n_frames, n_frames, allow_extreme, where)
    else:
        t = timewarp_map(motion, strength=strength, n_frames=n_frames,
                         smooth_seconds=smooth_seconds, root_weight=root_weight,
                         joint_weights=joint_weights, allow_extreme=allow_extreme)
        n_out = int(round(t[-1])) + 1
    _out_memory(motion, n_out, "time_map / n_frames", where)
    lam, sigma = _lam_sigma(lam, sigma, where)
    clip, motion = _stylized(motion, style, where)
    original = clip.motion
    res = _solve(motion, t, n_out, motion.frame_time, lam, sigma, _flags(allow_extreme),
                 return_var, where)
    if keep_contacts:
        ref = slerp_resample(original, time_map=t, allow_extreme=allow_extreme)
        src = np.interp(np.arange(n_out), t, np.arange(original.n_frames))
        res = _pinned(clip, res, ref, src)
    if not return_map:
        return res
    return (*res, t) if return_var else (res, t)
