"""Trimming the converter's lead-in (issue 20, item 4): mlayer.lead_in / mlayer.trim,
read_bvh(trim=), --trim on the command line."""
import subprocess
import sys

import numpy as np
import pytest

import mlayer
from mlayer import InvalidArgumentError
from mlayer.manifold.features import pose_features

T_POSE = ["cmu_01_01_playground_jumps.bvh", "cmu_10_01_soccer_kick.bvh",
          "cmu_60_10_salsa_dance.bvh", "cmu_02_03_run_jog_25fps.bvh"]
CLEAN = ["cmu_131_01_mj_style_walk.bvh", "lafan1_clip_a.bvh", "bandai1_walk_happy_001.bvh",
         "ai4a_dog_D1_008_KAN01_002.bvh"]


def _read(mocap, name, **kw):
    path = mocap / name
    if not path.exists():
        pytest.skip(f"{name} not found")
    return mlayer.read_bvh(path, **kw)


def _reference(m):
    """The rule of mlr_trim.h in numpy, on mlayer.pose_features (an independent pose code):
    (n_frames, n_held, distance)."""
    X = pose_features(m).reshape(m.n_frames, -1, 3)
    from mlayer.layers.layers import body_translation_joint
    b = body_translation_joint([m])
    inside = np.zeros(m.n_joints, bool)
    inside[b] = True
    for j in range(b + 1, m.n_joints):
        inside[j] = inside[m.skeleton.parents[j]]
    inside[b] = False
    X = X[:, inside]
    def d(a, c):
        return np.linalg.norm(a - c, axis=-1).mean(-1)
    still = 1e-3 * np.median(np.linalg.norm(X, axis=-1).mean(-1))
    d0 = d(X[0][None], X)
    h = int(np.argmax(d0 > still)) if (d0 > still).any() else m.n_frames
    step = d(X[1:], X[:-1])
    med = max(np.median(step[h:]), still)
    c = h
    for f in range(h, min(m.n_frames - 1, h + 33)):
        if (step[f:f + 3] <= 2 * med).all():
            c = f
            break
    dist = d0[c:].min() / med
    return (c, h, dist) if dist > 5 and c <= m.n_frames // 4 else (0, 0, dist)


def _arms_out(m, frame):
    """The largest |cosine| between a hand's offset from the joint its arm hangs from and the
    body's axis (root to head): 0 with the arms straight out to the sides."""
    P = m.positions()[frame]
    head = next(j for j, n in enumerate(m.joint_names) if n.lower() == "head")
    spine = P[head] - P[0]
    worst = 0.0
    for j, n in enumerate(m.joint_names):
        if n.lower() in ("lefthand", "righthand", "lhand", "rhand"):
            top = m.skeleton.parents[m.skeleton.parents[j]]
            v = P[j] - P[top]
            worst = max(worst, abs(v @ spine) / np.linalg.norm(v) / np.linalg.norm(spine))
    return worst


@pytest.mark.parametrize("name", T_POSE)
def test_the_cmu_t_pose_and_blend_are_trimmed(mocap, name):
    m = _read(mocap, name)
    lead = mlayer.lead_in(m)
    assert 1 <= lead.n_frames <= 10 and lead.n_held == 1
    ref = _reference(m)
    assert (lead.n_frames, lead.n_held) == ref[:2]
    assert lead.distance == pytest.approx(ref[2], rel=1e-9)
    # frame 0 is a T-pose: the arms straight out; the trimmed clip starts with them down
    assert _arms_out(m, 0) < 0.3  # measured 0.026 .. 0.26; the captured frames 0.68 .. 0.98
    t = mlayer.read_bvh(mocap / name, trim="auto")
    assert t.n_frames == m.n_frames - lead.n_frames
    assert _arms_out(t, 0) > 0.5
    np.testing.assert_array_equal(t.rot, m.rot[lead.n_frames:])
    np.testing.assert_array_equal(t.root_pos, m.root_pos[lead.n_frames:])
    # the trimmed start is close to the clip's motion: its next frames are ordinary steps
    # away (within 2 median steps, the rule's join), and nothing more is trimmed
    X = pose_features(t).reshape(t.n_frames, -1, 3)
    step = np.linalg.norm(X[1:] - X[:-1], axis=-1).mean(-1)
    assert (step[:3] <= 2 * np.median(step)).all()
    assert mlayer.lead_in(t).n_frames == 0
    assert mlayer.trim(m).n_frames == t.n_frames


@pytest.mark.parametrize("name", CLEAN)
def test_clean_clips_trim_nothing(mocap, name):
    m = _read(mocap, name)
    lead = mlayer.lead_in(m)
    assert lead == (0, 0, pytest.approx(_reference(m)[2], rel=1e-9))
    assert lead.distance < 2
    assert mlayer.read_bvh(mocap / name, trim="auto").n_frames == m.n_frames
    assert mlayer.trim(m, "auto") is m


def test_a_frame_count_and_the_string_reader(mocap):
    m = _read(mocap, "bandai1_walk_happy_001.bvh")
    text = mlayer.write_bvh_string(m[:40])
    s = mlayer.read_bvh_string(text, trim=7)
    assert s.n_frames == 33
    np.testing.assert_allclose(s.rot, mlayer.read_bvh_string(text).rot[7:])
    assert mlayer.read_bvh_string(text, trim=0).n_frames == 40
    assert mlayer.trim(m, 5).n_frames == m.n_frames - 5
    assert mlayer.trim(m, None) is m
    # the up axis stays the clip's
    z = mlayer.read_bvh_string(text, up="z", trim=3)
    assert z.up_axis == "z" and z.n_frames == 37
    # a T-pose put in front of a clean clip is found again
    tp = m[:1].copy()
    tp.rot = np.tile(np.array([1.0, 0, 0, 0]), (1, m.n_joints, 1))
    both = mlayer.Motion(m.skeleton, m.frame_time, np.vstack([m.root_pos[:1], m.root_pos]),
                         np.vstack([tp.rot, m.rot]), np.vstack([m.trans[:1], m.trans]))
    assert mlayer.lead_in(both).n_frames == 1


def test_bad_arguments(mocap):
    m = _read(mocap, "bandai1_walk_happy_001.bvh")
    for bad in ("x", -1, True, 1.5, "3"):
        with pytest.raises(InvalidArgumentError, match="trim"):
            mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh", trim=bad)
        with pytest.raises(InvalidArgumentError, match="trim"):
            mlayer.trim(m, bad)
    with pytest.raises(InvalidArgumentError, match="trim"):
        mlayer.read_bvh_string(mlayer.write_bvh_string(m[:5]), trim="all")
    with pytest.raises(InvalidArgumentError, match="leave nothing"):
        mlayer.trim(m, m.n_frames)
    with pytest.raises(InvalidArgumentError, match="lead_in: expected a mlayer.Motion"):
        mlayer.lead_in("walk.bvh")
    with pytest.raises(InvalidArgumentError, match="up must be"):
        mlayer.lead_in(m, up="w")
    bad = m.copy()
    bad.rot[3, 2, 0] = np.nan
    with pytest.raises(InvalidArgumentError, match="frame 3 has non-finite"):
        mlayer.lead_in(bad, up="y")
    # short clips: nothing to go by
    assert mlayer.lead_in(m[:5]).n_frames == 0


def _mlayer(*args):
    return subprocess.run([sys.executable, "-m", "mlayer", *map(str, args)], capture_output=True,
                          text=True, timeout=300)


def test_cli_trim_on_every_command_that_reads_clips(mocap, tmp_path):
    from mlayer import cli
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    reads_clips = {c.name: c.reads_clips for c in cli.COMMANDS}
    assert not reads_clips["version"] and not reads_clips["generate"]
    for name, sp in sub.choices.items():
        has = any("--trim" in a.option_strings for a in sp._actions)
        assert has == reads_clips[name], name
    clip = mocap / "cmu_10_01_soccer_kick.bvh"
    if not clip.exists():
        pytest.skip("cmu_10_01 not found")
    out = tmp_path / "r.bvh"
    r = _mlayer("resample", clip, "--fps", "60", "--trim", "auto", "-o", out)
    assert r.returncode == 0, r.stderr
    assert f"mlayer resample: {clip}: trimmed 8 frames at the start" in r.stderr
    full = mlayer.read_bvh(clip)
    got = mlayer.read_bvh(out)
    assert got.n_frames == mlayer.resample(full[8:], fps=60).n_frames
    r = _mlayer("info", clip, "--trim", "2")
    assert r.returncode == 0 and "trimmed 2 frames" in r.stderr
    r = _mlayer("info", clip, "--trim", "some")
    assert r.returncode == 2 and "expected 'auto' or a frame count" in r.stderr
    r = _mlayer("info", clip, "--trim", str(full.n_frames))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "leave nothing" in r.stderr
