"""mlayer.pose_features: shape, root at the origin, invariance to root translation and heading,
stacking of clips."""
import numpy as np
import pytest

import mlayer
from mlayer.features import heading


def yaw_quat(theta):
    return np.array([np.cos(theta / 2), 0.0, np.sin(theta / 2), 0.0])


def qmul(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2],
                    axis=-1)


def test_shape_and_root_at_origin():
    m = mlayer.data.load_sample()
    F = mlayer.pose_features(m)
    assert F.shape == (m.n_frames, 3 * m.n_joints)
    np.testing.assert_allclose(F[:, :3], 0.0, atol=1e-12)


@pytest.mark.parametrize("theta", [0.3, -2.0, np.pi])
def test_invariant_to_root_translation_and_heading(theta):
    m = mlayer.data.load_sample()
    F = mlayer.pose_features(m)
    c, s = np.cos(theta), np.sin(theta)
    Ry = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    root = m.root_pos @ Ry.T + np.array([123.0, 4.0, -56.0])
    rot = np.array(m.rot, copy=True)
    rot[:, 0] = qmul(np.broadcast_to(yaw_quat(theta), rot[:, 0].shape), rot[:, 0])
    m2 = m.with_frames(root_pos=root, rot=rot)
    F2 = mlayer.pose_features(m2)
    np.testing.assert_allclose(F2, F, atol=1e-8 * np.abs(F).max())
    # the heading really moved by theta
    d = np.angle(np.exp(1j * (heading(m2.world_rotations()[:, 0]) -
                              heading(m.world_rotations()[:, 0]) - theta)))
    np.testing.assert_allclose(d, 0.0, atol=1e-9)


def test_stacking_clips_of_one_skeleton(mocap):
    a = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    b = mlayer.read_bvh(mocap / "cmu_01_01_playground_jumps.bvh")
    F = mlayer.pose_features([a, b])
    assert F.shape == (a.n_frames + b.n_frames, 93)
    np.testing.assert_array_equal(F[: a.n_frames], mlayer.pose_features(a))
    other = mlayer.read_bvh(mocap / "lafan1_clip_a.bvh")  # 22 joints
    with pytest.raises(mlayer.InvalidArgumentError, match="skeleton"):
        mlayer.pose_features([a, other])
    with pytest.raises(mlayer.InvalidArgumentError, match="no clips"):
        mlayer.pose_features([])
