"""Pose features for the motion manifold (paper 2, section 2): forward-kinematics joint
positions with the body's position and heading removed, one 3J vector per frame. The body is
the joint that carries the body translation (:func:`mlayer.layers.layers.body_translation_joint`):
the root, or on rigs with a static root above a moving pelvis (Bandai) that pelvis."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidArgumentError
from ..layers.layers import body_translation_joint
from ..model.motion import Motion
from ..model.up_axis import to_y_up


def heading(rot_root: ArrayLike) -> NDArray[np.float64]:
    """Yaw of root rotations about +Y.

    The angle of the rotated +Z axis projected on the XZ plane, ``atan2(f_x, f_z)``.

    Parameters
    ----------
    rot_root : array_like, shape (N, 4)
        Scalar-first world rotations.

    Returns
    -------
    numpy.ndarray, shape (N,)
        Radians.
    """
    q = np.asarray(rot_root, dtype=np.float64)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    fx = 2.0 * (x * z + w * y)
    fz = 1.0 - 2.0 * (x * x + y * y)
    return np.arctan2(fx, fz)


def _one(m: Motion, body: int) -> NDArray[np.float64]:
    pos, wrot = m.forward_kinematics()     # (N, J, 3), (N, J, 4)
    pos, wrot = to_y_up(m.up_axis, pos, wrot)  # Z-up and X-up clips turned to Y-up
    rel = pos - pos[:, body:body + 1, :]   # the body joint's position removed
    yaw = heading(wrot[:, body])
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    out = np.empty_like(rel)
    # rotate by -yaw about Y: x' = c x - s z, z' = s x + c z
    out[..., 0] = c * rel[..., 0] - s * rel[..., 2]
    out[..., 1] = rel[..., 1]
    out[..., 2] = s * rel[..., 0] + c * rel[..., 2]
    if body != 0:
        # joints outside the body joint's subtree (the static root above it) stay where the
        # body left them: relative to the body they only hold the path, not the pose
        out[:, ~_subtree(m.skeleton.parents, body)] = 0.0
    return out.reshape(m.n_frames, -1)


def _subtree(parents: NDArray[np.int32], body: int) -> NDArray[np.bool_]:
    """(J,) mask of the body joint and its descendants (parents before children)."""
    inside = np.zeros(len(parents), dtype=bool)
    inside[body] = True
    for j in range(body + 1, len(parents)):
        inside[j] = inside[parents[j]]
    return inside


def pose_features(motion: Motion | Sequence[Motion]) -> NDArray[np.float64]:
    """Pose features of a motion, or of several clips of one skeleton.

    For each frame: world joint positions by forward kinematics, minus the body joint's world
    position, rotated about +Y by minus the body joint's heading (:func:`heading` of its world
    rotation), so a clip moved on the floor or turned about the vertical axis gives the same
    features. The body joint is the root on most rigs; where a joint below a static root
    carries the translation (Bandai's Hips) it is that joint
    (:func:`mlayer.layers.layers.body_translation_joint`, one joint for all the clips), and the
    joints outside its subtree (that static root) get zero features. Units are those of the
    clip.

    Parameters
    ----------
    motion : Motion or list or tuple of Motion
        One clip, or clips stacked in order; "one skeleton" means the same hierarchy, i.e.
        equal parent arrays (joint names may differ between exports, e.g. CMU's LeftHip /
        LeftUpLeg).

    Returns
    -------
    numpy.ndarray, shape (N, 3J)
        Joint j's coordinates are columns 3j .. 3j+2.

    Raises
    ------
    mlayer.InvalidArgumentError
        For no clips, something else than Motions, or clips of other skeletons.
    """
    clips: list[Any] = list(motion) if isinstance(motion, (list, tuple)) else [motion]
    if not clips:
        raise InvalidArgumentError("pose_features: no clips")
    for m in clips:
        if not isinstance(m, Motion):
            raise InvalidArgumentError(f"pose_features: expected Motion objects, got {type(m)}")
    sk = clips[0].skeleton
    for i, m in enumerate(clips[1:], 1):
        if not np.array_equal(m.skeleton.parents, sk.parents):
            raise InvalidArgumentError(f"pose_features: clip {i} has another skeleton than clip 0")
    body = body_translation_joint(clips)
    return np.concatenate([_one(m, body) for m in clips], axis=0)


__all__ = ["pose_features", "heading"]
