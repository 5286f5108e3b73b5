"""Two-bone IK (mlayer.ik): exact reach, bone lengths kept, identity at zero displacement."""
import numpy as np
import pytest

import mlayer
from mlayer import ik


def _leg(rng, n):
    """Random bent legs: hip at 0, thigh length 4, shin length 3."""
    hip = rng.normal(size=(n, 3))
    d1 = rng.normal(size=(n, 3))
    d1 /= np.linalg.norm(d1, axis=1, keepdims=True)
    d2 = rng.normal(size=(n, 3))
    d2 /= np.linalg.norm(d2, axis=1, keepdims=True)
    knee = hip + 4.0 * d1
    end = knee + 3.0 * d2
    return hip, knee, end


def _apply(hip, knee, end, r_hip, r_knee):
    from mlayer.guards.ik import _rotate
    c1 = knee + _rotate(r_knee, end - knee)
    return hip + _rotate(r_hip, knee - hip), hip + _rotate(r_hip, c1 - hip)


def test_reaches_reachable_targets_exactly(rng):
    hip, knee, end = _leg(rng, 2000)
    # targets at distances strictly inside (|l1 - l2|, l1 + l2) = (1, 7)
    dirs = rng.normal(size=(2000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    target = hip + dirs * rng.uniform(1.2, 6.9, size=(2000, 1))
    r_hip, r_knee = ik.two_bone(hip, knee, end, target)
    k1, e1 = _apply(hip, knee, end, r_hip, r_knee)
    np.testing.assert_allclose(e1, target, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(k1 - hip, axis=1), 4.0, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(e1 - k1, axis=1), 3.0, rtol=1e-12)


def test_identity_when_target_is_the_end(rng):
    hip, knee, end = _leg(rng, 500)
    r_hip, r_knee = ik.two_bone(hip, knee, end, end.copy())
    k1, e1 = _apply(hip, knee, end, r_hip, r_knee)
    np.testing.assert_allclose(k1, knee, atol=1e-9)
    np.testing.assert_allclose(e1, end, atol=1e-9)


def test_unreachable_target_stops_on_the_line(rng):
    hip, knee, end = _leg(rng, 100)
    target = hip + np.array([20.0, 0.0, 0.0])
    r_hip, r_knee = ik.two_bone(hip, knee, end, target)
    _, e1 = _apply(hip, knee, end, r_hip, r_knee)
    d = e1 - hip
    assert np.all(np.linalg.norm(d, axis=1) <= 7.0 + 1e-9)
    np.testing.assert_allclose(d / np.linalg.norm(d, axis=1, keepdims=True),
                               np.tile([1.0, 0.0, 0.0], (100, 1)), atol=1e-9)


def test_from_to(rng):
    u, v = rng.normal(size=(300, 3)), rng.normal(size=(300, 3))
    u[0], v[0] = [1, 0, 0], [-1, 0, 0]  # opposite
    q = ik.from_to(u, v)
    from mlayer.guards.ik import _rotate
    r = _rotate(q, u / np.linalg.norm(u, axis=1, keepdims=True))
    np.testing.assert_allclose(r, v / np.linalg.norm(v, axis=1, keepdims=True), atol=1e-12)


def test_apply_leg_on_a_real_clip(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    sk = m.skeleton
    chain = ik.leg_chain(sk, sk.index("LeftAnkle"))
    assert [sk.joint_names[j] for j in chain] == ["LeftHip", "LeftKnee", "LeftAnkle"]
    pos, wrot = m.forward_kinematics()
    target = pos[:, chain[2]] + np.array([0.5, 0.5, -0.4])  # about 4 cm in CMU units
    rot = m.rot.copy()
    ik.apply_leg(rot, pos, wrot, sk.parents, chain, target)
    out = m.with_frames(rot=rot)
    p1 = out.positions()
    h, k, e = chain
    reach = (np.linalg.norm(pos[:, k] - pos[:, h], axis=1)
             + np.linalg.norm(pos[:, e] - pos[:, k], axis=1))
    ok = np.linalg.norm(target - pos[:, h], axis=1) < 0.97 * reach
    assert ok.mean() > 0.6
    np.testing.assert_allclose(p1[ok, e], target[ok], atol=1e-8)
    # bone lengths of every joint unchanged; joints outside the leg did not move
    for j in range(1, sk.n_joints):
        par = sk.parents[j]
        np.testing.assert_allclose(np.linalg.norm(p1[:, j] - p1[:, par], axis=1),
                                   np.linalg.norm(pos[:, j] - pos[:, par], axis=1), atol=1e-9)
    moved = set(range(chain[0], chain[2] + 2))  # the leg and its toe
    for j in set(range(sk.n_joints)) - moved:
        np.testing.assert_allclose(p1[:, j], pos[:, j], atol=1e-9)


def test_leg_chain_skips_zero_length_bones():
    m = mlayer.Motion.from_arrays(
        ["root", "hipjoint", "thigh", "shin", "foot"], [-1, 0, 1, 2, 3],
        [[0, 0, 0], [0, 0, 0], [0, -4, 0], [0, -3, 0], [0, -1, 0]],
        np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 5, 1)))
    assert ik.leg_chain(m.skeleton, 4) == (2, 3, 4)
    with pytest.raises(mlayer.InvalidArgumentError, match="two-bone chain"):
        ik.leg_chain(m.skeleton, 2)


def test_bad_input():
    with pytest.raises(mlayer.InvalidArgumentError):
        ik.two_bone(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((2, 3)), np.zeros((3, 3)))
    bad = np.zeros((2, 3))
    bad[0, 0] = np.nan
    with pytest.raises(mlayer.InvalidArgumentError, match="NaN"):
        ik.two_bone(bad, np.ones((2, 3)), np.ones((2, 3)) * 2, np.zeros((2, 3)))
