"""Quality measures used across mlayer, on world-space joint positions.

Every function takes Motions (or (N, J, 3) position arrays) and returns a float in the clip's
own length units (BVH files carry no unit: CMU files are in ~5.6 cm "ASF" units, LaFAN1 and
Bandai in cm).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model._rig import axis, body_height_of, motion_axis
from .contacts import contact_positions
from ..errors import InvalidArgumentError

if TYPE_CHECKING:
    from ..model.motion import Motion

__all__ = ["mpjpe", "jitter", "body_height", "foot_sliding"]


def _positions(m: Motion | ArrayLike) -> NDArray[np.float64]:
    p = m.positions() if hasattr(m, "positions") else np.asarray(m, dtype=np.float64)
    if p.ndim != 3 or p.shape[-1] != 3:
        raise InvalidArgumentError(f"expected a Motion or an (N, J, 3) array, got shape {p.shape}")
    return p


def mpjpe(a: Motion | ArrayLike, b: Motion | ArrayLike) -> float:
    """Mean per-joint position error.

    The mean over frames and joints of the Euclidean distance between corresponding world
    positions of ``a`` and ``b`` (same skeleton, same frame count).

    Parameters
    ----------
    a, b : Motion or array_like, shape (N, J, 3)
        Motions or world joint positions.

    Returns
    -------
    float
        The error, in the clips' length unit.

    Raises
    ------
    mlayer.InvalidArgumentError
        When the positions are not (N, J, 3) or their shapes differ.
    """
    pa, pb = _positions(a), _positions(b)
    if pa.shape != pb.shape:
        raise InvalidArgumentError(f"mpjpe: shapes differ: {pa.shape} vs {pb.shape}")
    return float(np.linalg.norm(pa - pb, axis=-1).mean())


def jitter(m: Motion | ArrayLike, fps: float | None = None) -> float:
    """Mean magnitude of the third finite difference of world joint positions.

    The mean over frames and joints of ``|p[t+3] - 3 p[t+2] + 3 p[t+1] - p[t]|``.

    Parameters
    ----------
    m : Motion or array_like, shape (N, J, 3)
        A motion or world joint positions (at least 4 frames).
    fps : float, optional
        When given, the result is scaled by ``fps**3``: length units per second cubed,
        comparable across frame rates. Without it: length units per frame cubed.

    Returns
    -------
    float
        The jitter.

    Raises
    ------
    mlayer.InvalidArgumentError
        For fewer than 4 frames or positions that are not (N, J, 3).
    """
    p = _positions(m)
    if p.shape[0] < 4:
        raise InvalidArgumentError(f"jitter needs at least 4 frames, got {p.shape[0]}")
    j = np.linalg.norm(np.diff(p, n=3, axis=0), axis=-1).mean()
    return float(j * fps**3) if fps else float(j)


def body_height(m: Motion | ArrayLike, up: str | int | None = None) -> float:
    """Body size used to make thresholds and errors unit-free.

    The median over frames of the joints' extent along the up axis (End Sites excluded, so
    the head top and toe tips are not counted).

    Parameters
    ----------
    m : Motion or array_like, shape (N, J, 3)
        A motion or world joint positions.
    up : {"x", "y", "z"}, optional
        The up axis; by default the motion's :attr:`~mlayer.Motion.up_axis` (``"y"`` for a
        positions array).

    Returns
    -------
    float
        The height in the clip's length unit (a standing CMU subject is about 24 units).
    """
    p = _positions(m)
    return body_height_of(p, axis(up if up is not None else getattr(m, "up_axis", "y"),
                                  "body_height"))


def foot_sliding(m: Motion, contacts: ArrayLike, names: str | Sequence[str],
                 up: str | None = None, *, pos: NDArray[np.float64] | None = None,
                 wrot: NDArray[np.float64] | None = None) -> float:
    """Mean horizontal speed of the contact joints while they are in contact.

    For every contact point c and every pair of consecutive frames (t, t+1) that are both in
    contact, the horizontal displacement ``|p_c(t+1) - p_c(t)|`` (in the plane normal to the
    up axis) times the frame rate; the mean over all such pairs of all points.

    Parameters
    ----------
    m : Motion
        The motion.
    contacts : array_like of bool, shape (N, C)
        As returned by :func:`mlayer.detect_contacts`.
    names : str or sequence of str
        The C contact point names (joints, or ``"Joint/End"`` for a joint's End Site).
    up : {"x", "y", "z"}, optional
        The up axis; by default the motion's :attr:`~mlayer.Motion.up_axis`.
    pos, wrot : numpy.ndarray, optional
        ``m``'s forward kinematics when already at hand
        (:func:`mlayer.guards.contacts.contact_positions`).

    Returns
    -------
    float
        The clip's length unit per second (cm/s for LaFAN1 and Bandai); 0 for a perfectly
        planted foot, NaN when no point has two consecutive contact frames.

    Raises
    ------
    mlayer.InvalidArgumentError
        When ``m`` is not a Motion or ``contacts`` is not a bool array of shape (N, C).
    """
    if not hasattr(m, "positions") or not hasattr(m, "skeleton"):
        raise InvalidArgumentError("foot_sliding: m must be a mlayer.Motion")
    names = [names] if isinstance(names, str) else list(names)
    c = np.asarray(contacts)
    if c.dtype != np.bool_ or c.ndim != 2 or c.shape != (m.n_frames, len(names)):
        raise InvalidArgumentError(
            f"foot_sliding: contacts must be a bool array ({m.n_frames}, {len(names)}), got "
            f"{c.dtype} {c.shape}")
    k = motion_axis(m, up, "foot_sliding")
    p = contact_positions(m, names, pos, wrot)[:, :, [a for a in range(3) if a != k]]
    if p.shape[0] < 2:
        return float("nan")
    speed = np.linalg.norm(np.diff(p, axis=0), axis=-1) * m.fps
    both = c[1:] & c[:-1]
    if not both.any():
        return float("nan")
    return float(speed[both].mean())
