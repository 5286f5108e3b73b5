"""Stick-figure GIF rendering: frame count, non-blank content, one camera, atomic output."""
import os

import numpy as np
import pytest

import mlayer
import mlayer.data
from conftest import need
from mlayer.plotting.render import body_side, followed_joint, render_gif

need("render")
from PIL import Image as PIL  # noqa: E402


@pytest.fixture(scope="module")
def sample():
    return mlayer.data.load_sample()[:240]  # 2 s at 120 fps


def _frames(path):
    im = PIL.open(path)
    out = []
    for k in range(im.n_frames):
        im.seek(k)
        out.append(np.asarray(im.convert("RGB")))
    return out


def test_gif_has_one_frame_per_tick_and_is_not_blank(tmp_path, sample):
    out = tmp_path / "clip.gif"
    n = render_gif([sample, sample], out, labels=["a", "b"], fps=15, panel_size=(160, 200))
    frames = _frames(out)
    assert n == len(frames) == 30  # 2 s at 15 fps
    assert frames[0].shape == (200, 320, 3)
    for f in (frames[0], frames[-1]):
        # the figure's bones are drawn in the side colours: plenty of non-background pixels
        assert (np.abs(f.astype(int) - [250, 250, 247]).sum(-1) > 60).sum() > 200
    # same motion in both panels under one camera: the panels are identical apart from labels
    left, right = frames[10][20:, :160], frames[10][20:, 160:]
    assert np.mean(np.any(left != right, axis=-1)) < 0.02
    # the figure moves
    assert np.any(frames[0] != frames[-1])


def test_gif_lasts_as_long_as_the_motion(tmp_path, sample):
    """GIF delays are whole centiseconds: a constant 33 ms at 30 fps was stored as 30 ms and
    the GIF played 10% fast (issue 42). The delays now alternate so the total is the clip's."""
    from PIL import Image
    from mlayer.plotting.render import gif_delays
    out = tmp_path / "clip.gif"
    n = render_gif([sample], out, fps=30, panel_size=(80, 100))
    with Image.open(out) as im:
        stored = []
        for k in range(im.n_frames):
            im.seek(k)
            stored.append(im.info["duration"])
    assert n == len(stored) == 60 and sorted(set(stored)) == [30, 40]  # the 2 s sample
    assert sum(stored) == 2000
    assert gif_delays(3, 30) == [30, 40, 30] and sum(gif_delays(300, 24)) == 12500
    assert min(gif_delays(100, 120)) == 20


def test_panels_differ_when_motions_differ(tmp_path, sample):
    moved = sample.with_frames(root_pos=sample.root_pos + [0.0, 3.0, 0.0])  # lifted
    out = tmp_path / "two.gif"
    render_gif([sample, moved], out, fps=5, panel_size=(160, 200))
    f = _frames(out)[3]
    assert np.mean(np.any(f[20:, :160] != f[20:, 160:], axis=-1)) > 0.01


def test_bad_arguments_leave_no_file(tmp_path, sample):
    out = tmp_path / "bad.gif"
    with pytest.raises(mlayer.Error):
        render_gif([], out)
    with pytest.raises(mlayer.Error):
        render_gif([sample], out, labels=["a", "b"])
    with pytest.raises(mlayer.Error):
        render_gif([sample], out, fps=0.0)
    assert os.listdir(tmp_path) == []


def test_failure_while_writing_leaves_nothing(tmp_path, sample):
    def stop(done, total):
        if done == 3:
            raise KeyboardInterrupt
    out = tmp_path / "cut.gif"
    with pytest.raises(KeyboardInterrupt):
        render_gif([sample], out, progress=stop)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name,side", [
    ("LeftUpLeg", "left"), ("RightHand", "right"), ("lThigh", "left"), ("rShldr", "right"),
    ("UpperLeg_L", "left"), ("thigh.R", "right"), ("LowerBack", "center"), ("Hips", "center"),
    ("lowerback", "center"), ("Spine1", "center"), ("LThumb", "left"), ("RHipJoint", "right")])
def test_body_side(name, side):
    assert body_side(name) == side


def test_camera_follows_the_first_joint_that_moves(tmp_path, mocap):
    # Bandai's joint_Root stays at the origin; the body walks away with the Hips below it
    m = mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")
    p = m.positions()
    assert m.joint_names[followed_joint(p)] == "Hips"
    assert followed_joint(np.zeros((5, 3, 3))) == 0  # nothing moves: the root
    out = tmp_path / "bandai.gif"
    render_gif([m], out, fps=2, panel_size=(160, 200))
    last = _frames(out)[-1].astype(int)
    # the walker (7 body heights from its start, 3.6 from the origin by the end) is still in
    # the panel's middle: pixels of the left/right bone colours
    ink = np.zeros(last.shape[:2], bool)
    for rgb in ([38, 110, 200], [205, 60, 50]):
        ink |= np.abs(last - rgb).sum(-1) < 10
    cols = np.flatnonzero(ink.any(axis=0))
    assert ink.sum() > 100 and 40 < cols.mean() < 120


def test_cli_refuses_outputs_that_are_not_gif_files(tmp_path, mocap):
    # x.mp4 was refused here until render wrote MP4 (issue 22): it is now a video, see
    # test_render_writes_what_the_extension_says; x.avi and x.gif.bak take its place
    import subprocess
    import sys
    clip = str(mocap / "cmu_131_01_mj_style_walk.bvh")
    for out in ("x.avi", "-", "noext", "x.gif.bak"):
        r = subprocess.run([sys.executable, "-m", "mlayer", "render", clip, "-o", out],
                           capture_output=True, text=True, cwd=tmp_path)
        assert r.returncode == 1 and "give a path ending in .gif" in r.stderr, r.stderr
        assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
        assert not (tmp_path / out).exists()
