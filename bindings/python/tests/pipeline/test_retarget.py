"""mlayer.retarget against an independent reference: forward kinematics by scipy's Rotation
(world rotations composed down the tree) and the body frames of both rest poses by numpy, so
that every matched bone's world direction in the target is checked against the source's; a rig
onto itself; the top of the legs scaled by the leg lengths; the target as a skeleton, a motion
or a file; the map; bad input (a rig without legs, unknown joints) with nothing written; the
command; the feet sliding no more than the source's with the upper body kept."""
from __future__ import annotations

import numpy as np
import pytest

import mlayer
from mlayer.cli import main

Rotation = pytest.importorskip("scipy.spatial.transform").Rotation

HUMANS = ["cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh",
          "cmu_10_01_soccer_kick.bvh", "lafan1_clip_a.bvh", "bandai1_walk_happy_001.bvh"]
BONES = [("LeftUpperLeg", "LeftLowerLeg"), ("LeftLowerLeg", "LeftFoot"),
         ("RightUpperLeg", "RightLowerLeg"), ("RightLowerLeg", "RightFoot"),
         ("LeftShoulder", "LeftUpperArm"), ("LeftUpperArm", "LeftLowerArm"),
         ("LeftLowerArm", "LeftHand"), ("RightShoulder", "RightUpperArm"),
         ("RightUpperArm", "RightLowerArm"), ("RightLowerArm", "RightHand")]
_CACHE: dict = {}


def clip(mocap, name: str, frames: int = 90) -> mlayer.Motion:
    """The first frames of a shared clip, its position channels other than the body's at their
    OFFSETs (Bandai's repeat them with float noise, which a retarget does not carry)."""
    if name not in _CACHE:
        m = mlayer.read_bvh(mocap / name)[:frames]
        sk = m.skeleton
        if sk.trans_joints.size:
            t = m.trans.copy()
            for i, j in enumerate(sk.trans_joints.tolist()):
                if sk.joint_names[j] != "Hips":
                    t[:, i] = sk.offsets[j]
            m.trans = t
        _CACHE[name] = m
    return _CACHE[name].copy()


def scipy_fk(m: mlayer.Motion) -> np.ndarray:
    """World positions (N, J, 3) composed with scipy Rotation (scalar-last), independently of
    the C core's forward kinematics."""
    sk = m.skeleton
    N, J = m.n_frames, sk.n_joints
    trans = {j: i for i, j in enumerate(sk.trans_joints.tolist())}
    wr: list = [None] * J
    pos = np.zeros((N, J, 3))
    for j in range(J):
        local = Rotation.from_quat(m.rot[:, j][:, [1, 2, 3, 0]])
        p = sk.parents[j]
        if p < 0:
            wr[j], pos[:, j] = local, m.root_pos
            continue
        t = m.trans[:, trans[j]] if j in trans else np.tile(sk.offsets[j], (N, 1))
        pos[:, j] = pos[:, p] + wr[p].apply(t)
        wr[j] = wr[p] * local
    return pos


def rest_positions(sk) -> np.ndarray:
    pos = np.zeros((sk.n_joints, 3))
    for j in range(1, sk.n_joints):
        pos[j] = pos[sk.parents[j]] + sk.offsets[j]
    return pos


def body_frame(sk) -> np.ndarray:
    """Columns left, up, forward of a rest pose (mlr_retarget.h): up from the hips to the head,
    left from the right upper leg to the left one, each snapped to the nearest world axis."""
    roles = mlayer.retarget_roles(sk)
    names = sk.joint_names
    rp = rest_positions(sk)
    at = {r: rp[names.index(n)] for r, n in roles.items()}
    up = at["Head"] - at["Hips"]
    up /= np.linalg.norm(up)
    left = at["LeftUpperLeg"] - at["RightUpperLeg"]
    left -= left @ up * up
    left /= np.linalg.norm(left)
    up, left = snap(up), snap(left)
    return np.column_stack([left, up, np.cross(left, up)])


def snap(v: np.ndarray) -> np.ndarray:
    """The signed world axis nearest v."""
    out = np.zeros(3)
    k = int(np.argmax(np.abs(v)))
    out[k] = np.sign(v[k])
    return out


def world_frame(sk, up: str) -> np.ndarray:
    """The world frame (mlr_retarget.h): the rest body frame, or, where the world's up (given)
    is another axis than the rest's up (Bandai's bind pose lies along x), that up with the rest's
    left where it is level, else with the rest's forward."""
    body = body_frame(sk)
    k = "xyz".index(up)
    if abs(body[k, 1]) > 0.5:
        return body
    u = np.eye(3)[k]
    if abs(body[k, 0]) < 0.5:
        left = body[:, 0]
        return np.column_stack([left, u, np.cross(left, u)])
    fwd = body[:, 2]
    return np.column_stack([np.cross(u, fwd), u, fwd])


def bone_dirs(m: mlayer.Motion, pos: np.ndarray) -> dict:
    roles = mlayer.retarget_roles(m)
    names = m.joint_names
    out = {}
    for a, b in BONES:
        if a in roles and b in roles:
            d = pos[:, names.index(roles[b])] - pos[:, names.index(roles[a])]
            out[(a, b)] = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return out


def leg_length(sk) -> float:
    roles = mlayer.retarget_roles(sk)
    rp = rest_positions(sk)
    at = {r: rp[sk.joint_names.index(n)] for r, n in roles.items()}
    return float(np.mean([np.linalg.norm(at[f"{s}UpperLeg"] - at[f"{s}LowerLeg"])
                          + np.linalg.norm(at[f"{s}LowerLeg"] - at[f"{s}Foot"])
                          for s in ("Left", "Right")]))


@pytest.mark.parametrize("src", HUMANS)
@pytest.mark.parametrize("dst", HUMANS)
def test_every_matched_bone_points_as_the_source_s(mocap, src, dst):
    a, b = clip(mocap, src), clip(mocap, dst)
    out = mlayer.retarget(a, b, feet=False)
    assert out.joint_names == b.joint_names and out.n_frames == a.n_frames
    # target world -> source world
    G = world_frame(a.skeleton, a.up_axis) @ world_frame(b.skeleton, b.up_axis).T
    ds, dt = bone_dirs(a, scipy_fk(a)), bone_dirs(out, scipy_fk(out))
    assert set(dt) == set(ds) & set(dt) and len(dt) >= 8
    for k in dt:
        np.testing.assert_allclose(dt[k] @ G.T, ds[k], atol=1e-9, err_msg=f"{src}->{dst} {k}")
    # the top of the legs where the source's is, scaled by the leg lengths, raised along the
    # target's up by the median over frames of the target's ankle heights above their feet's
    # lowest points less the source's scaled (the mean of both sides)
    def mid(m, pos):
        r = mlayer.retarget_roles(m)
        return 0.5 * (pos[:, m.joint_names.index(r["LeftUpperLeg"])]
                      + pos[:, m.joint_names.index(r["RightUpperLeg"])])
    s = leg_length(b.skeleton) / leg_length(a.skeleton)
    up_a = world_frame(a.skeleton, a.up_axis)[:, 1]
    up_b = world_frame(b.skeleton, b.up_axis)[:, 1]
    pa, pb = scipy_fk(a), scipy_fk(out)
    da, _ = foot_drops(a, pa, up_a)
    db, _ = foot_drops(out, pb, up_b)
    lift = np.median((db - s * da).mean(axis=1))
    want = s * mid(a, pa) + lift * (G @ up_b)
    np.testing.assert_allclose(mid(out, pb) @ G.T, want, atol=1e-9 * np.abs(want).max())


def foot_drops(m, pos, up) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) each ankle's height above the lowest of its foot's points (toes, the End Sites of
    the foot and the toes) and (N, 2) the height of that lowest point, along up."""
    sk = m.skeleton
    r = mlayer.retarget_roles(m)
    wr = world_rotations_scipy(m)
    drops, lows = [], []
    for side in ("Left", "Right"):
        foot = sk.joint_names.index(r[f"{side}Foot"])
        toes = sk.joint_names.index(r[f"{side}Toes"]) if f"{side}Toes" in r else -1
        pts = [pos[:, foot]]
        if toes >= 0:
            pts.append(pos[:, foot] + wr[foot].apply(np.array(sk.offsets[toes])))
        for p, o in zip(sk.end_site_parents.tolist(), sk.end_site_offsets):
            if p == foot:
                pts.append(pos[:, foot] + wr[foot].apply(np.array(o)))
            elif p == toes:
                pts.append(pts[1] + wr[toes].apply(np.array(o)))
        h = np.stack(pts, 1) @ up
        drops.append(h[:, 0] - h.min(axis=1))
        lows.append(h.min(axis=1))
    return np.stack(drops, 1), np.stack(lows, 1)


def world_rotations_scipy(m) -> list:
    sk = m.skeleton
    wr: list = [None] * sk.n_joints
    for j in range(sk.n_joints):
        local = Rotation.from_quat(m.rot[:, j][:, [1, 2, 3, 0]])
        wr[j] = local if sk.parents[j] < 0 else wr[sk.parents[j]] * local
    return wr


@pytest.mark.parametrize("name", HUMANS)
def test_a_rig_onto_itself_gives_the_input_back(mocap, name):
    m = clip(mocap, name)
    out = mlayer.retarget(m, m, feet=False)
    np.testing.assert_allclose(out.rot, m.rot, atol=1e-9)
    np.testing.assert_allclose(out.root_pos, m.root_pos, atol=1e-9)
    np.testing.assert_allclose(out.trans, m.trans, atol=1e-9)


def test_the_target_as_skeleton_motion_or_file(mocap):
    a = clip(mocap, "cmu_01_01_playground_jumps.bvh")
    path = mocap / "lafan1_clip_a.bvh"
    b = mlayer.read_bvh(path, up="y")
    by_motion = mlayer.retarget(a, b)
    assert by_motion.up_axis == "y"
    # LaFAN1's bind pose lies along x: a bare skeleton needs its world up said
    for other in (mlayer.retarget(a, b.skeleton, target_up="y"), mlayer.retarget(a, path),
                  mlayer.retarget(a, str(path))):
        np.testing.assert_array_equal(other.rot, by_motion.rot)
        np.testing.assert_array_equal(other.root_pos, by_motion.root_pos)
    # standing: the head above the hips along y
    r = mlayer.retarget_roles(b)
    p = by_motion.positions()
    d = p[:, b.joint_names.index(r["Head"])] - p[:, b.joint_names.index(r["Hips"])]
    assert np.all(d[:, 1] > 0.8 * np.linalg.norm(d, axis=1))


def test_unmatched_target_joints_stay_at_rest(mocap):
    a = clip(mocap, "lafan1_clip_a.bvh")
    out = mlayer.retarget(a, clip(mocap, "cmu_01_01_playground_jumps.bvh"))
    # LaFAN1 has no hip joints between the hips and the legs, nor fingers
    for name in ("LHipJoint", "RHipJoint", "LFingers", "LThumb"):
        j = out.joint_names.index(name)
        np.testing.assert_allclose(np.abs(out.rot[:, j, 0]), 1.0, atol=1e-12)


def test_roles_of_the_shared_rigs(mocap):
    r = mlayer.retarget_roles(clip(mocap, "cmu_131_01_mj_style_walk.bvh"))
    assert (r["LeftShoulder"], r["LeftUpperArm"], r["LeftHand"]) == \
        ("LeftCollar", "LeftShoulder", "LeftWrist")
    assert [r[f"Spine{k}"] for k in range(3)] == ["lowerback", "Chest", "Chest2"]
    assert (r["Neck0"], r["Neck1"], r["Head"]) == ("lowerneck", "Neck", "Head")
    r = mlayer.retarget_roles(clip(mocap, "bandai1_walk_happy_001.bvh"))
    assert r["Hips"] == "Hips" and r["LeftToes"] == "Toes_L" and "Spine2" not in r


def _chain_skeleton(names=("base", "link1", "link2", "tip")) -> mlayer.Skeleton:
    n = len(names)
    return mlayer.Skeleton(list(names), [-1] + list(range(n - 1)), np.tile([0.0, 1.0, 0.0],
                                                                          (n, 1)))


def test_bad_input_names_what_is_missing(mocap):
    a = clip(mocap, "cmu_01_01_playground_jumps.bvh", 10)
    with pytest.raises(mlayer.InvalidArgumentError, match="target: no humanoid LeftFoot"):
        mlayer.retarget(a, _chain_skeleton())
    with pytest.raises(mlayer.InvalidArgumentError, match="no humanoid LeftFoot"):
        mlayer.retarget_roles(_chain_skeleton())
    b = clip(mocap, "lafan1_clip_a.bvh", 10)
    with pytest.raises(mlayer.InvalidArgumentError, match="target has no joint 'Nope'"):
        mlayer.retarget(a, b, mapping={"LeftFoot": "Nope"})
    with pytest.raises(mlayer.InvalidArgumentError, match="source has no joint 'Nope'"):
        mlayer.retarget(a, b, mapping="Nope=LeftFoot")
    with pytest.raises(mlayer.InvalidArgumentError, match="'LThumb' has no humanoid role"):
        mlayer.retarget(a, b, mapping=[("LThumb", "LeftHand")])
    with pytest.raises(mlayer.InvalidArgumentError, match="is not SOURCE=TARGET"):
        mlayer.retarget(a, b, mapping="LeftFoot")
    with pytest.raises(mlayer.InvalidArgumentError, match="expected a mlayer.Motion"):
        mlayer.retarget(a.skeleton, b)
    with pytest.raises(mlayer.InvalidArgumentError, match="target must be"):
        mlayer.retarget(a, 3)


def test_a_map_names_joints_the_names_do_not(mocap):
    a = clip(mocap, "lafan1_clip_a.bvh", 20)
    sk = a.skeleton
    names = [{"LeftFoot": "paw_a", "RightFoot": "paw_b"}.get(n, n) for n in sk.joint_names]
    odd = mlayer.Skeleton(names, sk.parents, sk.offsets, sk.channels, sk.end_site_parents,
                          sk.end_site_offsets)
    with pytest.raises(mlayer.InvalidArgumentError, match="target: no humanoid"):
        mlayer.retarget(a, odd)
    out = mlayer.retarget(a, odd, mapping={"LeftFoot": "paw_a", "RightFoot": "paw_b"},
                          feet=False, target_up="y")
    np.testing.assert_allclose(out.rot, a.rot, atol=1e-9)  # the same rig, renamed


# ---- the command line ----------------------------------------------------------------------

def run(capsys, *argv):
    code = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_command_writes_the_retargeted_clip(capsys, tmp_path, mocap):
    src, dst = mocap / "cmu_131_01_mj_style_walk.bvh", mocap / "lafan1_clip_a.bvh"
    out = tmp_path / "out.bvh"
    code, text, err = run(capsys, "retarget", src, "--to", dst, "-o", out)
    assert code == 0 and err == "" and "retargeted from 31 to 22 joints" in text
    ref = mlayer.retarget(mlayer.read_bvh(src), mlayer.read_bvh(dst))
    mlayer.write_bvh(ref, tmp_path / "ref.bvh")
    assert out.read_bytes() == (tmp_path / "ref.bvh").read_bytes()
    code, _, _ = run(capsys, "retarget", src, "--to", dst, "-o", tmp_path / "out.glb")
    assert code == 0 and (tmp_path / "out.glb").stat().st_size > 0


@pytest.mark.parametrize("argv,message", [
    (["--mapping", "LeftAnkle=Nope"], "target has no joint 'Nope'"),
    (["--mapping", "LeftAnkle"], "is not SOURCE=TARGET"),
])
def test_the_command_fails_in_one_line_and_writes_nothing(capsys, tmp_path, mocap, argv,
                                                          message):
    out = tmp_path / "out.bvh"
    code, text, err = run(capsys, "retarget", mocap / "cmu_131_01_mj_style_walk.bvh", "--to",
                          mocap / "lafan1_clip_a.bvh", "-o", out, *argv)
    assert code == 1 and message in err and len(err.strip().splitlines()) == 1
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_the_command_refuses_a_target_without_legs(capsys, tmp_path, mocap):
    chain = tmp_path / "chain.bvh"
    m = mlayer.Motion(_chain_skeleton(), 1 / 30, np.zeros((2, 3)),
                      np.tile([1.0, 0, 0, 0], (2, 4, 1)))
    mlayer.write_bvh(m, chain)
    out = tmp_path / "out.bvh"
    code, _, err = run(capsys, "retarget", mocap / "lafan1_clip_a.bvh", "--to", chain, "-o", out)
    assert code == 1 and "target: no humanoid LeftFoot" in err and not out.exists()


# ---- the feet ------------------------------------------------------------------------------

@pytest.mark.parametrize("src,dst", [("cmu_131_01_mj_style_walk.bvh",
                                      "bandai1_walk_happy_001.bvh"),
                                     ("bandai1_walk_happy_001.bvh", "lafan1_clip_a.bvh"),
                                     ("lafan1_clip_a.bvh", "cmu_10_01_soccer_kick.bvh")])
def test_the_feet_slide_no_more_than_the_source_s(mocap, src, dst):
    a = mlayer.read_bvh(mocap / src)[:240]
    b = mlayer.read_bvh(mocap / dst)
    bones, out = mlayer.retarget(a, b, feet=False), mlayer.retarget(a, b)
    ra, rb = mlayer.retarget_roles(a), mlayer.retarget_roles(b)
    # the source's contacts of its ankles, by mlayer.detect_contacts (the same detection the
    # C core runs), and the horizontal speed of the ankles on those frames, in leg lengths/s
    names = [ra["LeftFoot"], ra["RightFoot"]]
    _, c = mlayer.detect_contacts(a, names)
    assert c.sum() > 20

    def sliding(m, feet, leg):
        return mlayer.metrics.foot_sliding(m, c, feet) / leg

    s_a = sliding(a, names, leg_length(a.skeleton))
    s_out = sliding(out, [rb["LeftFoot"], rb["RightFoot"]], leg_length(b.skeleton))
    s_bones = sliding(bones, [rb["LeftFoot"], rb["RightFoot"]], leg_length(b.skeleton))
    # planted where the scaled source planted them: on the source's contact frames the ankles
    # move as the source's do, scaled (the same speed in leg lengths per second), not as the
    # bones alone put them
    assert s_out == pytest.approx(s_a, rel=1e-6) and s_out <= s_a * (1 + 1e-9)
    assert abs(s_bones - s_a) > 1e-3 * s_a
    # the rest of the body keeps its bones: the arms point as without the cleanup
    p1, p2 = bones.positions(), out.positions()
    for x, y in BONES[5:]:
        if x in rb and y in rb:
            d1 = p1[:, b.joint_names.index(rb[y])] - p1[:, b.joint_names.index(rb[x])]
            d2 = p2[:, b.joint_names.index(rb[y])] - p2[:, b.joint_names.index(rb[x])]
            np.testing.assert_allclose(d1, d2, atol=1e-9 * np.abs(d1).max())


def _world(m: mlayer.Motion) -> np.ndarray:
    """Positions (N, J, 3) by scipy_fk, in the rig's (left, up, forward) axes: the world up
    axis second."""
    p = scipy_fk(m)
    k = "xyz".index(m.up_axis)
    return p[..., [(k + 1) % 3, k, (k + 2) % 3]]


@pytest.mark.parametrize("src,dst", [("cmu_131_01_mj_style_walk.bvh",
                                      "bandai1_walk_happy_001.bvh"),
                                     ("bandai1_walk_happy_001.bvh", "lafan1_clip_a.bvh")])
def test_the_round_trip_with_the_feet_stays_within_one_percent(mocap, src, dst):
    # A -> B -> A with the feet planted both ways gives A back: the joints A and B both have,
    # by scipy's forward kinematics, within 1% of A's body height on average (the feet planted
    # at their own means and lifted to the source's median ground cost 1.12% and 1.80% on these
    # two); the cleanup changes the round trip by less than 1% of body height over the bones
    a = mlayer.read_bvh(mocap / src)[:240]
    b = mlayer.read_bvh(mocap / dst)
    back = mlayer.retarget(mlayer.retarget(a, b), a)
    back_bones = mlayer.retarget(mlayer.retarget(a, b, feet=False), a, feet=False)
    ra, rb = mlayer.retarget_roles(a), mlayer.retarget_roles(b)
    kinds = {k.rstrip("0123456789") for k in rb}
    keep = [a.joint_names.index(n) for k, n in ra.items()
            if k in rb or k.rstrip("0123456789") in kinds]
    pa, pback, pbones = _world(a), _world(back), _world(back_bones)
    h = float(np.median(pa[:, :, 1].max(axis=1) - pa[:, :, 1].min(axis=1)))
    err = np.linalg.norm(pback[:, keep] - pa[:, keep], axis=-1).mean() / h * 100
    err_bones = np.linalg.norm(pbones[:, keep] - pa[:, keep], axis=-1).mean() / h * 100
    assert err < 1.0 and err - err_bones < 1.0, (err, err_bones)


def _quadruped() -> mlayer.Skeleton:
    """A dog with a humanoid's names (as the AI4Animation dog has): Y-up, the spine along +z, the
    front legs ("arms") from the chest as long as the hind legs from the hips."""
    names = ["Hips", "Spine", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm",
             "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg",
             "RightLeg", "RightFoot"]
    parents = [-1, 0, 1, 1, 3, 4, 1, 6, 7, 0, 9, 10, 0, 12, 13]
    off = [[0, 30, 0], [0, 0, 40], [0, 8, 12], [6, 0, 0], [0, -14, 0], [0, -14, 0],
           [-6, 0, 0], [0, -14, 0], [0, -14, 0], [6, 0, 0], [0, -14, 0], [0, -14, 0],
           [-6, 0, 0], [0, -14, 0], [0, -14, 0]]
    return mlayer.Skeleton(names, parents, np.array(off, dtype=float))


def test_a_quadruped_is_refused_and_nothing_written(capsys, tmp_path, mocap):
    # the names give it every role; the proportions (front legs as long as the hind legs, the
    # torso longer than either, arms 1.00 and torso 40/28 = 1.43 of the legs) do not
    dog = _quadruped()
    with pytest.raises(mlayer.InvalidArgumentError,
                       match=r"rig: not a humanoid: arms \(LeftArm, RightArm\) 1\.00 and torso "
                             r"\(Hips-arms\) 1\.43 of the legs: a quadruped's \(humanoid: "
                             r"arms < [0-9.]+ or torso < [0-9.]+\) \[MLR_E_INVALID_ARG\]$"):
        mlayer.retarget_roles(dog)
    a = clip(mocap, "cmu_131_01_mj_style_walk.bvh", 10)
    with pytest.raises(mlayer.InvalidArgumentError, match="target: not a humanoid"):
        mlayer.retarget(a, dog)
    path = tmp_path / "dog.bvh"
    mlayer.write_bvh(mlayer.Motion(dog, 1 / 30, np.zeros((2, 3)),
                                   np.tile([1.0, 0, 0, 0], (2, dog.n_joints, 1))), path)
    out = tmp_path / "out.bvh"
    code, _, err = run(capsys, "retarget", mocap / "cmu_131_01_mj_style_walk.bvh", "--to", path,
                       "-o", out)
    assert code == 1 and "not a humanoid" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
    # the same tree standing, the arms at its sides and shorter than the legs, is a humanoid
    human = mlayer.Skeleton(dog.joint_names, dog.parents,
                            np.array([[0, 30, 0], [0, 20, 0], [0, 8, 0], [6, 0, 0], [0, -10, 0],
                                      [0, -10, 0], [-6, 0, 0], [0, -10, 0], [0, -10, 0],
                                      [6, 0, 0], [0, -14, 0], [0, -14, 0], [-6, 0, 0],
                                      [0, -14, 0], [0, -14, 0]], dtype=float))
    assert mlayer.retarget_roles(human)["LeftHand"] == "LeftHand"


def test_a_rig_whose_legs_hang_beside_the_spine_has_its_hips_and_head():
    # MakeHuman's tree: Root carries the spine and a pelvis joint named Hips that carries the
    # legs; the head found by name below Root (it was refused: not below the pelvis)
    names = ["Root", "Spine1", "Spine2", "Neck", "Head", "UpArm_L", "LoArm_L", "Hand_L",
             "UpArm_R", "LoArm_R", "Hand_R", "Hips", "UpLeg_L", "LoLeg_L", "Foot_L", "UpLeg_R",
             "LoLeg_R", "Foot_R"]
    parents = [-1, 0, 1, 2, 3, 2, 5, 6, 2, 8, 9, 0, 11, 12, 13, 11, 15, 16]
    off = [[0, 0, 0], [0, 8, 0], [0, 8, 0], [0, 3, 0], [0, 4, 0], [4, 0, 0], [8, 0, 0],
           [8, 0, 0], [-4, 0, 0], [-8, 0, 0], [-8, 0, 0], [0, -1, 0], [2, -2, 0], [0, -15, 0],
           [0, -15, 0], [-2, -2, 0], [0, -15, 0], [0, -15, 0]]
    r = mlayer.retarget_roles(mlayer.Skeleton(names, parents, np.array(off, dtype=float)))
    assert (r["Hips"], r["Head"], r["Neck0"], r["Spine0"], r["Spine1"]) == \
        ("Root", "Head", "Neck", "Spine1", "Spine2")
    assert r["LeftUpperLeg"] == "UpLeg_L" and "Spine2" not in r


def test_fingers_named_otherwise_follow_the_same_finger(mocap):
    # Daz's lIndex1, lThumb2 .. renamed as MakeHuman names them (Index1_L, Thumb2_L ..): the same
    # rig, so every finger must turn as the source's (they stayed at rest when only joints of
    # the same name were matched)
    a = clip(mocap, "cmu_10_01_soccer_kick.bvh", 20)
    sk = a.skeleton

    def rename(n: str) -> str:
        for f in ("Thumb", "Index", "Ring", "Pinky"):
            if len(n) == len(f) + 2 and n[1:].startswith(f) and n[0] in "lr":
                return f"{f}{n[-1]}_{n[0].upper()}"
        return n
    names = [rename(n) for n in sk.joint_names]
    fingers = [j for j, (n, m) in enumerate(zip(sk.joint_names, names)) if n != m]
    assert len(fingers) == 16
    odd = mlayer.Skeleton(names, sk.parents, sk.offsets, sk.channels, sk.end_site_parents,
                          sk.end_site_offsets)
    out = mlayer.retarget(a, odd, feet=False, target_up="y")
    moving = [j for j in fingers if not np.allclose(np.abs(a.rot[:, j, 0]), 1.0)]
    assert len(moving) == 6  # the others are still in this clip
    dots = np.abs(np.einsum("fjc,fjc->fj", out.rot[:, fingers], a.rot[:, fingers]))
    np.testing.assert_allclose(dots, 1.0, atol=1e-9)


def test_an_ankle_without_toes_follows_the_source_on_its_toes(mocap):
    # Daz's rig (CMU 10_01) has no toe joints: its ankles take the CMU source's toe contacts
    # too, so on every frame where a source foot touches (heel or toes) the target's ankle moves
    # as the source's, scaled (it moved as the bones put it where only the toes touched)
    a = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")[:240]
    b = mlayer.read_bvh(mocap / "cmu_10_01_soccer_kick.bvh")
    out = mlayer.retarget(a, b)
    ra, rb = mlayer.retarget_roles(a), mlayer.retarget_roles(b)
    assert "LeftToes" in ra and "LeftToes" not in rb
    pa, pb = scipy_fk(a), scipy_fk(out)
    toes_only = 0
    for side in ("Left", "Right"):
        _, c = mlayer.detect_contacts(a, [ra[f"{side}Foot"], ra[f"{side}Toes"]])
        on = c.any(axis=1)
        toes_only += int(np.sum(on & ~c[:, 0]))
        both = on[1:] & on[:-1]

        def speed(p, j, leg, frames):
            return np.linalg.norm(np.diff(p[:, j][:, [0, 2]], axis=0), axis=1)[frames] / leg
        v_a = speed(pa, a.joint_names.index(ra[f"{side}Foot"]), leg_length(a.skeleton), both)
        v_b = speed(pb, out.joint_names.index(rb[f"{side}Foot"]), leg_length(b.skeleton), both)
        np.testing.assert_allclose(v_b, v_a, atol=1e-6 * v_a.max())
    assert toes_only >= 5
