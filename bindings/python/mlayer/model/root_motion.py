"""Root motion: a clip split into an in-place motion and a root track on the ground plane
(in the C core: include/mlayer/mlr_root_motion.h).

Game engines drive a character by a root track (where it is on the ground and which way it
faces) and play the animation in place on top of it. :func:`extract_root_motion` makes both:

- the track follows the body joint (the joint that carries the body translation: the root, or
  Bandai's Hips below a static root): its position with the up component removed, and its
  heading about the up axis (radians, continuous: unwrapped), from the direction the body's
  left-right axis (found in the rest pose from the left/right joint pairs) turns to, because
  that axis stays put when the body pitches (a crouch, a bow, a dog lying down) and the names
  say which way is left where no convention says which local axis of a root is forward.
  Heading 0 faces the ground axis after up (Y-up: +Z, Z-up: +X, X-up: +Y);
- both smoothed by the LGS so the track is free of the gait's sway: ``smooth`` is the period in
  seconds whose amplitude the smoothing halves (default 1.0 s; 0: no smoothing);
- the in-place motion is the input relative to the track: root translation minus the track's
  position, turned by minus its heading; root rotation premultiplied by the inverse heading.

:func:`apply_root_motion` (or :meth:`RootTrack.apply`) puts them back together to rounding.
"""
from __future__ import annotations

import csv
import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays, _attrs
from .._files import atomic_output
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ._rig import axis, c_rig, motion_axis
from .motion import Motion


__all__ = ["RootTrack", "extract_root_motion", "apply_root_motion", "MODES"]

#: the modes of :func:`extract_root_motion`
MODES = {"ground": 0, "position": 1}

_CSV_HEADER = ["frame", "time", "x", "y", "z", "heading"]


class RootTrack(_attrs.ReadOnlyAttributes):
    """A root track: positions on the ground plane and headings about the up axis, per frame.

    The arguments are kept as the read-only attributes of the same names (AttributeError when
    assigned: make a new RootTrack).

    Parameters
    ----------
    positions : array_like, shape (F, 3)
        World positions whose up component is 0.
    heading : array_like, shape (F,)
        Radians about the up axis (right-handed), continuous, 0 facing the ground axis after up
        (Y-up: +Z, Z-up: +X, X-up: +Y).
    fps : float
        Frames per second.
    up_axis : {"x", "y", "z"}, optional
        The up axis.
    """
    positions: NDArray[np.float64]
    heading: NDArray[np.float64]
    fps: float

    __slots__ = ("positions", "heading", "fps", "up_axis")
    _readonly = __slots__

    def __init__(self, positions: ArrayLike, heading: ArrayLike, fps: float,
                 up_axis: str = "y") -> None:
        pos = _arrays.as_f64(positions, "RootTrack: positions", ndim=2, last=(3,))
        head = _arrays.as_f64(heading, "RootTrack: heading", ndim=1)
        if head.shape[0] != pos.shape[0]:
            raise InvalidArgumentError(f"RootTrack: heading has {head.shape[0]} frames, "
                                       f"positions {pos.shape[0]}")
        _arrays.require_finite(pos, "RootTrack: positions")
        _arrays.require_finite(head, "RootTrack: heading")
        f = _arrays.finite(fps, "RootTrack: fps")
        if f <= 0:
            raise InvalidArgumentError(f"RootTrack: fps must be > 0, got {fps!r}")
        self.positions = pos
        self.heading = head
        self.fps = f
        self.up_axis = "xyz"[axis(up_axis, "RootTrack")]

    @property
    def n_frames(self) -> int:
        """The number of frames F."""
        return int(self.positions.shape[0])

    def __len__(self) -> int:
        return self.n_frames

    def __repr__(self) -> str:
        return (f"RootTrack({self.n_frames} frames at {self.fps:g} fps, up {self.up_axis}, "
                f"heading {np.degrees(self.heading[0]) if self.n_frames else 0:.1f}.."
                f"{np.degrees(self.heading[-1]) if self.n_frames else 0:.1f} deg)")

    def apply(self, in_place: Motion) -> Motion:
        """The in-place motion put back on this track (:func:`apply_root_motion`).

        Parameters
        ----------
        in_place : Motion
            A motion of as many frames as the track.

        Returns
        -------
        Motion
            The motion on the track.
        """
        return apply_root_motion(in_place, self)

    def to_csv(self, path: str | os.PathLike[str]) -> None:
        """Write the track as CSV: ``frame,time,x,y,z,heading`` (heading in radians), one row
        per frame, atomically (a temporary beside the target, renamed when complete).

        Parameters
        ----------
        path : str or os.PathLike
            The CSV file.
        """
        with atomic_output(os.fspath(path)) as tmp:
            with open(tmp, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f)
                w.writerow(_CSV_HEADER)
                for i in range(self.n_frames):
                    p = self.positions[i]
                    w.writerow([i, repr(i / self.fps), repr(float(p[0])), repr(float(p[1])),
                                repr(float(p[2])), repr(float(self.heading[i]))])

    @classmethod
    def read_csv(cls, path: str | os.PathLike[str], *, fps: float | None = None,
                 up_axis: str = "y") -> RootTrack:
        """Read a track written by :meth:`to_csv`.

        Parameters
        ----------
        path : str or os.PathLike
            The CSV file.
        fps : float, optional
            Frames per second; default: from the time column (1 / the step of rows 0 and 1).
        up_axis : str, optional
            The up axis the track was made for (default "y").

        Returns
        -------
        RootTrack
            The track.

        Raises
        ------
        InvalidArgumentError
            A header other than ``frame,time,x,y,z,heading``, a row that is not numbers, or no
            fps (one row and no ``fps``).
        """
        with open(os.fspath(path), newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        if not rows or [c.strip() for c in rows[0]] != _CSV_HEADER:
            raise InvalidArgumentError(f"{os.fspath(path)}: not a root track CSV (the header "
                                       f"must be {','.join(_CSV_HEADER)})")
        try:
            data = np.array([[float(c) for c in r] for r in rows[1:] if r], dtype=np.float64)
        except ValueError as e:
            raise InvalidArgumentError(f"{os.fspath(path)}: {e}") from None
        data = data.reshape(-1, len(_CSV_HEADER))
        if fps is None:
            if data.shape[0] < 2 or not data[1, 1] > data[0, 1]:
                raise InvalidArgumentError(f"{os.fspath(path)}: cannot tell the fps from the "
                                           "time column; pass fps=")
            fps = 1.0 / (data[1, 1] - data[0, 1])
        return cls(data[:, 2:5], data[:, 5], fps, up_axis)


def _motion_arg(motion: Any, where: str) -> Motion:
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"{where}: expected a mlayer.Motion, got "
                                   f"{type(motion).__name__}")
    return motion


def extract_root_motion(motion: Motion, *, mode: str = "ground", smooth: float = 1.0,
                        body_joint: str | int | None = None,
                        up: str | int | None = None) -> tuple[Motion, RootTrack]:
    """Split a clip into an in-place motion and a root track on the ground plane.

    Parameters
    ----------
    motion : Motion
        The clip (at least one frame).
    mode : {"ground", "position"}, optional
        "ground" (default): the track has the position and the heading; "position": only the
        position (heading 0, the rotations are left alone).
    smooth : float, optional
        The LGS smoothing of the track, as the period in seconds whose amplitude it halves
        (default 1.0: most of a walk's sway, one stride, stays in the in-place motion); 0: none.
    body_joint : str or int, optional
        The joint the track follows (a name or an index); default: the joint that carries the
        body translation (the root for most rigs).
    up : str or int, optional
        The up axis ("x", "y", "z" or 0..2); default the motion's :attr:`~mlayer.Motion.up_axis`.

    Returns
    -------
    in_place : Motion
        The motion relative to the track (only the root's translation and rotation differ).
    track : RootTrack
        The track.

    Raises
    ------
    InvalidArgumentError
        A bad mode, smooth or body_joint (named in the message), no frames, values that are
        not finite.
    """
    motion = _motion_arg(motion, "extract_root_motion")
    if not isinstance(mode, str) or mode not in MODES:
        raise InvalidArgumentError(f"extract_root_motion: mode must be one of "
                                   f"{', '.join(MODES)}, got {mode!r}")
    ax = motion_axis(motion, up, "extract_root_motion")
    opts = [(lib.MLR_ROOT_MOTION_OPT_SMOOTH,
             _arrays.number(smooth, "extract_root_motion: smooth"))]
    if body_joint is not None:
        if isinstance(body_joint, str):
            if body_joint not in motion.joint_names:
                raise InvalidArgumentError(f"extract_root_motion: body_joint: no joint named "
                                           f"{body_joint!r}")
            bj = motion.joint_names.index(body_joint)
        elif isinstance(body_joint, (int, np.integer)) and not isinstance(body_joint, bool):
            bj = int(body_joint)
            if not 0 <= bj < motion.n_joints:
                raise InvalidArgumentError(f"extract_root_motion: body_joint {bj} is not in "
                                           f"[0, {motion.n_joints})")
        else:
            raise InvalidArgumentError("extract_root_motion: body_joint must be a joint name "
                                       f"or index, got {body_joint!r}")
        opts.append((lib.MLR_ROOT_MOTION_OPT_BODY_JOINT, float(bj)))
    c_opts = ffi.new("mlr_root_motion_option[]", len(opts))
    for i, (k, v) in enumerate(opts):
        c_opts[i].key, c_opts[i].value = k, v
    root_pos, rot, trans = motion._frames()
    N = rot.shape[0]
    if N == 0:
        raise InvalidArgumentError("extract_root_motion: the motion has no frames")
    track_pos, heading = np.empty((N, 3)), np.empty(N)
    out_root, out_rot = np.empty((N, 3)), rot.copy()
    rig, keep = c_rig(motion.skeleton)
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_root_motion_extract(
        rig, motion.fps, ax, MODES[mode], N, _arrays.ptr(root_pos), _arrays.ptr(rot),
        _arrays.ptr(trans), c_opts, len(opts), _arrays.ptr_out(track_pos),
        _arrays.ptr_out(heading), _arrays.ptr_out(out_root), _arrays.ptr_out(out_rot),
        4 * motion.n_joints, ffi.NULL, diag)
    del keep
    check(code, "extract_root_motion", diag)
    in_place = motion.with_frames(out_root, out_rot, trans.copy())
    return in_place, RootTrack(track_pos, heading, motion.fps, "xyz"[ax])


def apply_root_motion(in_place: Motion, track: RootTrack) -> Motion:
    """Put an in-place motion back on its root track: the inverse of
    :func:`extract_root_motion` (to rounding).

    Parameters
    ----------
    in_place : Motion
        The in-place motion.
    track : RootTrack
        A track of as many frames.

    Returns
    -------
    Motion
        The motion with the root translated by the track's position and turned by its heading
        (about the track's up axis).

    Raises
    ------
    InvalidArgumentError
        Not a Motion and a RootTrack, or different frame counts.
    """
    in_place = _motion_arg(in_place, "apply_root_motion")
    if not isinstance(track, RootTrack):
        raise InvalidArgumentError(f"apply_root_motion: track must be a mlayer.RootTrack, got "
                                   f"{type(track).__name__}")
    root_pos, rot, trans = in_place._frames()
    N = rot.shape[0]
    if track.n_frames != N:
        raise InvalidArgumentError(f"apply_root_motion: the track has {track.n_frames} frames, "
                                   f"the motion {N}")
    out_root, out_rot = np.empty((N, 3)), rot.copy()
    diag = ffi.new("mlr_diag *")
    ld = 4 * in_place.n_joints
    code = lib.mlr_root_motion_apply(
        "xyz".index(track.up_axis), N, _arrays.ptr(track.positions), _arrays.ptr(track.heading),
        _arrays.ptr(root_pos), _arrays.ptr(rot), ld, _arrays.ptr_out(out_root),
        _arrays.ptr_out(out_rot), ld, diag)
    check(code, "apply_root_motion", diag)
    return in_place.with_frames(out_root, out_rot, trans.copy())
