"""Quality measures used across mlayer, on world-space joint positions.

Every function takes Motions (or (N, J, 3) position arrays) and returns a float in the clip's
own length units (BVH files carry no unit: CMU files are in ~5.6 cm "ASF" units, LaFAN1 and
Bandai in cm).
"""
from __future__ import annotations

import numpy as np

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
    counted); up: "x", "y", "z" or None for the motion's :attr:`~mlayer.Motion.up_axis`.
    Units: the clip's length unit; a standing CMU subject is about 24 units."""
    from . import _arrays
    from ._native import ffi, lib
    from ._rig import axis
    from .errors import check
    p = np.ascontiguousarray(_positions(m), dtype=np.float64)
    if p.shape[0] == 0:
        raise InvalidArgumentError("body_height needs at least one frame")
    k = axis(up if up is not None else getattr(m, "up_axis", "y"), "body_height")
    h = ffi.new("double *")
    diag = ffi.new("mlr_diag *")
    # the C core's body size (mlr_rig_body_height), the one every C threshold uses
    check(lib.mlr_rig_body_height(p.shape[0], p.shape[1], _arrays.ptr(p), k, h, ffi.NULL, diag),
          "body_height", diag)
    return float(h[0])


# Body heights (a person or an animal standing: 0.3 to 2.5 m) in each length unit.
_UNIT_RANGES = (("m", 0.3, 2.5), ("cm", 30.0, 250.0), ("mm", 300.0, 2500.0))


def length_unit(height: float) -> str | None:
    """A guess at a clip's length unit from its body height in file units: "m", "cm" or "mm"
    when the height is one of a person's or an animal's (0.3 to 2.5 m) in just that unit, else
    None (CMU's converted files, about 24 units for a person, are in none of them)."""
    found = [u for u, lo, hi in _UNIT_RANGES if lo <= height <= hi]
    return found[0] if len(found) == 1 else None


def foot_sliding(m, contacts, names, up=None) -> float:
    """Mean horizontal speed of the contact joints while they are in contact.

    m: a Motion; contacts: bool (N, C) as returned by :func:`mlayer.detect_contacts`; names: the
    C contact point names (joints, or "Joint/End" for a joint's End Site). For every joint c and every pair of consecutive frames (t, t+1) that are both
    in contact, the horizontal displacement |p_c(t+1) - p_c(t)| (in the plane normal to up:
    "x", "y", "z", or None for the motion's :attr:`~mlayer.Motion.up_axis`) times the
    frame rate; the mean over all such pairs of all joints. Units: the clip's length unit per
    second (cm/s for LaFAN1 and Bandai). 0 for a perfectly planted foot; NaN when no joint has
    two consecutive contact frames.
    """
    if not hasattr(m, "positions") or not hasattr(m, "skeleton"):
        raise InvalidArgumentError("foot_sliding: m must be a mlayer.Motion")
    names = [names] if isinstance(names, str) else list(names)
    c = np.asarray(contacts)
    if c.dtype != np.bool_ or c.ndim != 2 or c.shape != (m.n_frames, len(names)):
        raise InvalidArgumentError(
            f"foot_sliding: contacts must be a bool array ({m.n_frames}, {len(names)}), got "
            f"{c.dtype} {c.shape}")
    from .contacts import contact_positions
    from ._rig import motion_axis
    k = motion_axis(m, up, "foot_sliding")
    p = contact_positions(m, names)[:, :, [a for a in range(3) if a != k]]
    if p.shape[0] < 2:
        return float("nan")
    speed = np.linalg.norm(np.diff(p, axis=0), axis=-1) * m.fps
    both = c[1:] & c[:-1]
    if not both.any():
        return float("nan")
    return float(speed[both].mean())
