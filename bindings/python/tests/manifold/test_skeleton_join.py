"""Clips of one skeleton, checked by joint names and tree before any training (issue 43): the
first differing joint named in one line, --rename / rename= joining CMU's two naming schemes,
in PrimitiveModel.fit, `mlayer primitives`, `mlayer generate --keys` and the viewer's manifold.
"""
import json

import numpy as np
import pytest

import mlayer
from conftest import REPO
from mlayer.errors import InvalidArgumentError
from mlayer.manifold.primitives import (CMU_NAMES, PrimitiveModel, join_skeletons, rename_joints,
                               skeleton_difference)
from mlayer.cli import main

#: a CMU clip of the other naming scheme (LeftUpLeg, LeftLeg, ... where the walk has LeftHip,
#: LeftKnee, ...), in the repository
CMU_01 = REPO / "tests" / "data" / "wild" / "assimp_cmu_01_03_first600.bvh"
SMALL = dict(som=(6, 6), lattice=(4, 4), epochs=2, k=3)


@pytest.fixture(scope="module")
def walk():
    return mlayer.data.load_sample()[:240]


@pytest.fixture(scope="module")
def other(walk):
    """The walk with CMU's other names: the same tree and frames."""
    return rename_joints(walk, CMU_NAMES)


def test_rename_keeps_the_frames_and_the_tree(walk, other):
    assert other.skeleton.joint_names[2] == "LeftUpLeg" and walk.skeleton.joint_names[2] == \
        "LeftHip"
    # renamed at once: the walk's Neck becomes Neck1 while its lowerneck becomes Neck
    names = other.skeleton.joint_names
    assert names[walk.skeleton.joint_names.index("Neck")] == "Neck1"
    assert names[walk.skeleton.joint_names.index("lowerneck")] == "Neck"
    np.testing.assert_array_equal(other.skeleton.parents, walk.skeleton.parents)
    np.testing.assert_array_equal(other.rot, walk.rot)
    np.testing.assert_array_equal(other.positions(), walk.positions())
    # the real clip of the other scheme has exactly these names
    assert mlayer.read_bvh(CMU_01).skeleton.joint_names == names
    with pytest.raises(InvalidArgumentError, match="two joints would be named 'Hips'"):
        rename_joints(walk, {"LeftHip": "Hips"})


def test_the_first_differing_joint_is_named(walk, other):
    assert skeleton_difference(walk.skeleton, walk.skeleton) is None
    assert skeleton_difference(other.skeleton, walk.skeleton, "clip 0") == \
        "joint 2 is 'LeftUpLeg' where clip 0 has 'LeftHip'"
    # a tree that differs below the same names: the parent named
    sk = walk.skeleton
    par = sk.parents.copy()
    j = sk.joint_names.index("LeftToe")
    par[j] = sk.joint_names.index("LeftKnee")  # the toe on the knee
    moved = mlayer.Skeleton(sk.joint_names, par, sk.offsets)
    assert skeleton_difference(moved, sk) == (f"joint {j} 'LeftToe' has the parent 'LeftKnee' "
                                              f"where the first clip has 'LeftAnkle'")
    fewer = walk.skeleton.joint_names[:5]
    short = mlayer.Skeleton(fewer, sk.parents[:5], sk.offsets[:5])
    assert skeleton_difference(short, sk) == "5 joints where the first clip has 31 " \
                                             "(missing 'LeftToe')"


def test_join_renames_either_way(walk, other):
    with pytest.raises(InvalidArgumentError) as e:
        join_skeletons([walk, other], names=["a.bvh", "b.bvh"])
    assert str(e.value) == ("clip 1 (b.bvh): another skeleton: joint 2 is 'LeftUpLeg' where "
                            "clip 0 (a.bvh) has 'LeftHip'; join two naming schemes with option "
                            "rename")
    for clips in ([walk, other, walk], [other, walk, other]):
        joined = join_skeletons(clips, rename=CMU_NAMES)
        for m in joined:
            assert m.skeleton.joint_names == clips[0].skeleton.joint_names
            np.testing.assert_array_equal(m.rot, walk.rot)
    # a partial map: the joint it leaves differing is named
    with pytest.raises(InvalidArgumentError, match="joint 3 is 'LeftLeg' where clip 0 has "
                                                   "'LeftKnee'; option rename did not"):
        join_skeletons([walk, other], rename={"LeftUpLeg": "LeftHip"})


def test_fit_refuses_before_any_training(walk, other, monkeypatch):
    import mlayer.manifold.features
    import mlayer.manifold.primitives
    import mlayer.manifold.som

    def no_work(*a, **k):
        raise AssertionError("work started before the skeletons were checked")
    monkeypatch.setattr(mlayer.manifold.som.SOM, "train", no_work)
    monkeypatch.setattr(mlayer.manifold.features, "pose_features", no_work)
    monkeypatch.setattr(mlayer.manifold.primitives, "pose_features", no_work)  # its caller's name
    with pytest.raises(InvalidArgumentError, match=r"^clip 1 \(b\): another skeleton: joint 2"):
        PrimitiveModel.fit([walk, other], names=["a", "b"], **SMALL)


def test_fit_with_rename_is_the_fit_of_one_scheme(walk, other):
    joined = PrimitiveModel.fit([walk, other], rename=CMU_NAMES, **SMALL)
    same = PrimitiveModel.fit([walk, walk], **SMALL)
    assert joined.skeleton.joint_names == walk.skeleton.joint_names
    np.testing.assert_array_equal(joined.points, same.points)
    np.testing.assert_array_equal(joined.labels, same.labels)


def test_primitives_command_names_the_joint_and_joins(tmp_path, capsys):
    walk_path = mlayer.data.sample_path()
    out = tmp_path / "m.npz"
    argv = ["primitives", str(walk_path), str(CMU_01), "-o", str(out), "--plots", "",
            "--som", "6x6", "--lattice", "4x4", "--epochs", "2", "--k", "3"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "error" in ln]
    assert len(lines) == 1 and lines[0] == (
        f"mlayer primitives: error: clip 1 ({CMU_01}): another skeleton: joint 2 is "
        f"'LeftUpLeg' where clip 0 ({walk_path}) has 'LeftHip'; join two naming schemes with "
        f"--rename")
    assert "features:" not in err and not out.exists()
    # the map as pairs, as a JSON file, and by name
    mapping = tmp_path / "names.json"
    mapping.write_text(json.dumps(CMU_NAMES))
    pairs = ",".join(f"{a}={b}" for a, b in CMU_NAMES.items())
    for rename in ("cmu", str(mapping), pairs):
        assert main(argv + ["--rename", rename]) == 0, capsys.readouterr().err
        model = mlayer.PrimitiveModel.load(out)
        assert model.skeleton.joint_names == mlayer.read_bvh(walk_path).skeleton.joint_names
        assert model.points.shape[0] == 994 + 600
        out.unlink()
    assert main(argv + ["--rename", "LeftUpLeg"]) == 1
    assert "--rename: 'LeftUpLeg' is not OLD=NEW" in capsys.readouterr().err


def test_generate_keys_checks_the_names(walk, other, tmp_path, capsys):
    model = PrimitiveModel.fit(walk, names=["walk.bvh"], **SMALL)
    model_path = tmp_path / "m.npz"
    model.save(model_path)
    key_clip = tmp_path / "key.bvh"
    mlayer.write_bvh(other, key_clip)
    with pytest.raises(InvalidArgumentError, match="another skeleton than the model: joint 2 is "
                                                   "'LeftUpLeg' where the model has 'LeftHip'"):
        model.generate(30, keys=[(other, 3), (0, 10)], guards=False)
    out = tmp_path / "g.bvh"
    argv = ["generate", str(model_path), "--frames", "30", "--no-guards", "-o", str(out),
            "--keys", f"{key_clip}:3,0:10"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(
        f"mlayer generate: error: --keys: {key_clip} has another skeleton than the model: "
        f"joint 2 is 'LeftUpLeg' where the model has 'LeftHip'") and not out.exists()
    assert main(argv + ["--rename", "cmu"]) == 0
    # renamed, the key clip is the training clip: its key frame gives the same path
    a = mlayer.read_bvh(out)
    assert main(["generate", str(model_path), "--frames", "30", "--no-guards", "-o",
                 str(tmp_path / "h.bvh"), "--keys", "walk.bvh:3,0:10"]) == 0
    b = mlayer.read_bvh(tmp_path / "h.bvh")
    np.testing.assert_allclose(a.rot, b.rot, atol=1e-6)


def test_viewer_manifold_leaves_out_or_joins(walk, other, tmp_path):
    from mlayer.viewer.manifold import ManifoldSession
    from mlayer.viewer.session import ResultCache, load_clips
    paths = [tmp_path / "a.bvh", tmp_path / "b.bvh"]
    mlayer.write_bvh(walk, paths[0])
    mlayer.write_bvh(other, paths[1])
    clips = load_clips(paths)
    s = ManifoldSession(clips, cache=ResultCache(), max_values=10**7)
    assert [c.index for c in s.used] == [0]
    assert s.excluded == [{"clip": 1, "name": clips[1].name,
                           "reason": f"another skeleton: joint 2 is 'LeftUpLeg' where "
                                     f"{clips[0].name} has 'LeftHip'; join two naming schemes "
                                     f"with option rename"}]
    s = ManifoldSession(clips, cache=ResultCache(), max_values=10**7, rename=CMU_NAMES)
    assert [c.index for c in s.used] == [0, 1] and s.excluded == []
