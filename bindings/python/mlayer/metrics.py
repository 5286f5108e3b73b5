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


def body_height(m) -> float:
    """Body size used to make thresholds and errors unit-free: the median over frames of the
    joints' vertical (Y) extent (End Sites excluded, so the head top and toe tips are not
    counted). Units: the clip's length unit; a standing CMU subject is about 24 units."""
    p = _positions(m)
    if p.shape[0] == 0:
        raise InvalidArgumentError("body_height needs at least one frame")
    return float(np.median(p[..., 1].max(axis=1) - p[..., 1].min(axis=1)))
