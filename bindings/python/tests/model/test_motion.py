"""Motion: building from arrays, slicing, copies, new frames, forward kinematics checked
against an independent numpy/scipy implementation, and the bundled sample clip."""
import numpy as np
import pytest

import mlayer
from conftest import reference
from mlayer import Motion

R = reference("scipy.spatial.transform", "scipy").Rotation


def random_quats(rng, shape):
    q = rng.normal(size=shape + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def reference_fk(m):
    """World positions and rotations with scipy Rotations, joint by joint (no C involved)."""
    N, J = m.n_frames, m.n_joints
    t = np.broadcast_to(m.offsets, (N, J, 3)).copy()
    t[:, 0] = m.root_pos
    for k, j in enumerate(m.trans_joints):
        t[:, j] = m.trans[:, k]
    local = [R.from_quat(m.rot[:, j], scalar_first=True) for j in range(J)]
    wrot, pos = [None] * J, np.empty((N, J, 3))
    for j in range(J):
        p = m.parents[j]
        if p < 0:
            wrot[j], pos[:, j] = local[j], t[:, j]
        else:
            wrot[j] = wrot[p] * local[j]
            pos[:, j] = pos[:, p] + wrot[p].apply(t[:, j])
    q = np.stack([w.as_quat(scalar_first=True) for w in wrot], axis=1)
    return pos, q


def same_rotation(a, b, tol):
    d = np.abs(np.einsum("...i,...i->...", a, b))
    return np.all(d >= 1 - tol)


@pytest.fixture
def tree(rng):
    """A 6-joint tree with two branches, a non-root joint with position channels, End Sites."""
    names = ["root", "spine", "head", "arm", "hand", "leg"]
    parents = [-1, 0, 1, 1, 3, 0]
    offsets = rng.normal(size=(6, 3))
    channels = [None, "Zrotation Xrotation Yrotation", "Yrotation Xrotation Zrotation",
                "Xposition Yposition Zposition Xrotation Yrotation Zrotation",
                "Zrotation Yrotation Xrotation", "Xrotation Zrotation Yrotation"]
    channels[0] = "Xposition Yposition Zposition Zrotation Yrotation Xrotation"
    N = 17
    return dict(joint_names=names, parents=parents, offsets=offsets, channels=channels,
                root_pos=rng.normal(size=(N, 3)), rot=random_quats(rng, (N, 6)),
                trans=rng.normal(size=(N, 1, 3)), end_site_parents=[2, 4, 5],
                end_site_offsets=rng.normal(size=(3, 3)), fps=60)


def test_from_arrays_defaults(rng):
    N = 5
    m = Motion.from_arrays(["a", "b", "c"], [-1, 0, 1], np.eye(3), np.zeros((N, 3)),
                           random_quats(rng, (N, 3)))
    assert m.fps == pytest.approx(30.0) and m.n_frames == N == len(m) and m.n_joints == 3
    M = mlayer.model.motion
    root_ch, joint_ch = M.DEFAULT_ROOT_CHANNELS, M.DEFAULT_JOINT_CHANNELS
    assert m.channels == (root_ch, joint_ch, joint_ch)
    assert m.euler_orders == ("ZYX",) * 3
    assert m.trans.shape == (N, 0, 3) and m.trans_joints.shape == (0,)
    assert m.skeleton.n_channels == 12 and m.skeleton.n_end_sites == 0
    assert list(m.parents) == [-1, 0, 1] and m.parents.dtype == np.int32
    assert m.joint_names == ["a", "b", "c"]


def test_from_arrays_round_trip_through_bvh(tree, tmp_path):
    m = Motion.from_arrays(**tree)
    assert list(m.trans_joints) == [3]
    assert m.euler_orders == ("ZYX", "ZXY", "YXZ", "XYZ", "ZYX", "XZY")
    f = tmp_path / "tree.bvh"
    mlayer.write_bvh(m, f)
    m2 = mlayer.read_bvh(f)
    assert m2.skeleton == m.skeleton
    assert m2.frame_time == m.frame_time
    assert same_rotation(m2.rot, m.rot, 1e-14)
    np.testing.assert_allclose(m2.root_pos, m.root_pos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m2.trans, m.trans, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m2.positions(), m.positions(), rtol=0, atol=1e-7)
    np.testing.assert_array_equal(m2.end_site_parents, [2, 4, 5])
    np.testing.assert_array_equal(m2.end_site_offsets, tree["end_site_offsets"])


def test_fk_matches_scipy_reference(tree):
    m = Motion.from_arrays(**tree)
    pos, wrot = m.forward_kinematics()
    ref_pos, ref_rot = reference_fk(m)
    np.testing.assert_allclose(pos, ref_pos, rtol=0, atol=1e-12)
    assert same_rotation(wrot, ref_rot, 1e-12)
    np.testing.assert_array_equal(m.positions(), pos)
    np.testing.assert_array_equal(m.world_rotations(), wrot)
    # the arm's position channels replace its OFFSET
    np.testing.assert_allclose(
        pos[:, 3] - pos[:, 1], R.from_quat(wrot[:, 1], scalar_first=True).apply(m.trans[:, 0]),
        atol=1e-12)
    # End Sites: parent position + parent world rotation applied to the End Site OFFSET
    es = m.end_site_positions()
    for k, j in enumerate(m.end_site_parents):
        np.testing.assert_allclose(
            es[:, k], pos[:, j] + R.from_quat(wrot[:, j], scalar_first=True).apply(
                m.end_site_offsets[k].copy()), atol=1e-12)


def test_fk_on_the_sample_clip_matches_scipy_reference():
    m = mlayer.data.load_sample()[::7]
    ref_pos, ref_rot = reference_fk(m)
    pos, wrot = m.forward_kinematics()
    np.testing.assert_allclose(pos, ref_pos, rtol=0, atol=1e-10)
    assert same_rotation(wrot, ref_rot, 1e-12)


def test_local_translations(tree):
    m = Motion.from_arrays(**tree)
    t = m.local_translations()
    np.testing.assert_array_equal(t[:, 0], m.root_pos)
    np.testing.assert_array_equal(t[:, 3], m.trans[:, 0])
    np.testing.assert_array_equal(t[:, 2], np.broadcast_to(m.offsets[2], (len(m), 3)))


def test_slicing(tree):
    m = Motion.from_arrays(**tree)
    s = m[3:10]
    assert isinstance(s, Motion) and len(s) == 7 and s.skeleton is m.skeleton
    np.testing.assert_array_equal(s.rot, m.rot[3:10])
    np.testing.assert_array_equal(s.root_pos, m.root_pos[3:10])
    np.testing.assert_array_equal(s.trans, m.trans[3:10])
    np.testing.assert_array_equal(s.positions(), m.positions()[3:10])
    assert s.frame_time == m.frame_time
    s.rot[0, :, 0] += 1.0  # a slice owns its frames
    assert not np.array_equal(m.rot[3], s.rot[0])
    assert len(m[-4:]) == 4 and len(m[100:]) == 0 and len(m[:0].positions()) == 0
    e = m[::2]
    assert len(e) == 9 and e.fps == pytest.approx(30.0)
    np.testing.assert_array_equal(e.rot, m.rot[::2])
    one = m[-1]
    assert len(one) == 1
    np.testing.assert_array_equal(one.rot[0], m.rot[-1])
    with pytest.raises(IndexError):
        m[17]
    with pytest.raises(ValueError):
        m[::-1]
    with pytest.raises(TypeError):
        m["a"]


def test_copy_and_with_frames(tree, rng):
    m = Motion.from_arrays(**tree)
    c = m.copy()
    c.root_pos += 1
    assert not np.array_equal(c.root_pos, m.root_pos) and c.skeleton is m.skeleton
    new_rot = random_quats(rng, (40, 6))
    w = m.with_frames(root_pos=np.zeros((40, 3)), rot=new_rot, trans=np.ones((40, 1, 3)))
    assert len(w) == 40 and w.skeleton is m.skeleton and w.rot is new_rot  # no copy
    w2 = m.with_frames(rot=m.rot[::-1].copy())
    np.testing.assert_array_equal(w2.root_pos, m.root_pos)
    assert w2.root_pos is not m.root_pos
    assert m.with_frames(frame_time=0.5).fps == 2.0
    with pytest.raises(mlayer.InvalidArgumentError):
        m.with_frames(rot=new_rot)  # root_pos still has 17 frames
    with pytest.raises(mlayer.InvalidArgumentError, match="unit"):
        m.with_frames(rot=2 * m.rot)
    bad = m.rot.copy()
    bad[2, 1, 0] = np.nan
    with pytest.raises(mlayer.InvalidArgumentError, match="NaN"):
        m.with_frames(rot=bad)
    with pytest.raises(mlayer.InvalidArgumentError):
        m.with_frames(rot=m.rot[:, :5])


def test_bad_skeletons_are_refused_with_a_reason(rng):
    q = random_quats(rng, (2, 3))
    p = np.zeros((2, 3))
    ok = dict(joint_names=["a", "b", "c"], parents=[-1, 0, 1], offsets=np.zeros((3, 3)))
    for change, match in [
        (dict(parents=[-1, 0, 2]), "parent"),
        (dict(parents=[0, 0, 1]), "parent"),
        (dict(parents=[-1, 0]), "parents"),
        (dict(joint_names=["a", "b{", "c"]), "name"),
        (dict(joint_names=["a", "", "c"]), "name"),
        (dict(offsets=np.zeros((2, 3))), "offsets"),
        (dict(offsets=np.full((3, 3), np.inf)), ""),
        (dict(channels=["Xposition", "Zrotation Zrotation", ""]), "channel"),
        (dict(channels=["Xposition", "Wrotation", ""]), "channel"),
        (dict(channels="Zrotation"), "channels"),
    ]:
        with pytest.raises(mlayer.InvalidArgumentError, match=f"(?i){match}"):
            Motion.from_arrays(**{**ok, **change}, root_pos=p, rot=q)
    with pytest.raises(mlayer.InvalidArgumentError):
        Motion.from_arrays(**ok, root_pos=p, rot=q, fps=0)
    with pytest.raises(mlayer.InvalidArgumentError):
        Motion.from_arrays(**ok, root_pos=p, rot=q, fps=30, frame_time=0.1)
    with pytest.raises(mlayer.InvalidArgumentError):
        Motion.from_arrays(**ok, root_pos=p, rot=q, end_site_parents=[5],
                           end_site_offsets=[[0, 1, 0]])


def test_joints_without_channels_and_partial_rotations(rng):
    m = Motion.from_arrays(["r", "fixed", "bend"], [-1, 0, 1], np.eye(3), np.zeros((3, 3)),
                           np.tile([1.0, 0, 0, 0], (3, 3, 1)),
                           channels=["Xposition Yposition Zposition", "", "Xrotation"])
    assert m.skeleton.n_channels == 4
    m.rot[:, 2] = R.from_euler("X", [[10], [20], [30]], degrees=True).as_quat(scalar_first=True)
    m2 = mlayer.read_bvh_string(mlayer.write_bvh_string(m))
    assert m2.channels == m.channels
    assert same_rotation(m2.rot, m.rot, 1e-14)


def test_skeleton_helpers():
    m = mlayer.data.load_sample()
    sk = m.skeleton
    assert sk.index("LeftKnee") == 3 and sk.children(0) == [1, 6, 11]
    assert sk.depth()[3] == 3
    with pytest.raises(ValueError):
        sk.index("Tail")
    assert not sk.parents.flags.writeable and not sk.offsets.flags.writeable
    assert "31 joints" in repr(sk)


def test_repr():
    r = repr(mlayer.data.load_sample())
    assert r.startswith("<mlayer.Motion 994 frames at 120 fps")
    assert "31 joints (+7 End Sites)" in r and "96 channels" in r and "'Hips'" in r


def test_bundled_sample(mocap):
    p = mlayer.data.sample_path()
    assert p.is_file() and p.name == "cmu_131_01_mj_style_walk.bvh"
    assert p.read_bytes() == (mocap / p.name).read_bytes()  # byte for byte
    readme = (p.parent / "README.md").read_text()
    assert "The data used in this project was obtained from mocap.cs.cmu.edu." in readme
    assert "NSF EIA-0196217" in readme
    m = mlayer.data.load_sample()
    assert m.n_frames == 994 and m.n_joints == 31 and m.fps == pytest.approx(120, rel=1e-4)
    ref = mlayer.read_bvh(mocap / p.name)
    np.testing.assert_array_equal(m.rot, ref.rot)


def test_edited_arrays_are_used(tree):
    m = Motion.from_arrays(**tree)
    m.root_pos = m.root_pos + 5.0  # replaced, not only edited in place
    ref, _ = reference_fk(m)
    np.testing.assert_allclose(m.positions(), ref, atol=1e-12)
    with pytest.raises(mlayer.InvalidArgumentError, match="Motion.rot"):
        m.rot = m.rot[:, :4]  # refused where it is assigned: the skeleton has more joints
    m.root_pos = m.root_pos[:5]  # a shape of its own, but not rot's frame count
    with pytest.raises(mlayer.InvalidArgumentError, match="Motion.root_pos"):
        m.positions()
