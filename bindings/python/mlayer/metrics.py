"""Quality measures used across mlayer, on world-space joint positions.

Every function takes Motions (or (N, J, 3) position arrays) and returns a float in the clip's
own length units (BVH files carry no unit: CMU files are in ~5.6 cm "ASF" units, LaFAN1 and
Bandai in cm).
"""
from __future__ import annotations

import numpy as np

from ._rig import axis, body_height_of, motion_axis
from .contacts import contact_positions
from .errors import InvalidArgumentError


def _positions(m) -> np.ndarray:
    p = m.positions() if hasattr(m, "positions") else np.asarray(m, dtype=np.float64)
    if p.ndim != 3 or p.shape[-1] != 3:
        raise InvalidArgumentError(f"expected a Motion or an (N, J, 3) array, got shape {p.shape}")
    return p


def mpjpe(a, b) -> float:
    """Mean per-joint position error: the mean over frames and joints of the Euclidean distance
    between corresponding world positions of a and b (same skeleton, same frame count).
    Units: the clips' length unit."""
    pa, pb = _positions(a), _positions(b)
    if pa.shape != pb.shape:
        raise InvalidArgumentError(f"mpjpe: shapes differ: {pa.shape} vs {pb.shape}")
    return float(np.linalg.norm(pa - pb, axis=-1).mean())


def jitter(m, fps: float | None = None) -> float:
    """Mean magnitude of the third finite difference of world joint positions.

    Without fps: length units per frame^3, the mean over frames and joints of
    |p[t+3] - 3 p[t+2] + 3 p[t+1] - p[t]|. With fps: scaled by fps^3 to length units per
    second^3, comparable across frame rates.
    """
    p = _positions(m)
    if p.shape[0] < 4:
        raise InvalidArgumentError(f"jitter needs at least 4 frames, got {p.shape[0]}")
    j = np.linalg.norm(np.diff(p, n=3, axis=0), axis=-1).mean()
    return float(j * fps**3) if fps else float(j)


def body_height(m, up=None) -> float:
    """Body size used to make thresholds and errors unit-free: the median over frames of the
    joints' extent along the up axis (End Sites excluded, so the head top and toe tips are not
    counted); up: "x", "y", "z" or None for the motion's :attr:`~mlayer.Motion.up_axis` ("y"
    for a positions array). Units: the clip's length unit; a standing CMU subject is about 24
    units."""
    p = _positions(m)
    return body_height_of(p, axis(up if up is not None else getattr(m, "up_axis", "y"),
                                  "body_height"))


def foot_sliding(m, contacts, names, up=None, *, pos=None, wrot=None) -> float:
    """Mean horizontal speed of the contact joints while they are in contact.

    m: a Motion; contacts: bool (N, C) as returned by :func:`mlayer.detect_contacts`; names: the
    C contact point names (joints, or "Joint/End" for a joint's End Site). For every joint c and every pair of consecutive frames (t, t+1) that are both
    in contact, the horizontal displacement |p_c(t+1) - p_c(t)| (in the plane normal to up:
    "x", "y", "z", or None for the motion's :attr:`~mlayer.Motion.up_axis`) times the
    frame rate; the mean over all such pairs of all joints. Units: the clip's length unit per
    second (cm/s for LaFAN1 and Bandai). 0 for a perfectly planted foot; NaN when no joint has
    two consecutive contact frames. pos, wrot: m's forward kinematics when already at hand
    (:func:`mlayer.contacts.contact_positions`).
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
