"""mlayer.pose_features: shape, root at the origin, invariance to root translation and heading,
stacking of clips."""
import numpy as np
import pytest

import mlayer
from mlayer.manifold.features import heading


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


def test_root_clip_features_are_root_relative(mocap):
    # a clip whose root carries the translation: the features are the root-relative positions
    # turned by the root's heading, exactly as before the body joint
    m = mlayer.read_bvh(mocap / "cmu_10_01_soccer_kick.bvh")
    pos, wrot = m.forward_kinematics()
    rel = pos - pos[:, :1]
    yaw = heading(wrot[:, 0])
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    ref = np.stack([c * rel[..., 0] - s * rel[..., 2], rel[..., 1],
                    s * rel[..., 0] + c * rel[..., 2]], axis=-1).reshape(m.n_frames, -1)
    np.testing.assert_array_equal(mlayer.pose_features(m), ref)


def test_bandai_features_follow_the_hips(mocap):
    # Bandai: a static joint_Root, the 9.6 m walk in the Hips channels. The features are
    # relative to Hips and its heading, so each frame spans a body, not the walk
    m = mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")
    hips = m.joint_names.index("Hips")
    F = mlayer.pose_features(m).reshape(m.n_frames, -1, 3)
    pos = m.positions()
    height = np.median(np.ptp(pos[..., 1], axis=1))
    assert np.ptp(pos[:, hips, [0, 2]], axis=0).max() > 5 * height  # the walk is long
    extent = np.ptp(F, axis=1).max()
    assert extent < 1.1 * height, (extent, height)  # measured 139.3 cm, the body 139.0 cm
    # relative to the static root (the features before the body joint) a frame spans the walk
    assert np.ptp(pos - pos[:, :1], axis=1).max() > 3 * height
    np.testing.assert_allclose(F[:, hips], 0.0, atol=1e-12)
    np.testing.assert_array_equal(F[:, 0], 0.0)  # the static root above the body holds no pose
    # moving and turning the walk (the Hips channels and its heading) changes nothing
    theta = 0.7
    c, s = np.cos(theta), np.sin(theta)
    Ry = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    p = list(m.trans_joints).index(hips)
    trans = m.trans.copy()
    trans[:, p] = trans[:, p] @ Ry.T + np.array([300.0, 0.0, -40.0])
    rot = np.array(m.rot, copy=True)
    rot[:, hips] = qmul(np.broadcast_to(yaw_quat(theta), rot[:, hips].shape), rot[:, hips])
    F2 = mlayer.pose_features(m.with_frames(trans=trans, rot=rot)).reshape(F.shape)
    np.testing.assert_allclose(F2, F, atol=1e-9 * np.abs(F).max())
