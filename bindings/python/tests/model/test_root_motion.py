"""mlayer.extract_root_motion on the shared clips: the inverse gives the input back to 1e-9 body
heights, the heading is continuous, the in-place body stays near the origin on the walks, a
Z-up clip, the position mode, the track's CSV; bad input; the `mlayer rootmotion` command."""
from __future__ import annotations

import numpy as np
import pytest

import mlayer
from mlayer._native import ffi, lib
from mlayer.model._rig import c_rig
from mlayer.cli import main
from conftest import SHARED_CLIPS
from test_mirror import native_z_up

#: the clips that travel (walks, a run, the jumps, the dog's walk); the kick and the salsa stay
WALKS = ["ai4a_dog_D1_008_KAN01_002.bvh", "bandai1_walk_happy_001.bvh",
         "cmu_01_01_playground_jumps.bvh", "cmu_02_03_run_jog_25fps.bvh",
         "cmu_131_01_mj_style_walk.bvh", "lafan1_clip_a.bvh"]

_CACHE: dict = {}


def clip(mocap, name: str) -> mlayer.Motion:
    if name not in _CACHE:
        _CACHE[name] = mlayer.read_bvh(mocap / name)
    return _CACHE[name].copy()


def body_joint(m: mlayer.Motion) -> int:
    """The joint that carries the body translation (mlr_rig_body_translation_joint)."""
    rig, keep = c_rig(m.skeleton)
    out = ffi.new("int32_t *")
    root, _, trans = m._frames()
    assert lib.mlr_rig_body_translation_joint(
        rig, m.n_frames, ffi.cast("double *", ffi.from_buffer(root)),
        ffi.cast("double *", ffi.from_buffer(trans)) if trans.size else ffi.NULL, out,
        ffi.NULL) == 0
    del keep
    return int(out[0])


def ground(m: mlayer.Motion) -> list[int]:
    u = "xyz".index(m.up_axis)
    return [k for k in range(3) if k != u]


@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_the_inverse_puts_the_clip_back_together(mocap, name):
    m = clip(mocap, name)
    in_place, track = mlayer.extract_root_motion(m)
    assert isinstance(track, mlayer.RootTrack) and track.n_frames == m.n_frames
    back = mlayer.apply_root_motion(in_place, track)
    h = mlayer.metrics.body_height(m)
    assert np.abs(back.positions() - m.positions()).max() <= 1e-9 * h
    assert np.abs(track.apply(in_place).root_pos - m.root_pos).max() <= 1e-9 * h
    # only the root's channels change
    assert np.array_equal(in_place.rot[:, 1:], m.rot[:, 1:])
    assert np.array_equal(in_place.trans, m.trans)
    # the track lies on the ground plane; the heading is continuous
    assert np.all(track.positions[:, "xyz".index(m.up_axis)] == 0.0)
    assert np.abs(np.diff(track.heading)).max() < np.radians(10.0)


@pytest.mark.parametrize("name", WALKS)
def test_the_in_place_body_stays_near_the_origin_on_a_walk(mocap, name):
    m = clip(mocap, name)
    in_place, track = mlayer.extract_root_motion(m)
    b, g = body_joint(m), ground(m)
    path = np.linalg.norm(np.diff(m.positions()[:, b][:, g], axis=0), axis=1).sum()
    away = np.linalg.norm(in_place.positions()[:, b][:, g], axis=1).max()
    h = mlayer.metrics.body_height(m)
    assert path >= 2.0 * h
    assert away <= 0.02 * path and away <= 0.15 * h, (away / path, away / h)
    # the in-place body faces heading 0 on average: the track took the turns
    _, again = mlayer.extract_root_motion(in_place, smooth=0)
    assert abs(np.degrees(np.mean(again.heading))) < 2.0


def test_the_heading_points_along_a_straight_walk(mocap):
    """The run goes in a straight line: the heading is where it goes (heading 0 faces +Z)."""
    m = clip(mocap, "cmu_02_03_run_jog_25fps.bvh")
    _, track = mlayer.extract_root_motion(m)
    v = np.gradient(track.positions, axis=0)
    speed = np.linalg.norm(v, axis=1)
    facing = np.stack([np.sin(track.heading), np.zeros(m.n_frames), np.cos(track.heading)], 1)
    moving = speed > 0.5 * np.median(speed)
    cos = (v * facing).sum(1)[moving] / speed[moving]
    assert np.median(cos) > 0.98


def test_without_smoothing_the_track_is_the_ground_path(mocap):
    m = clip(mocap, "bandai1_walk_happy_001.bvh")  # the walk rides on Hips, not the root
    _, track = mlayer.extract_root_motion(m, smooth=0)
    b = body_joint(m)
    assert m.joint_names[b] == "Hips"
    p = m.positions()[:, b].copy()
    p[:, 1] = 0.0
    assert np.array_equal(track.positions, p)
    _, smooth = mlayer.extract_root_motion(m, smooth=2.0)
    # smoothing takes the sway out of the track: its steps vary less
    step = lambda t: np.linalg.norm(np.diff(t.positions, axis=0), axis=1)  # noqa: E731
    assert np.std(step(smooth)) < 0.5 * np.std(step(track))


def test_a_z_up_clip_gives_the_turned_track(mocap):
    m = clip(mocap, "cmu_131_01_mj_style_walk.bvh")
    z = native_z_up(m)
    in_y, ty = mlayer.extract_root_motion(m)
    in_z, tz = mlayer.extract_root_motion(z)
    assert tz.up_axis == "z" and ty.up_axis == "y"
    Q = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    h = mlayer.metrics.body_height(m)
    assert np.abs(tz.positions - ty.positions @ Q.T).max() <= 1e-9 * h
    assert np.all(tz.positions[:, 2] == 0.0)
    # heading 0 faces +Z on Y-up and +X on Z-up: Q takes +Z to -Y, a quarter turn back
    d = tz.heading - ty.heading
    assert np.abs(np.angle(np.exp(1j * (d + np.pi / 2)))).max() < 1e-9
    back = tz.apply(in_z)
    assert np.abs(back.positions() - z.positions()).max() <= 1e-9 * h


def test_the_position_mode_keeps_the_rotations(mocap):
    m = clip(mocap, "lafan1_clip_a.bvh")[:600]
    in_place, track = mlayer.extract_root_motion(m, mode="position")
    assert np.all(track.heading == 0.0)
    assert np.array_equal(in_place.rot, m.rot)
    assert np.allclose(in_place.root_pos + track.positions, m.root_pos, rtol=0, atol=1e-9)
    # another body joint: the track follows the Spine
    _, ts = mlayer.extract_root_motion(m, body_joint="Spine", smooth=0)
    p = m.positions()[:, m.joint_names.index("Spine")]
    assert np.allclose(ts.positions[:, [0, 2]], p[:, [0, 2]], rtol=0, atol=1e-9)


def test_the_track_csv_round_trips(tmp_path, mocap):
    m = clip(mocap, "cmu_131_01_mj_style_walk.bvh")
    _, track = mlayer.extract_root_motion(m)
    track.to_csv(tmp_path / "t.csv")
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert lines[0] == "frame,time,x,y,z,heading" and len(lines) == m.n_frames + 1
    again = mlayer.RootTrack.read_csv(tmp_path / "t.csv")
    assert np.array_equal(again.positions, track.positions)
    assert np.array_equal(again.heading, track.heading)
    assert again.fps == pytest.approx(m.fps, rel=1e-5)
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n")
    with pytest.raises(mlayer.InvalidArgumentError, match="not a root track CSV"):
        mlayer.RootTrack.read_csv(tmp_path / "bad.csv")


@pytest.mark.parametrize("kwargs,message", [
    (dict(mode="air"), "mode must be one of ground, position, got 'air'"),
    (dict(smooth=-1), "root motion: option smooth = -1 is not >= 0"),
    (dict(smooth="a"), "smooth must be a number"),
    (dict(body_joint="Nope"), "body_joint: no joint named 'Nope'"),
    (dict(body_joint=99), r"body_joint 99 is not in \[0, 31\)"),
    (dict(up="w"), "up must be"),
])
def test_bad_input_names_the_argument(mocap, kwargs, message):
    m = clip(mocap, "cmu_131_01_mj_style_walk.bvh")[:20]
    with pytest.raises(mlayer.InvalidArgumentError, match=message):
        mlayer.extract_root_motion(m, **kwargs)


def test_bad_tracks(mocap):
    m = clip(mocap, "cmu_131_01_mj_style_walk.bvh")[:20]
    in_place, track = mlayer.extract_root_motion(m)
    with pytest.raises(mlayer.InvalidArgumentError, match="the track has 20 frames, the motion "
                       "10"):
        mlayer.apply_root_motion(in_place[:10], track)
    with pytest.raises(mlayer.InvalidArgumentError, match="track must be a mlayer.RootTrack"):
        mlayer.apply_root_motion(in_place, track.positions)
    with pytest.raises(mlayer.InvalidArgumentError, match="heading has 3 frames, positions 2"):
        mlayer.RootTrack(np.zeros((2, 3)), np.zeros(3), 30)
    with pytest.raises(mlayer.InvalidArgumentError, match="NaN"):
        mlayer.RootTrack(np.full((2, 3), np.nan), np.zeros(2), 30)
    with pytest.raises(mlayer.InvalidArgumentError, match="no frames"):
        mlayer.extract_root_motion(m[:0])


# ---- the command line ----------------------------------------------------------------------

def run(capsys, *argv):
    code = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_command_writes_the_clip_and_the_track(capsys, tmp_path, mocap):
    src = mocap / "cmu_131_01_mj_style_walk.bvh"
    code, text, err = run(capsys, "rootmotion", src, "-o", tmp_path / "ip.bvh", "--track",
                          tmp_path / "t.csv")
    assert code == 0 and err == "" and "frames in place" in text
    m = mlayer.read_bvh(src)
    in_place, track = mlayer.extract_root_motion(m)
    mlayer.write_bvh(in_place, tmp_path / "ref.bvh")
    assert (tmp_path / "ip.bvh").read_bytes() == (tmp_path / "ref.bvh").read_bytes()
    got = mlayer.RootTrack.read_csv(tmp_path / "t.csv")
    assert np.array_equal(got.positions, track.positions)
    # the file's in-place clip on the file's track is the input (to the BVH's precision)
    back = got.apply(mlayer.read_bvh(tmp_path / "ip.bvh"))
    assert np.abs(back.positions() - m.positions()).max() < 1e-3 * mlayer.metrics.body_height(m)
    code, text, _ = run(capsys, "rootmotion", src, "-o", tmp_path / "p.bvh", "--track",
                        tmp_path / "p.csv", "--mode", "position", "--smooth", "0")
    assert code == 0 and "position, smooth 0 s" in text


@pytest.mark.parametrize("argv,message", [
    (["--smooth", "-1"], "root motion: --smooth = -1 is not >= 0"),
    (["--track", "t.txt"], "--track"),
])
def test_bad_input_one_line_status_1_no_output(capsys, tmp_path, mocap, argv, message):
    src = mocap / "cmu_131_01_mj_style_walk.bvh"
    args = ["rootmotion", src, "-o", tmp_path / "o.bvh"]
    if "--track" not in argv:
        args += ["--track", tmp_path / "t.csv"]
    else:
        argv = ["--track", tmp_path / argv[1]]
    code, _, err = run(capsys, *args, *argv)
    assert code == 1
    assert err.count("\n") == 1 and message in err and err.startswith("mlayer rootmotion: ")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_leaves_neither_file(capsys, tmp_path, mocap, monkeypatch):
    from mlayer.cli import rootmotion as cli

    def fail(motion, path):
        raise mlayer.MlayerIOError(f"{path}: disk full")
    monkeypatch.setattr(cli, "write_bvh", fail)
    code, _, err = run(capsys, "rootmotion", mocap / "cmu_131_01_mj_style_walk.bvh", "-o",
                       tmp_path / "o.bvh", "--track", tmp_path / "t.csv")
    assert code == 1 and "disk full" in err
    assert list(tmp_path.iterdir()) == []
