"""Motion.to_scipy / Motion.from_scipy (one scipy Rotation stack per joint) and
Motion.to_dataframe (one row per frame, one column per BVH channel), checked against the BVH
files' own channel values and against per-joint mlayer.quat.to_scipy."""
import numpy as np
import pytest

import mlayer
from conftest import reference, requires
from mlayer import quat

Rotation = reference("scipy.spatial.transform", "scipy").Rotation


def motion_values(text: str) -> np.ndarray:
    """The numbers of a BVH text's MOTION section (after 'Frames:' and 'Frame Time:')."""
    lines = text.split("MOTION", 1)[1].splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.strip().startswith("Frame Time")) + 1
    return np.array([[float(v) for v in ln.split()] for ln in lines[start:] if ln.strip()])


@pytest.mark.parametrize("name", ["cmu_131_01_mj_style_walk.bvh", "bandai1_walk_happy_001.bvh",
                                  "lafan1_clip_a.bvh"])
@requires("dataframe")
def test_dataframe_holds_the_files_channel_values(mocap, name):
    path = mocap / name
    m = mlayer.read_bvh(path)
    df = m.to_dataframe()
    raw = motion_values(path.read_text(errors="replace"))
    assert df.shape == raw.shape == (m.n_frames, m.skeleton.n_channels)
    # the columns are the file's channels, in its order
    want = [(n, c) for n, ch in zip(m.joint_names, m.channels) for c in ch.split()]
    assert list(df.columns) == want and df.columns.names == ["joint", "channel"]
    assert df.index.name == "frame" and df.attrs["fps"] == pytest.approx(m.fps)
    # positions are the file's numbers; angles the file's where they are in the canonical
    # ranges, and otherwise angles of the same rotation
    is_pos = np.array([c.endswith("position") for _, c in want])
    assert np.abs(df.values[:, is_pos] - raw[:, is_pos]).max() < 1e-9
    assert np.abs(df.values - motion_values(mlayer.write_bvh_string(m))).max() < 1e-9
    k = 0
    for j, (n, ch) in enumerate(zip(m.joint_names, m.channels)):
        rc = [c for c in ch.split() if c.endswith("rotation")]
        if len(rc) == 3:
            order = "".join(c[0] for c in rc)
            ang = df[n][rc].to_numpy()
            q = quat.from_euler(ang, order)
            dot = np.abs(np.sum(q * m.rot[:, j], axis=-1))
            assert dot.min() > 1 - 1e-12, (n, dot.min())
            k += 1
    assert k >= 20


@requires("dataframe")
def test_dataframe_of_an_empty_motion(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[:0]
    df = m.to_dataframe()
    assert df.shape == (0, m.skeleton.n_channels)


@pytest.mark.parametrize("name", ["cmu_131_01_mj_style_walk.bvh", "bandai1_walk_happy_001.bvh"])
def test_to_scipy_and_back(mocap, name):
    m = mlayer.read_bvh(mocap / name)
    f = m.to_scipy()
    assert len(f.rotations) == m.n_joints
    assert all(len(r) == m.n_frames for r in f.rotations)
    assert f.root_pos.shape == (m.n_frames, 3) and f.trans.shape == m.trans.shape
    # each joint's column is that joint's rotations, as mlayer.quat.to_scipy gives them
    for j in (0, 3, m.n_joints - 1):
        per_joint = quat.to_scipy(m.rot[:, j])
        assert np.allclose(f.rotations[j].as_matrix(), per_joint.as_matrix(), atol=1e-12)
        # BVH's intrinsic Euler order is scipy's uppercase order
        order = m.euler_orders[j]
        q2 = quat.from_euler(f.rotations[j].as_euler(order, degrees=True), order)
        assert np.abs(np.sum(q2 * m.rot[:, j], axis=-1)).min() > 1 - 1e-9
    # scipy rotates vectors as mlayer's quaternions do (a naive from_quat(m.rot) would not)
    v = np.array([0.3, -1.2, 0.5])
    qv = np.concatenate([[0.0], v])
    ref = quat.mul(quat.mul(m.rot[:, 2], qv), quat.conj(m.rot[:, 2]))[:, 1:]
    assert np.allclose(f.rotations[2].apply(v), ref, atol=1e-12)
    back = mlayer.Motion.from_scipy(m.skeleton, m.frame_time, *f)
    assert np.abs(back.rot - m.rot).max() < 1e-12
    assert np.array_equal(back.root_pos, m.root_pos) and np.array_equal(back.trans, m.trans)
    assert np.allclose(back.positions(), m.positions(), atol=1e-9)
    # the copies are the motion's values, not views of them
    keep = m.root_pos.copy()
    f.root_pos[:] += 1.0
    assert np.array_equal(m.root_pos, keep)


def test_from_scipy_accepts_flat_and_nd_stacks(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[:50]
    flat = quat.to_scipy(m.rot)
    a = mlayer.Motion.from_scipy(m.skeleton, m.frame_time, m.root_pos, flat)
    per_joint = [quat.to_scipy(m.rot[:, j]) for j in range(m.n_joints)]
    b = mlayer.Motion.from_scipy(m.skeleton, m.frame_time, m.root_pos, per_joint)
    done = [a, b]
    try:  # scipy 1.17 and later hold (N, J) rotations
        nd = Rotation.from_quat(quat.to_scalar_last(m.rot))
        done.append(mlayer.Motion.from_scipy(m.skeleton, m.frame_time, m.root_pos, nd))
    except ValueError:
        pass
    for x in done:
        assert np.abs(x.rot - m.rot).max() < 1e-12
    with pytest.raises(mlayer.InvalidArgumentError, match="rotations for 50 frames"):
        mlayer.Motion.from_scipy(m.skeleton, m.frame_time, m.root_pos, flat[:-1])
    with pytest.raises(mlayer.InvalidArgumentError, match="per-joint"):
        mlayer.Motion.from_scipy(m.skeleton, m.frame_time, m.root_pos, per_joint[:-1])
    with pytest.raises(mlayer.InvalidArgumentError, match="Rotation"):
        mlayer.Motion.from_scipy(m.skeleton, m.frame_time, m.root_pos, m.rot)


@pytest.mark.parametrize("name", ["cmu_131_01_mj_style_walk.bvh", "bandai1_walk_happy_001.bvh",
                                  "lafan1_clip_a.bvh"])
@requires("dataframe")
def test_from_dataframe_inverts_to_dataframe(mocap, name):
    m = mlayer.read_bvh(mocap / name)
    df = m.to_dataframe()
    back = mlayer.Motion.from_dataframe(df, m.skeleton)
    assert back.frame_time == m.frame_time and back.n_frames == m.n_frames
    np.testing.assert_allclose(back.root_pos, m.root_pos, atol=1e-9)
    np.testing.assert_allclose(back.trans, m.trans, atol=1e-9)
    # the same rotations (q and -q are one)
    assert np.abs(np.sum(back.rot * m.rot, axis=-1)).min() > 1 - 1e-12
    # and the same channel values again
    assert np.abs(back.to_dataframe().to_numpy() - df.to_numpy()).max() < 1e-7
    # flat column names, any column order, an explicit frame time
    flat = df.copy()
    flat.columns = ["/".join(c) for c in flat.columns]
    flat = flat[flat.columns[::-1]]
    flat.attrs.clear()
    again = mlayer.Motion.from_dataframe(flat, m.skeleton, frame_time=0.5)
    assert again.frame_time == 0.5
    np.testing.assert_allclose(again.root_pos, m.root_pos, atol=1e-9)


@requires("dataframe")
def test_from_dataframe_edits_reach_the_motion():
    m = mlayer.data.load_sample()[:30]
    df = m.to_dataframe()
    root = m.joint_names[0]
    df[root, "Yposition"] += 2.0
    lifted = mlayer.Motion.from_dataframe(df, m.skeleton)
    np.testing.assert_allclose(lifted.root_pos[:, 1], m.root_pos[:, 1] + 2.0)


@requires("dataframe")
def test_from_dataframe_names_the_bad_column():
    m = mlayer.data.load_sample()[:10]
    df = m.to_dataframe()
    root = m.joint_names[0]
    with pytest.raises(mlayer.InvalidArgumentError,
                       match=f"channel {root}/Xposition is missing from the table"):
        mlayer.Motion.from_dataframe(df.drop(columns=[(root, "Xposition")]), m.skeleton)
    extra = df.copy()
    extra["Nose", "Xposition"] = 0.0
    with pytest.raises(mlayer.InvalidArgumentError,
                       match="column Nose/Xposition is not a channel of the skeleton"):
        mlayer.Motion.from_dataframe(extra, m.skeleton)
    flat = df.copy()
    flat.columns = ["/".join(c) for c in flat.columns]
    twice = flat.rename(columns={f"{root}/Yposition": f"{root}/Xposition"})
    with pytest.raises(mlayer.InvalidArgumentError, match=f"column {root}/Xposition appears "
                                                          "twice"):
        mlayer.Motion.from_dataframe(twice, m.skeleton)
    nan = df.copy()
    nan.iloc[3, 2] = np.nan
    with pytest.raises(mlayer.InvalidArgumentError, match="is not finite at row 3"):
        mlayer.Motion.from_dataframe(nan, m.skeleton)
    bare = df.copy()
    bare.attrs.clear()
    with pytest.raises(mlayer.InvalidArgumentError, match="no frame_time"):
        mlayer.Motion.from_dataframe(bare, m.skeleton)
    with pytest.raises(mlayer.InvalidArgumentError, match="must be a pandas.DataFrame"):
        mlayer.Motion.from_dataframe(df.to_numpy(), m.skeleton)
