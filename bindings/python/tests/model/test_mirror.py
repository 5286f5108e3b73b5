"""mlayer.mirror on the shared clips: mirroring twice gives the input back, the mirrored positions
are the reflected positions of the input with left and right swapped, contacts swap sides, a
Z-up clip; keep_skeleton; bad input (unknown joints, a joint paired with itself, a bad plane);
the `mlayer mirror` command."""
from __future__ import annotations

import numpy as np
import pytest

import mlayer
from mlayer.cli import main
from mlayer.model.mirroring import mirror_plane
from conftest import SHARED_CLIPS

_CACHE: dict = {}


def clip(mocap, name: str) -> mlayer.Motion:
    if name not in _CACHE:
        _CACHE[name] = mlayer.read_bvh(mocap / name)
    return _CACHE[name].copy()


def partner_index(motion) -> np.ndarray:
    """Joint j's partner by the pairs mirror_pairs reports (mid-plane joints: themselves)."""
    names = motion.joint_names
    p = np.arange(motion.n_joints)
    for a, b in mlayer.mirror_pairs(motion):
        i, k = names.index(a), names.index(b)
        p[i], p[k] = k, i
    return p


def body_height(motion) -> float:
    return mlayer.metrics.body_height(motion)


def reflected_swapped(motion, axis: str) -> np.ndarray:
    p = motion.positions()[:, partner_index(motion)]
    p[..., "xyz".index(axis)] *= -1
    return p


@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_the_mirror_is_the_reflected_input_with_the_sides_swapped(mocap, name):
    m = clip(mocap, name)
    mm = mlayer.mirror(m)
    axis = mirror_plane(m)
    err = np.abs(mm.positions() - reflected_swapped(m, axis)).max()
    assert err <= 1e-9 * body_height(m), err / body_height(m)
    assert mm.joint_names == m.joint_names and np.array_equal(mm.skeleton.parents,
                                                              m.skeleton.parents)
    assert mm.up_axis == m.up_axis


@pytest.mark.parametrize("name", SHARED_CLIPS)
@pytest.mark.parametrize("keep", [False, True])
def test_mirroring_twice_gives_the_input_back_exactly(mocap, name, keep):
    m = clip(mocap, name)
    back = mlayer.mirror(mlayer.mirror(m, keep_skeleton=keep), keep_skeleton=keep)
    for attr in ("root_pos", "rot", "trans"):
        assert np.array_equal(getattr(back, attr), getattr(m, attr)), attr
    assert np.array_equal(back.skeleton.offsets, m.skeleton.offsets)
    assert np.array_equal(back.skeleton.end_site_offsets, m.skeleton.end_site_offsets)


@pytest.mark.parametrize("name", ["cmu_10_01_soccer_kick.bvh", "lafan1_clip_a.bvh",
                                  "bandai1_walk_happy_001.bvh"])
def test_keep_skeleton_keeps_the_bones_and_mirrors_the_motion(mocap, name):
    m = clip(mocap, name)[:200]
    exact, kept = mlayer.mirror(m), mlayer.mirror(m, keep_skeleton=True)
    assert kept.skeleton is m.skeleton
    for attr in ("root_pos", "rot", "trans"):
        assert np.array_equal(getattr(kept, attr), getattr(exact, attr)), attr
    # the bones are the input's: each bone keeps its length (a bone given by position
    # channels is motion, mirrored like the rest: Bandai's)
    par = m.skeleton.parents
    bones = np.setdiff1d(np.arange(1, m.n_joints), m.skeleton.trans_joints)
    lengths = lambda p: np.linalg.norm(p[:, bones] - p[:, par[bones]], axis=2)  # noqa: E731
    assert np.allclose(lengths(kept.positions()), lengths(m.positions()), rtol=0, atol=1e-9)
    # ... so the asymmetric skeletons come out close to, not exactly, the mirror image
    h = body_height(m)
    gap = np.abs(kept.positions() - exact.positions()).max() / h
    if m.trans.shape[1] < m.n_joints - 1:  # Bandai's bones are all position channels
        assert 1e-6 < gap < 0.1, gap


@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_contacts_swap_sides(mocap, name):
    m = clip(mocap, name)
    swap = {}
    for a, b in mlayer.mirror_pairs(m):
        swap[a], swap[b] = b, a

    def other(point: str) -> str:
        joint, _, end = point.partition("/")
        return swap.get(joint, joint) + ("/" + end if end else "")
    names, c = mlayer.detect_contacts(m)
    names_m, c_m = mlayer.detect_contacts(mlayer.mirror(m))
    assert names_m == names and c.any()
    expected = c[:, [names.index(other(n)) for n in names]]
    assert np.array_equal(c_m, expected)


def native_z_up(m: mlayer.Motion) -> mlayer.Motion:
    """The clip as a native Z-up rig: offsets, translations and rotations turned by +90
    degrees about X (Y to Z). Used by test_root_motion.py too."""
    Q = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    q = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0])
    sk = m.skeleton
    z_sk = mlayer.Skeleton(sk.joint_names, sk.parents, sk.offsets @ Q.T, sk.channels,
                           sk.end_site_parents, sk.end_site_offsets @ Q.T)
    qc = q * np.array([1, -1, -1, -1])
    rot = mlayer.quat.mul(mlayer.quat.mul(np.broadcast_to(q, m.rot.shape), m.rot),
                          np.broadcast_to(qc, m.rot.shape))
    out = mlayer.Motion(z_sk, m.frame_time, m.root_pos @ Q.T, mlayer.quat.normalize(rot),
                        m.trans @ Q.T)
    out.up_axis = "z"
    return out


def test_a_z_up_clip_mirrors_the_same_way(mocap):
    m = clip(mocap, "cmu_131_01_mj_style_walk.bvh")
    z = native_z_up(m)
    assert mirror_plane(z) == "x"
    mz = mlayer.mirror(z)
    h = body_height(z)
    assert np.abs(mz.positions() - reflected_swapped(z, "x")).max() <= 1e-9 * h
    # the Z-up mirror is the turned Y-up mirror
    Q = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    assert np.abs(mz.positions() - mlayer.mirror(m).positions() @ Q.T).max() <= 1e-9 * h
    back = mlayer.mirror(mz)
    assert np.array_equal(back.rot, z.rot) and np.array_equal(back.root_pos, z.root_pos)
    names, c = mlayer.detect_contacts(z)
    assert np.array_equal(mlayer.detect_contacts(mz)[1],
                          c[:, [names.index(n.replace("Left", "#").replace("Right", "Left")
                                            .replace("#", "Right")) for n in names]])


def test_the_pairs_by_name_and_explicit_pairs(mocap):
    m = clip(mocap, "cmu_10_01_soccer_kick.bvh")[:50]
    found = mlayer.mirror_pairs(m)
    assert ("lShldr", "rShldr") in found and ("leftEye", "rightEye") in found
    assert len(found) == 19
    # an explicit pair equal to the found one changes nothing; the three spellings agree
    ref = mlayer.mirror(m)
    for pairs in ({"lShldr": "rShldr"}, [("rShldr", "lShldr")], "lShldr=rShldr"):
        assert np.array_equal(mlayer.mirror(m, pairs=pairs).rot, ref.rot)
    # only the given pairs: the rest stays on its side
    assert mlayer.mirror_pairs(m, {"rightEye": "leftEye"}, by_name=False) == \
        [("leftEye", "rightEye")]  # the left first
    with pytest.raises(mlayer.InvalidArgumentError, match="rFoot pairs with lFoot, but their "
                       "parents rShin and lShin are not partners"):
        mlayer.mirror(m, pairs={"lFoot": "rFoot"}, by_name=False)
    # a plane given explicitly
    assert not np.array_equal(mlayer.mirror(m, plane="z").rot, ref.rot)
    assert np.array_equal(mlayer.mirror(m, plane="X").rot, ref.rot)


@pytest.mark.parametrize("kwargs,message", [
    (dict(pairs={"lHand": "Nope"}), "no joint named 'Nope'"),
    (dict(pairs="lHand=lHand"), "'lHand' is paired with itself"),
    (dict(pairs=[("lHand", "rHand"), ("lFoot", "lHand")]), "'lHand' is in two pairs"),
    (dict(pairs="lHand"), "'lHand' is not NAME=NAME"),
    (dict(pairs=[("lHand",)]), "is not a pair of joint names"),
    (dict(pairs=5), "pairs must be 'auto', a mapping"),
    (dict(pairs={"lHand": "chest"}), "chest pairs with lHand, but their parents abdomen"),
    (dict(plane="w"), "plane must be 'auto', 'x', 'y' or 'z', got 'w'"),
    (dict(plane=1), "plane must be"),
    (dict(keep_skeleton="yes"), "keep_skeleton must be True or False"),
])
def test_bad_input_names_the_argument(mocap, kwargs, message):
    m = clip(mocap, "cmu_10_01_soccer_kick.bvh")[:10]
    with pytest.raises(mlayer.InvalidArgumentError, match=message.replace("(", r"\(")):
        mlayer.mirror(m, **kwargs)


def test_a_skeleton_without_pairs_needs_a_plane():
    m = mlayer.Motion.from_arrays(["root", "a", "b"], [-1, 0, 1], np.ones((3, 3)),
                                  np.zeros((4, 3)), np.tile([1.0, 0, 0, 0], (4, 3, 1)))
    with pytest.raises(mlayer.InvalidArgumentError, match="no left/right joint pairs"):
        mlayer.mirror(m)
    out = mlayer.mirror(m, plane="x")
    assert np.array_equal(out.skeleton.offsets[:, 0], -m.skeleton.offsets[:, 0])
    with pytest.raises(mlayer.InvalidArgumentError, match="expected a mlayer.Motion"):
        mlayer.mirror(m.skeleton)


# ---- the command line ----------------------------------------------------------------------

def run(capsys, *argv):
    code = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_command_writes_the_mirror(capsys, tmp_path, mocap):
    src = mocap / "cmu_10_01_soccer_kick.bvh"
    out = tmp_path / "out.bvh"
    code, text, err = run(capsys, "mirror", src, "-o", out)
    assert code == 0 and err == "" and "19 joint pairs swapped" in text and "x plane" in text
    mlayer.write_bvh(mlayer.mirror(mlayer.read_bvh(src)), tmp_path / "ref.bvh")
    assert out.read_bytes() == (tmp_path / "ref.bvh").read_bytes()
    code, text, _ = run(capsys, "mirror", src, "-o", tmp_path / "k.bvh", "--keep-skeleton",
                        "--pairs", "lHand=rHand", "--plane", "x")
    assert code == 0 and "skeleton kept" in text
    k = mlayer.read_bvh(tmp_path / "k.bvh")
    assert np.allclose(k.skeleton.offsets, mlayer.read_bvh(src).skeleton.offsets)


@pytest.mark.parametrize("argv,message", [
    (["--pairs", "lHand=Nope"], "no joint named 'Nope'"),
    (["--pairs", "lHand=lHand"], "paired with itself"),
    (["--pairs", "lHand"], "is not NAME=NAME"),
    (["--plane", "w"], "plane must be 'auto', 'x', 'y' or 'z'"),
])
def test_bad_input_one_line_status_1_no_output(capsys, tmp_path, mocap, argv, message):
    out = tmp_path / "out.bvh"
    code, _, err = run(capsys, "mirror", mocap / "cmu_10_01_soccer_kick.bvh", "-o", out, *argv)
    assert code == 1
    assert err.count("\n") == 1 and message in err and err.startswith("mlayer mirror: error: ")
    assert list(tmp_path.iterdir()) == []
