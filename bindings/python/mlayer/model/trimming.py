"""Trimming the converter's lead-in: the T-pose (and blend) frames some converters put before
the captured motion of a clip.

The CMU BVH conversions start with a T-pose frame that was never captured, and the Daz- and
MakeHuman-style ones follow it with a few frames blending into the first captured pose. The C
core finds them (``mlr_trim_lead_in``, include/mlayer/mlr_trim.h): frame 0 is a lead-in when
its pose (joint positions relative to the body, heading removed, as :func:`mlayer.pose_features`)
is more than 5 median frame-to-frame steps away from every pose of the motion after it; the
blend runs until 3 steps in a row are at most 2 median steps. Every threshold is a ratio of
distances: units and frame rates do not matter. On the shared clips it drops 1 frame of
cmu_01_01, 8 of cmu_10_01, 7 of cmu_60_10, 5 of cmu_02_03 and none of the others.

``mlayer.read_bvh(path, trim="auto")`` (``--trim auto`` on the command line) drops them as the
clip is read; ``trim=N`` drops N frames; :func:`trim` does the same to a Motion.
"""
from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple

import numpy as np

from .. import _arrays
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ._rig import axis, c_rig
from .motion import Motion


__all__ = ["LeadIn", "lead_in", "trim", "reading_trim"]

# The trim of clips read with trim=None while the CLI's --trim is given (None: no trim), and a
# function told (name, frames dropped) for each clip trimmed.
_TRIM: contextvars.ContextVar[tuple[str | int | None, Callable[[str, int], object] | None]] = \
    contextvars.ContextVar("mlayer_trim", default=(None, None))


class LeadIn(NamedTuple):
    """What :func:`lead_in` found.

    Attributes
    ----------
    n_frames : int
        Frames to drop at the start (0: none).
    n_held : int
        Of those, the frames that hold the first pose (the T-pose).
    distance : float
        Frame 0's distance to the motion in median steps (a lead-in above 5).
    """
    n_frames: int
    n_held: int
    distance: float


def lead_in(motion: Motion, *, up: str | int | None = None) -> LeadIn:
    """The converter's lead-in at the start of a motion (T-pose and blend frames).

    Parameters
    ----------
    motion : Motion
        The clip.
    up : {"x", "y", "z"}, optional
        The up axis; default the motion's :attr:`~mlayer.Motion.up_axis`.

    Returns
    -------
    LeadIn
        What to drop.

    Raises
    ------
    mlayer.InvalidArgumentError
        When ``motion`` is not a Motion.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"lead_in: expected a mlayer.Motion, got "
                                   f"{type(motion).__name__}")
    u = axis(motion.up_axis if up is None else up, "lead_in")
    root_pos, rot, trans = motion._frames()
    rig, keep = c_rig(motion.skeleton)
    out = ffi.new("mlr_trim_lead *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_trim_lead_in(rig, rot.shape[0], _arrays.ptr(root_pos), _arrays.ptr(rot),
                               _arrays.ptr(trans), u, out, ffi.NULL, diag), "lead_in", diag)
    del keep
    return LeadIn(int(out.n_frames), int(out.n_held), float(out.distance))


def frames_arg(trim: Any, where: str) -> str | int | None:
    """A trim argument: None, "auto", or a frame count >= 0 (an int)."""
    if trim is None or trim == "auto":
        return trim
    if isinstance(trim, (int, np.integer)) and not isinstance(trim, bool) and trim >= 0:
        return int(trim)
    raise InvalidArgumentError(f"{where}: trim must be 'auto', a frame count >= 0 or None, got "
                               f"{trim!r}")


def trim(motion: Motion, frames: str | int | None = "auto") -> Motion:
    """A motion without its first frames.

    Parameters
    ----------
    motion : Motion
        The clip.
    frames : "auto", int or None, optional
        ``"auto"`` drops the converter's lead-in that :func:`lead_in` finds (possibly none),
        an int N the first N frames (fewer than the clip has), None nothing.

    Returns
    -------
    Motion
        A new motion (the same one when nothing is dropped); the up axis is kept.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a bad ``frames`` or one that leaves no frame.
    """
    frames = frames_arg(frames, "trim")
    if frames is None:
        return motion
    n = lead_in(motion).n_frames if isinstance(frames, str) else frames
    if n >= motion.n_frames:
        raise InvalidArgumentError(f"trim: {n} frames dropped from a clip of {motion.n_frames} "
                                   "leave nothing")
    return motion[n:] if n else motion


def _read(m: Motion, trim_given: str | int | None, name: str) -> Motion:
    """A clip as read_bvh returns it: trimmed as trim_given, or as the CLI's --trim says."""
    report = None
    if trim_given is None:
        trim_given, report = _TRIM.get()
    if trim_given is None:
        return m
    out = trim(m, trim_given)
    if report is not None and out.n_frames != m.n_frames:
        report(name, m.n_frames - out.n_frames)
    return out


@contextlib.contextmanager
def reading_trim(frames: str | int | None,
                 report: Callable[[str, int], object] | None = None) -> Iterator[None]:
    """A context in which clips read with ``read_bvh(..., trim=None)`` are trimmed.

    The CLI's ``--trim`` uses it.

    Parameters
    ----------
    frames : "auto", int or None
        As for :func:`trim` (None: not trimmed).
    report : callable, optional
        ``report(name, n)`` is called for each clip trimmed.

    Yields
    ------
    None
        Nothing; the setting ends with the block.
    """
    token = _TRIM.set((frames_arg(frames, "--trim"), report))
    try:
        yield
    finally:
        _TRIM.reset(token)
