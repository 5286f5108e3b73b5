"""Pose features for the motion manifold (paper 2, section 2): forward-kinematics joint
positions with the root position and heading removed, one 3J vector per frame."""
from __future__ import annotations

import numpy as np

from .errors import InvalidArgumentError
from .motion import Motion


def heading(rot_root) -> np.ndarray:
    """Yaw (radians, about +Y) of root rotations (N, 4) scalar-first: the angle of the rotated
    +Z axis projected on the XZ plane, atan2(f_x, f_z)."""
    q = np.asarray(rot_root, dtype=np.float64)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    fx = 2.0 * (x * z + w * y)
    fz = 1.0 - 2.0 * (x * x + y * y)
    return np.arctan2(fx, fz)


def _one(m: Motion) -> np.ndarray:
    pos, wrot = m.forward_kinematics()  # (N, J, 3), (N, J, 4)
    rel = pos - pos[:, :1, :]           # root position removed
    yaw = heading(wrot[:, 0])
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    out = np.empty_like(rel)
    # rotate by -yaw about Y: x' = c x - s z, z' = s x + c z
    out[..., 0] = c * rel[..., 0] - s * rel[..., 2]
    out[..., 1] = rel[..., 1]
    out[..., 2] = s * rel[..., 0] + c * rel[..., 2]
    return out.reshape(m.n_frames, -1)


def pose_features(motion) -> np.ndarray:
    """(N, 3J) pose features of a Motion, or of several clips of one skeleton (a list or tuple
    of Motions, stacked in order; "one skeleton" means the same hierarchy, i.e. equal parent
    arrays: joint names may differ between exports, e.g. CMU's LeftHip / LeftUpLeg).

    For each frame: world joint positions by forward kinematics, minus the root joint's world
    position, rotated about +Y by minus the root's heading (:func:`heading`), so a clip moved
    on the floor or turned about the vertical axis gives the same features. Units are those of
    the clip. Joint j's coordinates are columns 3j .. 3j+2.
    """
    clips = list(motion) if isinstance(motion, (list, tuple)) else [motion]
    if not clips:
        raise InvalidArgumentError("pose_features: no clips")
    for m in clips:
        if not isinstance(m, Motion):
            raise InvalidArgumentError(f"pose_features: expected Motion objects, got {type(m)}")
    sk = clips[0].skeleton
    for i, m in enumerate(clips[1:], 1):
        if not np.array_equal(m.skeleton.parents, sk.parents):
            raise InvalidArgumentError(f"pose_features: clip {i} has another skeleton than clip 0")
    return np.concatenate([_one(m) for m in clips], axis=0)


__all__ = ["pose_features", "heading"]
