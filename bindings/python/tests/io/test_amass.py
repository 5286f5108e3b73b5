"""AMASS / SMPL input and output (mlayer.read_amass, write_amass) and joint trees given in any
order (Skeleton, Motion.from_arrays). The AMASS files are synthetic, made here: AMASS itself
is licensed and not redistributable."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mlayer
from mlayer.io import smpl

RNG = np.random.default_rng(20261202)


def _poses(F: int, width: int, scale: float = 0.6) -> np.ndarray:
    return RNG.normal(0.0, scale, (F, width))


def _save(path, **keys):
    with open(path, "wb") as f:
        np.savez(f, **keys)
    return path


def _file(tmp_path, width=156, F=40, rate_key="mocap_framerate", fps=120.0, name="clip.npz",
          **extra):
    keys = dict(poses=_poses(F, width), trans=RNG.normal(0.0, 0.5, (F, 3)),
                betas=np.zeros(16), gender=np.array("female"))
    keys[rate_key] = np.array(fps)
    keys.update(extra)
    return _save(tmp_path / name, **keys), keys


def _reference_fk(poses_smpl: np.ndarray, trans: np.ndarray, parents, offsets) -> np.ndarray:
    """World joint positions (F, J, 3) in SMPL order, by scipy: R_j = R_parent R_local,
    p_j = p_parent + R_parent offset_j, the pelvis at trans + offset_0."""
    F, J = poses_smpl.shape[0], len(parents)
    offsets = np.array(offsets, dtype=np.float64)  # a writable copy (scipy's apply wants one)
    local = [Rotation.from_rotvec(poses_smpl[:, 3 * j:3 * j + 3]) for j in range(J)]
    world, pos = [None] * J, np.zeros((F, J, 3))
    for j in range(J):  # SMPL order has parents before children
        p = parents[j]
        if p < 0:
            world[j], pos[:, j] = local[j], trans + offsets[j]
        else:
            world[j] = world[p] * local[j]
            pos[:, j] = pos[:, p] + world[p].apply(offsets[j])
    return pos


def _by_smpl(m: mlayer.Motion, names) -> np.ndarray:
    idx = [m.joint_names.index(n) for n in names]
    return m.positions()[:, idx]


@pytest.mark.parametrize("width,model,J,hand_cols", [
    (72, "smpl", 22, None), (66, "smpl", 22, None),
    (156, "smplh", 52, (66, 156)), (165, "smplx", 52, (75, 165))])
def test_read_matches_scipy_fk(tmp_path, width, model, J, hand_cols):
    path, keys = _file(tmp_path, width=width)
    m = mlayer.read_amass(path)
    assert m.n_joints == J and m.n_frames == 40 and m.fps == pytest.approx(120.0)
    names, parents, offsets = smpl.tree(J == 52)
    assert sorted(m.joint_names) == sorted(names)
    cols = keys["poses"][:, :66]
    if hand_cols:
        cols = np.concatenate([cols, keys["poses"][:, hand_cols[0]:hand_cols[1]]], axis=1)
    ref = _reference_fk(cols, keys["trans"], parents, offsets)
    np.testing.assert_allclose(_by_smpl(m, names), ref, rtol=0, atol=1e-12)
    # explicit model= agrees with the width
    m2 = mlayer.read_amass(path, model=model)
    np.testing.assert_array_equal(m2.positions(), m.positions())


def test_depth_first_joint_order_and_names(tmp_path):
    path, _ = _file(tmp_path, width=72)
    m = mlayer.read_amass(path)
    # SMPL's order is not depth-first (L_Knee's parent L_Hip is not an ancestor of Spine1);
    # the motion's is, and source_order says where each joint came from
    assert m.joint_names[:5] == ["Pelvis", "L_Hip", "L_Knee", "L_Ankle", "L_Foot"]
    assert [smpl.SMPL_BODY_NAMES[i] for i in m.skeleton.source_order] == m.joint_names
    for j in range(1, m.n_joints):
        assert m.parents[j] < j


def test_framerate_keys_and_model_type(tmp_path):
    a, _ = _file(tmp_path, width=165, rate_key="mocap_frame_rate", fps=60.0, name="x.npz",
                 surface_model_type=np.array("smplx"))
    m = mlayer.read_amass(a)
    assert m.fps == pytest.approx(60.0) and m.n_joints == 52
    b, _ = _file(tmp_path, width=156, rate_key="mocap_framerate", fps=59.94, name="h.npz")
    assert mlayer.read_amass(b).fps == pytest.approx(59.94)
    with pytest.raises(mlayer.ParseError, match="156 columns per frame, smplx"):
        mlayer.read_amass(b, model="smplx")
    with pytest.raises(mlayer.InvalidArgumentError, match="model"):
        mlayer.read_amass(b, model="mano")


def test_split_keys_as_in_amass_x(tmp_path):
    F = 12
    ro, pb, ph = _poses(F, 3), _poses(F, 63), _poses(F, 90)
    path = _save(tmp_path / "split.npz", root_orient=ro, pose_body=pb, pose_hand=ph,
                 trans=np.zeros((F, 3)), mocap_frame_rate=np.array(30.0))
    m = mlayer.read_amass(path)
    names, parents, offsets = smpl.tree(True)
    ref = _reference_fk(np.concatenate([ro, pb, ph], axis=1), np.zeros((F, 3)), parents,
                        offsets)
    np.testing.assert_allclose(_by_smpl(m, names), ref, rtol=0, atol=1e-12)


def _standing(F: int, width: int = 156) -> np.ndarray:
    """Small motions around the rest pose, turned Z-up as AMASS's root orientation does."""
    p = _poses(F, width, scale=0.05)
    p[:, :3] = Rotation.from_euler("x", 90, degrees=True).as_rotvec()
    return p


def test_z_up(tmp_path):
    F = 30
    path = _save(tmp_path / "stand.npz", poses=_standing(F),
                 trans=np.tile([0.0, 0.0, 0.95], (F, 1)), mocap_framerate=np.array(30.0))
    m = mlayer.read_amass(path)
    assert m.up_axis == "z" and m.units == "m"
    guess = mlayer.detect_up(m)
    assert (guess.axis, guess.sign) == ("z", 1) and guess.sure
    pos = m.positions()
    head, foot = m.joint_names.index("Head"), m.joint_names.index("L_Foot")
    assert (pos[:, head, 2] - pos[:, foot, 2]).min() > 1.2  # standing, in metres
    assert 1.3 < mlayer.metrics.body_height(m) < 1.8


def test_joint_positions(tmp_path):
    path, keys = _file(tmp_path, width=156)
    names, parents, offsets = smpl.tree(True)
    # rest locations of a bigger subject, the pelvis off the origin as in the SMPL model
    jp = np.zeros((52, 3))
    for j in range(52):
        jp[j] = (jp[parents[j]] if parents[j] >= 0 else 0.0) + 1.1 * offsets[j]
    jp += [0.002, -0.22, 0.028]
    m = mlayer.read_amass(path, joint_positions=jp)
    own = offsets * 1.1
    own[0] = jp[0]
    ref = _reference_fk(keys["poses"], keys["trans"], parents, own)
    np.testing.assert_allclose(_by_smpl(m, names), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.root_pos, keys["trans"] + jp[0], rtol=0, atol=1e-15)
    # SMPL-X's 55 joints: jaw and eyes dropped
    jx = np.concatenate([jp[:22], np.full((3, 3), 9.0), jp[22:]])
    mx = mlayer.read_amass(path, joint_positions=jx)
    np.testing.assert_array_equal(mx.offsets, m.offsets)
    with pytest.raises(mlayer.InvalidArgumentError, match="30 rows"):
        mlayer.read_amass(path, joint_positions=np.zeros((30, 3)))
    with pytest.raises(mlayer.InvalidArgumentError, match="NaN"):
        mlayer.read_amass(path, joint_positions=np.full((52, 3), np.nan))


@pytest.mark.parametrize("width", [72, 156, 165])
def test_round_trip(tmp_path, width):
    path, keys = _file(tmp_path, width=width)
    m = mlayer.read_amass(path)
    out = tmp_path / "out.npz"
    mlayer.write_amass(m, out)
    m2 = mlayer.read_amass(out)
    assert m2.joint_names == m.joint_names and m2.fps == m.fps
    np.testing.assert_allclose(m2.positions(), m.positions(), rtol=0, atol=1e-9)
    np.testing.assert_allclose(m2.root_pos, m.root_pos, rtol=0, atol=1e-12)
    dots = np.abs(np.einsum("fjk,fjk->fj", m2.rot, m.rot))
    assert np.abs(dots - 1).max() < 1e-12
    with np.load(out, allow_pickle=False) as z:
        written = z["poses"]
        assert written.shape == (40, 72 if width == 72 else 156)
        assert str(z["surface_model_type"]) == ("smpl" if width == 72 else "smplh")
        assert float(z["mocap_framerate"]) == 120.0
        np.testing.assert_allclose(z["trans"], keys["trans"], rtol=0, atol=1e-12)
        # rotation vectors come back as given where the angle is below pi (log's range)
        src = keys["poses"][:, :66]
        small = np.linalg.norm(src.reshape(40, -1, 3), axis=-1) < np.pi - 1e-6
        got = written[:, :66].reshape(40, -1, 3)[small]
        np.testing.assert_allclose(got, src.reshape(40, -1, 3)[small], rtol=0, atol=1e-9)


def test_round_trip_with_joint_positions(tmp_path):
    path, keys = _file(tmp_path, width=156)
    jp = np.cumsum(np.abs(RNG.normal(0, 0.1, (52, 3))), axis=0)
    m = mlayer.read_amass(path, joint_positions=jp)
    mlayer.write_amass(m, tmp_path / "o.npz")
    with np.load(tmp_path / "o.npz", allow_pickle=False) as z:
        np.testing.assert_allclose(z["trans"], keys["trans"], rtol=0, atol=1e-12)
    m2 = mlayer.read_amass(tmp_path / "o.npz", joint_positions=jp)
    np.testing.assert_allclose(m2.positions(), m.positions(), rtol=0, atol=1e-9)


def test_write_other_tree_names_the_joint(tmp_path):
    cmu = mlayer.data.load_sample()
    with pytest.raises(mlayer.InvalidArgumentError, match=repr(cmu.joint_names[0])):
        mlayer.write_amass(cmu, tmp_path / "x.npz")
    path, _ = _file(tmp_path, width=72)
    m = mlayer.read_amass(path)
    names = list(m.joint_names)
    names[names.index("L_Knee")] = "LeftKnee"
    bad = mlayer.Motion.from_arrays(names, m.parents, m.offsets, m.root_pos, m.rot)
    with pytest.raises(mlayer.InvalidArgumentError, match="'LeftKnee'"):
        mlayer.write_amass(bad, tmp_path / "x.npz")
    # right names, wrong parent: R_Foot hung below L_Ankle
    par = m.parents.copy()
    par[names.index("R_Foot")] = names.index("L_Ankle")
    wrong = mlayer.Motion.from_arrays(m.joint_names, par, m.offsets, m.root_pos, m.rot)
    with pytest.raises(mlayer.InvalidArgumentError, match="'R_Foot'.*'L_Ankle'.*'R_Ankle'"):
        mlayer.write_amass(wrong, tmp_path / "x.npz")
    # a joint missing
    keep = [j for j, n in enumerate(m.joint_names) if n != "R_Foot"]
    remap = {old: new for new, old in enumerate(keep)}
    short = mlayer.Motion.from_arrays([m.joint_names[j] for j in keep],
                                      [remap.get(int(m.parents[j]), -1) for j in keep],
                                      m.offsets[keep], m.root_pos, m.rot[:, keep])
    with pytest.raises(mlayer.InvalidArgumentError, match="'R_Foot'.*missing"):
        mlayer.write_amass(short, tmp_path / "x.npz")
    assert not (tmp_path / "x.npz").exists()


# ---- bad input ----------------------------------------------------------------------------

def _bad(tmp_path, **keys):
    base = dict(poses=_poses(10, 156), trans=np.zeros((10, 3)),
                mocap_framerate=np.array(30.0))
    base.update(keys)
    return _save(tmp_path / "bad.npz", **{k: v for k, v in base.items() if v is not None})


@pytest.mark.parametrize("keys,reason", [
    (dict(poses=None), "no 'poses'"),
    (dict(trans=None), "no 'trans'"),
    (dict(mocap_framerate=None), "no frame rate"),
    (dict(poses=np.zeros(156)), "'poses' must have 2 dimensions"),
    (dict(poses=np.zeros((10, 100))), "100 columns"),
    (dict(trans=np.zeros((10, 2))), r"'trans' must be \(10, 3\)"),
    (dict(trans=np.zeros((9, 3))), r"'trans' must be \(10, 3\)"),
    (dict(trans=np.zeros(3)), "'trans' must have 2 dimensions"),
    (dict(poses=np.full((10, 156), np.nan)), "'poses' has a non-finite value at \\(0, 0\\)"),
    (dict(trans=np.array([[0, 0, np.inf]] * 10)), "'trans' has a non-finite value"),
    (dict(mocap_framerate=np.array(0.0)), "must be positive"),
    (dict(mocap_framerate=np.array(-120.0)), "must be positive"),
    (dict(mocap_framerate=np.array(np.nan)), "non-finite"),
    (dict(mocap_framerate=np.array([30.0, 60.0])), "must be one number"),
    (dict(poses=np.array([["a"] * 156] * 10)), "must hold numbers"),
    (dict(betas=np.array([np.nan] * 16)), "'betas' has a non-finite"),
])
def test_bad_files(tmp_path, keys, reason):
    path = _bad(tmp_path, **keys)
    with pytest.raises(mlayer.ParseError, match=reason) as e:
        mlayer.read_amass(path)
    assert str(e.value).startswith(str(path)) and e.value.path == str(path)


def test_not_an_npz(tmp_path):
    text = tmp_path / "walk.npz"
    text.write_text("HIERARCHY\nROOT Hips\n")
    with pytest.raises(mlayer.ParseError, match="not a numpy .npz archive"):
        mlayer.read_amass(text)
    npy = tmp_path / "poses.npy"
    np.save(npy, np.zeros((3, 156)))
    with pytest.raises(mlayer.ParseError, match="single .npy array"):
        mlayer.read_amass(npy)
    with pytest.raises(mlayer.MlayerIOError, match="cannot open"):
        mlayer.read_amass(tmp_path / "missing.npz")


def test_no_pickle(tmp_path):
    path = tmp_path / "pickled.npz"
    with open(path, "wb") as f:
        np.savez(f, poses=np.array([object()] * 3, dtype=object), trans=np.zeros((3, 3)),
                 mocap_framerate=np.array(30.0))
    with pytest.raises(mlayer.ParseError, match="without pickle"):
        mlayer.read_amass(path)


# ---- joint trees in any order ---------------------------------------------------------------

def _shuffled_tree():
    """The SMPL body tree in a random order (parents after children too), with its arrays."""
    names, parents, offsets = smpl.tree(False)
    perm = RNG.permutation(22)
    inv = np.argsort(perm)
    return ([names[i] for i in perm], [int(inv[parents[i]]) if parents[i] >= 0 else -1
                                       for i in perm], np.asarray(offsets)[perm], perm)


def test_from_arrays_any_order():
    names, parents, offsets, perm = _shuffled_tree()
    assert any(p > j for j, p in enumerate(parents))  # truly not even topological
    F = 8
    rv = _poses(F, 66).reshape(F, 22, 3)
    rot_smpl = mlayer.quat.exp(rv)
    root = RNG.normal(size=(F, 3))
    m = mlayer.Motion.from_arrays(names, parents, offsets, root, rot_smpl[:, perm], fps=30)
    sm, sp, so = smpl.tree(False)
    # the reference takes AMASS's trans, the pelvis less its rest location (row 0 of the offsets)
    ref = _reference_fk(rv.reshape(F, -1), root - so[0], sp, so)
    np.testing.assert_allclose(_by_smpl(m, sm), ref, rtol=0, atol=1e-12)
    assert [names[i] for i in m.skeleton.source_order] == m.joint_names
    assert m.parents[0] == -1 and all(m.parents[j] < j for j in range(1, 22))
    # a written BVH reads back with the same hierarchy
    back = mlayer.read_bvh_string(mlayer.write_bvh_string(m))
    assert back.joint_names == m.joint_names
    np.testing.assert_allclose(back.positions(), m.positions(), rtol=0, atol=1e-4)


def test_any_order_with_position_channels_and_end_sites():
    # root R, children A (with position channels) and B; B listed first, A's child C last
    names = ["B", "R", "C", "A"]
    parents = [1, -1, 3, 1]
    offsets = np.array([[0, 0, 1.0], [0, 0, 0], [0, 1.0, 0], [1.0, 0, 0]])
    ch = ["Zrotation Yrotation Xrotation",
          "Xposition Yposition Zposition Zrotation Yrotation Xrotation",
          "Zrotation Yrotation Xrotation",
          "Xposition Yposition Zposition Zrotation Yrotation Xrotation"]
    F = 3
    rot = mlayer.quat.exp(_poses(F, 12).reshape(F, 4, 3))
    trans = RNG.normal(size=(F, 1, 3))  # A's translation (the only non-root position joint)
    m = mlayer.Motion.from_arrays(names, parents, offsets, np.zeros((F, 3)), rot, channels=ch,
                                  trans=trans, end_site_parents=[2, 0],
                                  end_site_offsets=[[0, 2.0, 0], [0, 0, 3.0]])
    assert m.joint_names == ["R", "B", "A", "C"]
    np.testing.assert_array_equal(m.trans, trans)
    np.testing.assert_array_equal(m.rot, rot[:, [1, 0, 3, 2]])
    # End Sites follow their joints: B's first (index 1), then C's (index 3)
    np.testing.assert_array_equal(m.end_site_parents, [1, 3])
    np.testing.assert_array_equal(m.end_site_offsets, [[0, 0, 3.0], [0, 2.0, 0]])
    # world position of C: A's translation, then C's offset rotated by R and A
    R = Rotation.from_quat(mlayer.quat.to_scalar_last(rot[:, 1]))
    A = R * Rotation.from_quat(mlayer.quat.to_scalar_last(rot[:, 3]))
    c = R.apply(trans[:, 0]) + A.apply([0, 1.0, 0])
    np.testing.assert_allclose(m.positions()[:, 3], c, rtol=0, atol=1e-12)


@pytest.mark.parametrize("parents,reason", [
    ([-1, 0, 3, 2], r"joint 'c' \(index 2\) is not below the root"),
    ([-1, 0, -1, 2], "2 roots: joints 'a' .* and 'c'"),
    ([1, 0, 1, 2], "no root"),
    ([-1, 0, 7, 2], r"joint 'c' \(index 2\) has parent 7, outside -1..3"),
    ([-1, 1, 0, 2], r"joint 'b' \(index 1\) is its own parent"),
])
def test_bad_trees_name_the_joint(parents, reason):
    with pytest.raises(mlayer.InvalidArgumentError, match=reason):
        mlayer.Skeleton(["a", "b", "c", "d"], parents, np.zeros((4, 3)))


def test_depth_first_input_unchanged():
    m = mlayer.data.load_sample()
    sk = mlayer.Skeleton(m.joint_names, m.parents, m.offsets, m.channels,
                         m.end_site_parents, m.end_site_offsets)
    assert sk == m.skeleton
    np.testing.assert_array_equal(sk.source_order, np.arange(sk.n_joints))


# ---- the layers on an AMASS clip -----------------------------------------------------------

def _walk(F: int, fps: float) -> np.ndarray:
    """Poses (F, 156) of a walk-like clip: hips, knees and arms swinging at 1 Hz, Z-up."""
    t = np.arange(F) / fps
    s = np.sin(2 * np.pi * t)
    p = np.zeros((F, 156))
    p[:, :3] = Rotation.from_euler("x", 90, degrees=True).as_rotvec()
    idx = {n: i for i, n in enumerate(smpl.SMPL_BODY_NAMES)}
    for side, sign in (("L", 1.0), ("R", -1.0)):
        p[:, 3 * idx[f"{side}_Hip"]] = 0.45 * sign * s
        p[:, 3 * idx[f"{side}_Knee"]] = 0.6 * np.maximum(0.0, sign * np.cos(2 * np.pi * t))
        p[:, 3 * idx[f"{side}_Shoulder"] + 2] = -sign * 1.2  # arms down from the T-pose
        p[:, 3 * idx[f"{side}_Shoulder"] + 0] = -0.3 * sign * s
    return p


def test_layers_on_amass_walk(tmp_path):
    F, fps = 240, 60.0
    clean = _walk(F, fps)
    trans = np.stack([np.zeros(F), 1.2 * np.arange(F) / fps, np.full(F, 0.9)], axis=1)
    noisy = clean + RNG.normal(0.0, 0.03, clean.shape) * (np.arange(156) >= 3)
    _save(tmp_path / "clean.npz", poses=clean, trans=trans, mocap_framerate=np.array(fps))
    _save(tmp_path / "noisy.npz", poses=noisy, trans=trans, mocap_framerate=np.array(fps))
    ref = mlayer.read_amass(tmp_path / "clean.npz").positions()
    m = mlayer.read_amass(tmp_path / "noisy.npz")
    out = mlayer.denoise(m)
    assert out.up_axis == "z" and out.joint_names == m.joint_names
    p_in, p_out = m.positions(), out.positions()
    assert np.isfinite(p_out).all()
    err_in = np.linalg.norm(p_in - ref, axis=-1).mean()
    err_out = np.linalg.norm(p_out - ref, axis=-1).mean()
    assert err_out < 0.7 * err_in, (err_in, err_out)
    # jitter (second differences) of the body joints falls
    acc = lambda p: np.linalg.norm(np.diff(p, 2, axis=0), axis=-1).mean()  # noqa: E731
    assert acc(p_out) < 0.5 * acc(p_in)
    # the walk is kept: the pelvis still travels its 4.8 m along y
    travel = p_out[-1, 0, 1] - p_out[0, 0, 1]
    assert abs(travel - 1.2 * (F - 1) / fps) < 0.1
    st = mlayer.stylize(out, 1.5)
    ps = st.positions()
    assert np.isfinite(ps).all() and st.n_frames == F
    # bones stay rigid (FK on the same offsets) and the body stays upright and on its feet
    head, foot = st.joint_names.index("Head"), st.joint_names.index("L_Ankle")
    assert (ps[:, head, 2] - ps[:, foot, 2]).min() > 1.0
    mlayer.write_amass(st, tmp_path / "styled.npz")
    assert mlayer.read_amass(tmp_path / "styled.npz").n_frames == F


def test_large_trees_in_linear_time():
    import time
    # a chain of 20,000 joints, then 20,000 children of the root: depth-first already, and
    # checking it must not walk the chain for every child (that was J x depth steps)
    J = 40000
    parents = np.concatenate([[-1], np.arange(19999), np.zeros(20000, dtype=np.int64)])
    t0 = time.perf_counter()
    order = mlayer.model.motion.depth_first_order(parents)
    assert np.array_equal(order, np.arange(J))
    # the same tree listed backwards (every parent after its children) is reordered
    rev = np.where(parents[::-1] < 0, -1, J - 1 - parents[::-1])
    order = mlayer.model.motion.depth_first_order(rev)
    assert order[0] == J - 1 and np.array_equal(np.sort(order), np.arange(J))
    assert time.perf_counter() - t0 < 5.0


def test_body_kept_through_a_round_trip(tmp_path):
    betas = RNG.normal(size=16)
    path, _ = _file(tmp_path, width=165, betas=betas, gender=np.array("female"),
                    surface_model_type=np.array("smplx"))
    m, body = mlayer.read_amass(path, return_body=True)
    assert body.gender == "female" and body.model == "smplx"
    np.testing.assert_array_equal(body.betas, betas)
    mlayer.write_amass(m, tmp_path / "o.npz", betas=body.betas, gender=body.gender)
    m2, body2 = mlayer.read_amass(tmp_path / "o.npz", return_body=True)
    assert body2.gender == "female" and body2.model == "smplh"  # hands kept, jaw/eyes not
    np.testing.assert_array_equal(body2.betas, betas)
    # no betas, and a gender stored as a pickled object: both None, the motion still reads
    F = 5
    with open(tmp_path / "p.npz", "wb") as f:
        np.savez(f, poses=_poses(F, 72), trans=np.zeros((F, 3)), mocap_framerate=np.array(30.0),
                 gender=np.array([b"male"], dtype=object))
    m3, body3 = mlayer.read_amass(tmp_path / "p.npz", return_body=True)
    assert body3 == (None, None, "smpl") and m3.n_joints == 22


def test_hostile_header_is_refused_before_allocating(tmp_path):
    # an .npz whose 'poses' header declares 10^12 x 156 doubles over a few bytes of data
    header = {"descr": "<f8", "fortran_order": False, "shape": (10 ** 12, 156)}
    buf = __import__("io").BytesIO()
    np.lib.format.write_array_header_1_0(buf, header)
    buf.write(b"\0" * 64)
    import zipfile
    path = tmp_path / "hostile.npz"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("poses.npy", buf.getvalue())
        b2 = __import__("io").BytesIO()
        np.save(b2, np.zeros((3, 3)))
        zf.writestr("trans.npy", b2.getvalue())
    with pytest.raises(mlayer.ParseError, match="declares a larger array"):
        mlayer.read_amass(path)


def test_cli_convert_amass(tmp_path, capsys):
    """`mlayer convert` reads .npz files as AMASS and writes motions on the SMPL tree back."""
    from mlayer.cli import main
    src, _ = _file(tmp_path, width=156, F=30)
    ref = mlayer.read_amass(src)
    assert main(["convert", str(src), str(tmp_path / "a.bvh")]) == 0
    via_bvh = mlayer.read_bvh(tmp_path / "a.bvh", up="z", units="m")
    np.testing.assert_allclose(via_bvh.positions(), ref.positions(), rtol=0, atol=1e-6)
    assert main(["convert", str(tmp_path / "a.bvh"), str(tmp_path / "b.npz")]) == 0
    back = mlayer.read_amass(tmp_path / "b.npz")
    np.testing.assert_allclose(back.positions(), ref.positions(), rtol=0, atol=1e-6)
    assert main(["convert", str(src), str(tmp_path / "c.glb")]) == 0
    assert (tmp_path / "c.glb").stat().st_size > 0
    capsys.readouterr()
    # a clip that is not on the SMPL tree: one line naming the joint, exit 1, no file
    assert main(["convert", str(mlayer.data.sample_path()), str(tmp_path / "d.npz")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Hips" in err[0], err
    assert not (tmp_path / "d.npz").exists()
    # npz to npz is not a conversion
    assert main(["convert", str(src), str(tmp_path / "e.npz")]) == 1
    assert not (tmp_path / "e.npz").exists()


def test_hostile_archives_are_refused_before_they_expand(tmp_path):
    """Issue 39: a raw pickle member raised AttributeError; a 0-frame file was accepted and
    could not be written back; an archive's members are checked against max_bytes (their
    declared sizes, before anything is decompressed)."""
    import pickle
    import zipfile
    p = tmp_path / "pk.npz"
    with zipfile.ZipFile(p, "w") as z:
        z.writestr("poses", pickle.dumps([1, 2, 3]))
        z.writestr("trans.npy", b"")
    with pytest.raises(mlayer.ParseError, match="'poses' is not a numpy array"):
        mlayer.read_amass(p)
    p = tmp_path / "zero.npz"
    np.savez(p, poses=np.zeros((0, 156)), trans=np.zeros((0, 3)),
             mocap_framerate=np.array(120.0))
    with pytest.raises(mlayer.ParseError, match="no frames"):
        mlayer.read_amass(p)
    # 40,000 frames of zeros: 25 MB of members in a 0.1 MB file
    p = tmp_path / "bomb.npz"
    np.savez_compressed(p, poses=np.zeros((40000, 156)), trans=np.zeros((40000, 3)),
                        mocap_framerate=np.array(120.0))
    assert p.stat().st_size < 200_000
    with pytest.raises(mlayer.ParseError, match=r"expand to \d+ bytes, more than max_bytes"):
        mlayer.read_amass(p, max_bytes=10_000_000)
    assert mlayer.read_amass(p).n_frames == 40000  # within the default budget
    with pytest.raises(mlayer.InvalidArgumentError, match="max_bytes"):
        mlayer.read_amass(p, max_bytes=0)


@pytest.mark.parametrize("name", ["amass_zlib_error.npz", "amass_header_token_error.npz"])
def test_fuzzed_archives_are_parse_errors(name):
    """Cases tests/fuzz/fuzz_readers.py found (issue 39, item 2): a zlib.error and a
    TokenError before; a ParseError naming the file now."""
    from conftest import REPO
    path = REPO / "tests" / "data" / "fuzz" / name
    with pytest.raises(mlayer.ParseError) as e:
        mlayer.read_amass(path)
    assert str(path) in str(e.value)


def test_fuzzed_gender_that_is_not_an_array_is_left_out():
    """Another case the fuzzer found: ``gender`` stored as raw bytes (not .npy) raised an
    AttributeError; like a gender that would need pickle, it is now read as absent."""
    from conftest import REPO
    m, body = mlayer.read_amass(REPO / "tests" / "data" / "fuzz" / "amass_gender_not_npy.npz",
                                return_body=True)
    assert m.n_frames == 10 and body.gender is None
