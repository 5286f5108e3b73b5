"""BVH reading and writing: every real clip round-trips, local rotations match an independent
Euler conversion (scipy), world positions match an independent third-party reader (bvhio from
PyPI), and bad input raises ParseError with the path and the line."""
import os
import re

import numpy as np
import pytest

import mlayer
from conftest import mocap_dir, reference

CLIPS = sorted(p.name for p in mocap_dir().glob("*.bvh")) if mocap_dir().is_dir() else []
clip_params = pytest.mark.parametrize("clip", CLIPS or [pytest.param(
    "none", marks=pytest.mark.skip(reason="shared mocap clips not found"))])


def test_all_shared_clips_are_found(mocap):
    assert len(CLIPS) >= 8, CLIPS


def clip_size(m):
    """Size of a clip: the largest extent of its world joint positions over all frames."""
    p = m.positions().reshape(-1, 3)
    return float((p.max(axis=0) - p.min(axis=0)).max())


def rotation_angle(q1, q2):
    """Angle (rad) of the rotation between unit quaternions (sign-insensitive), accurate near 0:
    4 asin(|q1 - s q2| / 2) with s the sign of their dot product."""
    s = np.where(np.einsum("...i,...i->...", q1, q2) < 0, -1.0, 1.0)[..., None]
    d = np.linalg.norm(q1 - s * q2, axis=-1)
    return 4.0 * np.arcsin(np.clip(d / 2, 0.0, 1.0))


@pytest.fixture(scope="module")
def motions(mocap):
    return {c: mlayer.read_bvh(mocap / c) for c in CLIPS}


# ---- round trip ----------------------------------------------------------------------------


@clip_params
def test_round_trip_reproduces_every_clip(clip, motions, tmp_path):
    m = motions[clip]
    out = tmp_path / ("copy_" + clip)
    mlayer.write_bvh(m, out)
    m2 = mlayer.read_bvh(out)
    assert m2.skeleton == m.skeleton
    assert m2.frame_time == m.frame_time and m2.n_frames == m.n_frames
    assert m2.euler_orders == m.euler_orders
    assert rotation_angle(m.rot, m2.rot).max() <= 1e-6
    size = clip_size(m)
    assert np.abs(m2.root_pos - m.root_pos).max() <= 1e-6 * size
    assert np.abs(m2.trans - m.trans).max(initial=0.0) <= 1e-6 * size
    assert np.abs(m2.positions() - m.positions()).max() <= 1e-6 * size
    # a second round trip changes nothing that matters
    m3 = mlayer.read_bvh_string(mlayer.write_bvh_string(m2))
    assert rotation_angle(m2.rot, m3.rot).max() <= 1e-7
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no temporary file left


@clip_params
def test_local_rotations_match_scipy_euler(clip, motions, mocap):
    """Independent of the C reader: numpy reads the MOTION block, scipy converts each joint's
    angles with the order its CHANNELS line names."""
    R = reference("scipy.spatial.transform", "scipy").Rotation
    text = (mocap / clip).read_text()
    head, motion = re.split(r"Frame Time:[^\n]*\n", text, maxsplit=1)
    values = np.array(motion.split(), dtype=np.float64)
    m = motions[clip]
    values = values.reshape(m.n_frames, -1)
    chan_lines = re.findall(r"CHANNELS\s+\d+([^\n]*)", head)
    assert len(chan_lines) == m.n_joints
    col = 0
    for j, line in enumerate(chan_lines):
        names = line.split()
        rot_axes = "".join(n[0].upper() for n in names if n.lower().endswith("rotation"))
        rot_cols = [col + k for k, n in enumerate(names) if n.lower().endswith("rotation")]
        pos_cols = {n[0].upper(): col + k for k, n in enumerate(names)
                    if n.lower().endswith("position")}
        if len(rot_axes) == 3:
            ref = R.from_euler(rot_axes, values[:, rot_cols], degrees=True)
            q = ref.as_quat(scalar_first=True)
            assert rotation_angle(q, m.rot[:, j]).max() < 1e-9, m.joint_names[j]
        if pos_cols:  # position channels replace the OFFSET
            t = m.root_pos if j == 0 else m.trans[:, list(m.trans_joints).index(j)]
            for a, c in pos_cols.items():
                np.testing.assert_array_equal(t[:, "XYZ".index(a)], values[:, c])
        col += len(names)
    assert col == values.shape[1] == m.skeleton.n_channels


def _bvhio_positions(path, frames):
    bvhio = reference("bvhio", "bvhio")
    root = bvhio.readAsHierarchy(str(path))
    joints = [j for j, _, _ in root.layout()]
    out = np.empty((len(frames), len(joints), 3))
    for i, f in enumerate(frames):
        root.loadPose(int(f))
        for k, j in enumerate(joints):
            p = j.PositionWorld
            out[i, k] = (p.x, p.y, p.z)
    return [j.Name for j in joints], out


@clip_params
def test_fk_agrees_with_bvhio(clip, motions, mocap):
    """bvhio (PyPI) computes world positions its own way (float32 glm transforms); they agree
    with mlayer's C forward kinematics to 1e-5 of the clip's size on 25 frames spread over the
    clip, first and last included."""
    m = motions[clip]
    frames = np.unique(np.linspace(0, m.n_frames - 1, 25).round().astype(int))
    names, ref = _bvhio_positions(mocap / clip, frames)
    assert names == m.joint_names
    p = m.positions()[frames]
    size = clip_size(m)
    err = np.abs(p - ref).max()
    assert err <= 1e-5 * size, f"{clip}: max |mlayer - bvhio| = {err:.3g}, size {size:.4g}"


def test_bandai_position_channels_replace_offsets(mocap):
    m = mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")
    assert all(len(c.split()) == 6 for c in m.channels)
    assert list(m.trans_joints) == list(range(1, m.n_joints))
    # Hips (joint 1) carries the body translation under joint_Root; on the other joints the
    # position values equal the OFFSETs in these files, so bones keep their length
    assert m.joint_names[:2] == ["joint_Root", "Hips"]
    assert np.ptp(m.trans[:, 0, 2]) > 100  # walks forward
    np.testing.assert_allclose(m.trans[:, 1:],
                               np.broadcast_to(m.offsets[2:], m.trans[:, 1:].shape),
                               atol=1e-4)
    p = m.positions()
    for j in range(2, m.n_joints):
        bone = np.linalg.norm(p[:, j] - p[:, m.parents[j]], axis=-1)
        np.testing.assert_allclose(bone, np.linalg.norm(m.offsets[j]), rtol=1e-4, atol=1e-4)


def test_mixed_euler_orders_are_kept(mocap):
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    assert m.euler_orders.count("ZYX") == 19 and m.euler_orders.count("ZXY") == 12
    m2 = mlayer.read_bvh_string(mlayer.write_bvh_string(m))
    assert m2.channels == m.channels


# ---- strings, paths, writing ---------------------------------------------------------------

SMALL = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
1 2 3 0 0 0 0 0 0
1 2 3 90 0 0 0 45 0
"""


def test_read_string_and_bytes():
    m = mlayer.read_bvh_string(SMALL)
    assert m.n_frames == 2 and m.fps == pytest.approx(25.0) and m.joint_names == ["Hips", "Spine"]
    np.testing.assert_array_equal(m.root_pos, [[1, 2, 3], [1, 2, 3]])
    p = m.positions()
    np.testing.assert_allclose(p[0], [[1, 2, 3], [1, 12, 3]])
    np.testing.assert_allclose(p[1], [[1, 2, 3], [-9, 2, 3]], atol=1e-12)  # 90 deg about Z
    m2 = mlayer.read_bvh_string(SMALL.replace("\n", "\r\n").encode())
    np.testing.assert_array_equal(m2.rot, m.rot)
    # End Site: Spine at (-9, 2, 3) turned by Rz(90) Rx(45) applied to (0, 5, 0)
    h = 5 * np.sqrt(0.5)
    np.testing.assert_allclose(m.end_site_positions()[1], [[-9 - h, 2, 3 + h]], atol=1e-12)


def test_read_accepts_pathlike_and_bytes_paths(tmp_path):
    f = tmp_path / "small.bvh"
    f.write_text(SMALL)
    for arg in (f, str(f), os.fsencode(str(f))):
        assert mlayer.read_bvh(arg).n_frames == 2


@clip_params
def test_threads_give_the_same_motion(clip, motions, mocap):
    m = motions[clip]
    data = (mocap / clip).read_bytes()
    for threads in (1, 2, 3, 16):
        for b in (mlayer.read_bvh(mocap / clip, threads=threads),
                  mlayer.read_bvh_string(data, threads=threads)):
            assert b.skeleton == m.skeleton
            assert np.array_equal(b.rot, m.rot) and np.array_equal(b.root_pos, m.root_pos)
            assert np.array_equal(b.trans, m.trans)


def test_threads_argument_is_checked():
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(mlayer.InvalidArgumentError):
            mlayer.read_bvh_string(SMALL, threads=bad)


def _long_text(n_frames):
    head, motion = SMALL.split("MOTION")
    lines = [f"{i % 7} {i % 5}.25 -{i % 3}.5 {i % 90} 0 0 1e-3 {i % 45} 0"
             for i in range(n_frames)]
    return (head + f"MOTION\nFrames: {n_frames}\nFrame Time: 0.04\n" + "\n".join(lines) + "\n")


def test_errors_are_the_same_on_threads(tmp_path):
    text = _long_text(20000).splitlines()
    first = next(i for i, t in enumerate(text) if t.startswith("Frame Time"))
    text[first + 15000] = "1.2.3" + text[first + 15000][1:]  # frame 15000
    text = "\n".join(text) + "\n"
    f = tmp_path / "bad.bvh"
    f.write_text(text)
    errors = []
    for threads in (1, 2, 4, None):
        for call in (lambda threads=threads: mlayer.read_bvh(f, threads=threads),
                     lambda threads=threads: mlayer.read_bvh_string(text, name=str(f),
                                                                    threads=threads)):
            with pytest.raises(mlayer.ParseError) as e:
                call()
            errors.append((e.value.path, e.value.line, e.value.column, e.value.reason))
    assert errors[0][1] == first + 15001 and "invalid number '1.2.3'" in errors[0][3]
    assert all(e == errors[0] for e in errors)
    # the file is not held open: it can be replaced
    mlayer.write_bvh(mlayer.read_bvh_string(SMALL), f)
    assert mlayer.read_bvh(f).n_frames == 2


def test_files_read_as_their_text(tmp_path):
    text = _long_text(3000)
    small, big = tmp_path / "small.bvh", tmp_path / "big.bvh"
    small.write_text(SMALL)
    big.write_text(text)
    assert np.array_equal(mlayer.read_bvh(small).rot, mlayer.read_bvh_string(SMALL).rot)
    m = mlayer.read_bvh(big)
    assert m.n_frames == 3000
    assert np.array_equal(m.rot, mlayer.read_bvh_string(text).rot)
    np.testing.assert_array_equal(m.root_pos[123], [123 % 7, 123 % 5 + 0.25, -(123 % 3) - 0.5])


def test_missing_file_is_an_oserror(tmp_path):
    with pytest.raises(FileNotFoundError):
        mlayer.read_bvh(tmp_path / "nope.bvh")
    with pytest.raises(IsADirectoryError):
        mlayer.read_bvh(tmp_path)
    with pytest.raises(ValueError, match="null byte"):
        mlayer.read_bvh(str(tmp_path / "a\0b.bvh"))


def test_large_file_reads_alike_on_every_thread_count(mocap):
    # over 1 MiB: read by the parsing threads in shares, then parsed; same bits for every count
    src = mocap / "cmu_01_01_playground_jumps.bvh"
    ref = mlayer.read_bvh(src, threads=1)
    for threads in (None, 2, 3):
        m = mlayer.read_bvh(src, threads=threads)
        assert np.array_equal(m.rot, ref.rot) and np.array_equal(m.root_pos, ref.root_pos)


def test_write_failure_is_an_oserror_and_keeps_the_old_file(tmp_path):
    m = mlayer.read_bvh_string(SMALL)
    with pytest.raises(OSError):
        mlayer.write_bvh(m, tmp_path / "no_such_dir" / "x.bvh")
    target = tmp_path / "x.bvh"
    target.write_text("old")
    bad = m.copy()
    bad.rot[1, 1, 0] = np.nan
    with pytest.raises((ValueError, OSError)):
        mlayer.write_bvh(bad, target)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.bvh"]
    mlayer.write_bvh(m, target)
    assert mlayer.read_bvh(target).n_frames == 2


def test_write_rejects_non_motions(tmp_path):
    with pytest.raises(TypeError):
        mlayer.write_bvh("not a motion", tmp_path / "x.bvh")
    with pytest.raises(TypeError):
        mlayer.write_bvh_string(None)


def test_write_string_has_lf_and_the_hierarchy():
    m = mlayer.read_bvh_string(SMALL)
    s = mlayer.write_bvh_string(m)
    assert "\r" not in s and s.startswith("HIERARCHY\nROOT Hips\n")
    assert "CHANNELS 3 Zrotation Xrotation Yrotation" in s and "End Site" in s
    assert "Frames: 2" in s


def test_write_string_longer_than_its_first_buffer(tmp_path):
    # positions that need 17 digits and an exponent (24 bytes) on every joint make the text
    # longer than the 16 bytes a value the first pass makes room for: the second pass must give
    # the whole text, as the file has it
    rng = np.random.default_rng(5)
    n = 1000
    q = rng.standard_normal((n, 2, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    pos = "Xposition Yposition Zposition Zrotation Xrotation Yrotation"
    m = mlayer.Motion.from_arrays(
        ["root", "child"], [-1, 0], np.array([[0.0, 0, 0], [0, 1, 0]]),
        rng.standard_normal((n, 3)) * 1e-200, q, fps=30.0, channels=[pos, pos],
        trans=rng.standard_normal((n, 1, 3)) * 1e-200)
    s = mlayer.write_bvh_string(m)
    assert len(s) > 16 * 12 * n + 4096 + 160 * 4  # more than the first buffer holds
    mlayer.write_bvh(m, tmp_path / "long.bvh")
    assert s == (tmp_path / "long.bvh").read_text()
    back = mlayer.read_bvh_string(s)
    np.testing.assert_array_equal(back.root_pos, m.root_pos)
    np.testing.assert_array_equal(back.trans, m.trans)


# ---- bad input -----------------------------------------------------------------------------

def _lines(text):
    return text.split("\n")


def _replace_line(text, n, new):
    lines = _lines(text)
    lines[n - 1] = new
    return "\n".join(lines)


BAD = [
    # (id, text, expected line, words expected in the reason). SMALL: line 17 "Frames: 2",
    # 18 "Frame Time:", 19 and 20 the frames.
    ("truncated-mid-frame", SMALL[: SMALL.index("1 2 3 90") + 17], 20, "has 8 values"),
    ("truncated-after-frame", SMALL[: SMALL.index("1 2 3 90")], 17, "at most 1 frames"),
    ("truncated-hierarchy", SMALL[: SMALL.index("End Site")], 10, "end of file"),
    ("truncated-header", SMALL[: SMALL.index("Frame Time")], 18, "end of file"),
    ("garbage-number", _replace_line(SMALL, 19, "1 2 3 0 0 0 0 4x5 0"), 19, "invalid number"),
    ("nan", _replace_line(SMALL, 19, "1 2 3 nan 0 0 0 45 0"), 19, "invalid number"),
    ("inf", _replace_line(SMALL, 20, "1 2 inf 0 0 0 0 0 0"), 20, "invalid number"),
    ("huge", _replace_line(SMALL, 20, "1 2 1e999 0 0 0 0 0 0"), 20, "invalid number"),
    ("too-few-values", _replace_line(SMALL, 19, "1 2 3 0 0 0 0 0"), 19, "has 8 values"),
    ("too-many-values", _replace_line(SMALL, 19, "1 2 3 0 0 0 0 0 0 7"), 19, "more than"),
    ("too-few-frames", SMALL.replace("Frames: 2", "Frames: 3"), 17, "Frames"),
    ("too-many-frames", SMALL.replace("Frames: 2", "Frames: 1"), 20, "data after"),
    ("channel-count", SMALL.replace("CHANNELS 3 Z", "CHANNELS 4 Z"), 10, "lists only 3"),
    ("channel-count-7", SMALL.replace("CHANNELS 3 Z", "CHANNELS 7 Z"), 9, "0 to 6"),
    ("unknown-channel",
     SMALL.replace("Xrotation Yrotation\n    End", "Xrotation Wrotation\n    End"),
     9, "unknown channel"),
    ("missing-open-brace", _replace_line(SMALL, 7, ""), 8, "expected '{'"),
    ("missing-close-brace", _replace_line(SMALL, 14, ""), 16, "missing '}'"),
    ("missing-end-site-brace", _replace_line(SMALL, 13, ""), 16, "missing '}'"),
    ("absurd-frames", SMALL.replace("Frames: 2", "Frames: 99999999999999"), 17,
     "at most 2 frames"),
    ("overflowing-frames", SMALL.replace("Frames: 2", "Frames: 999999999999999999999999999"), 17,
     "out of range"),
    ("negative-frames", SMALL.replace("Frames: 2", "Frames: -2"), 17, "whole number"),
    ("zero-frame-time", SMALL.replace("0.04", "0"), 18, "positive"),
    ("nan-frame-time", SMALL.replace("0.04", "nan"), 18, "Frame Time"),
    ("offset-garbage", SMALL.replace("OFFSET 0 10 0", "OFFSET 0 1O 0"), 8, "OFFSET"),
    ("no-hierarchy", SMALL.replace("HIERARCHY", "HIERARCH"), 1, "HIERARCHY"),
    ("empty", "", 1, "empty"),
    ("binary-junk-in-frames", _replace_line(SMALL, 19, "1 2 3 0 0 \x00\x01\x02 0 0 0"), 19,
     "invalid number"),
    ("binary-junk-in-hierarchy", SMALL.replace("JOINT Spine", "JOINT Sp\x01ine"), 6, "control"),
]


@pytest.mark.parametrize("name,text,line,words", BAD, ids=[b[0] for b in BAD])
def test_bad_input_raises_parse_error_with_path_and_line(name, text, line, words, tmp_path):
    f = tmp_path / f"{name}.bvh"
    f.write_bytes(text.encode("latin-1"))
    with pytest.raises(mlayer.ParseError) as ei:
        mlayer.read_bvh(f, strict=True)
    e = ei.value
    assert isinstance(e, mlayer.Error) and isinstance(e, ValueError)
    assert e.path == str(f)
    assert e.line == line, str(e)
    assert str(e).startswith(f"{f}:{line}: "), str(e)
    assert words.lower() in str(e).lower(), str(e)
    assert "\n" not in str(e)


# Lenient reading (the default). SMALL: line 17 "Frames: 2", 18 "Frame Time:", 19 and 20 the
# frames. (id, text, frames read, [(warning kind, line)], or None for a ParseError)
FRAME2 = "1 2 3 90 0 0 0 45 0"
LENIENT = [
    ("extra-line", SMALL.replace("Frames: 2", "Frames: 1"), 2, [("extra_frames", 20)]),
    ("assimp-like", SMALL + FRAME2 + "\n", 3, [("extra_frames", 21)]),
    ("missing-line", SMALL.replace("Frames: 2", "Frames: 3"), 2, [("missing_frames", 21)]),
    ("missing-three", SMALL.replace("Frames: 2", "Frames: 5"), 2, [("missing_frames", 21)]),
    ("missing-four", SMALL.replace("Frames: 2", "Frames: 6"), None, []),
    ("trailing-junk", SMALL + "END OF FILE\n", 2, [("trailing_data", 21)]),
    ("junk-after-extra", SMALL + FRAME2 + "\n\x1a", 3,
     [("extra_frames", 21), ("trailing_data", 22)]),
    ("no-final-newline", SMALL.rstrip("\n"), 2, [("no_final_newline", 20)]),
    ("truncated-mid-frame", SMALL[: SMALL.index("1 2 3 90") + 17], None, []),
    ("bad-number-before-last", _replace_line(SMALL, 19, "1 2 3 0 0 0 0 4x5 0"), None, []),
]


@pytest.mark.parametrize("name,text,n,kinds", LENIENT, ids=[c[0] for c in LENIENT])
def test_lenient_reading_warns_with_file_and_line(name, text, n, kinds, tmp_path):
    f = tmp_path / f"{name}.bvh"
    f.write_bytes(text.encode("latin-1"))
    if n is None:
        with pytest.raises(mlayer.ParseError) as ei:
            mlayer.read_bvh(f)
        assert str(ei.value).startswith(f"{f}:")
        return
    for read in (lambda: mlayer.read_bvh(f),
                 lambda: mlayer.read_bvh_string(text.encode("latin-1"), name=str(f)),
                 lambda: mlayer.read_bvh(f, threads=2)):
        with pytest.warns(mlayer.ParseWarning) as rec:
            m = read()
        assert m.n_frames == n
        got = [(w.message.kind, w.message.line) for w in rec]
        assert got == kinds
        for w in rec:
            assert str(w.message).startswith(f"{f}:{w.message.line}: ")
            assert isinstance(w.message, mlayer.MlayerWarning) and w.message.path == str(f)
        # frames read agree with the clean file's
        ref = mlayer.read_bvh_string(SMALL)
        k = min(n, 2)
        np.testing.assert_array_equal(m.rot[:k], ref.rot[:k])
    # strict keeps the old errors (a missing final line end is no error there either)
    if kinds[0][0] == "no_final_newline":
        with pytest.warns(mlayer.ParseWarning):
            assert mlayer.read_bvh(f, strict=True).n_frames == 2
    else:
        with pytest.raises(mlayer.ParseError):
            mlayer.read_bvh(f, strict=True)
        with mlayer.io.bvh.strict_reading(), pytest.raises(mlayer.ParseError):
            mlayer.read_bvh(f)


def test_truncated_file_is_an_error_unless_kept(tmp_path):
    cut = SMALL[: SMALL.index("1 2 3 90") + 17]  # inside the last frame line
    with pytest.raises(mlayer.ParseError, match="truncated file: 1 of 2 frames"):
        mlayer.read_bvh_string(cut, name="cut.bvh")
    with pytest.warns(mlayer.ParseWarning, match=r"cut\.bvh:20: truncated file: kept the 1 "):
        m = mlayer.read_bvh_string(cut, name="cut.bvh", keep_truncated=True)
    assert m.n_frames == 1
    with pytest.raises(mlayer.InvalidArgumentError, match="keep_truncated=True needs strict"):
        mlayer.read_bvh_string(cut, strict=True, keep_truncated=True)
    with pytest.raises(mlayer.InvalidArgumentError, match="strict must be True or False"):
        mlayer.read_bvh_string(SMALL, strict="yes")


def test_cli_prints_one_line_per_warning_and_strict_refuses(tmp_path):
    import subprocess
    import sys
    f = tmp_path / "extra.bvh"
    f.write_text(SMALL + FRAME2 + "\nEND\n")
    r = subprocess.run([sys.executable, "-m", "mlayer", "info", str(f)], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 2 and all(ln.startswith("mlayer info: warning: ") for ln in lines)
    assert f"{f}:21: 3 frame lines" in lines[0] and f"{f}:22: data after" in lines[1]
    assert "frames    3" in r.stdout
    r = subprocess.run([sys.executable, "-m", "mlayer", "info", "--strict", str(f)],
                       capture_output=True, text=True)
    assert r.returncode == 1 and "data after the 2 frames" in r.stderr
    assert "Traceback" not in r.stderr and len(r.stderr.splitlines()) == 1


def test_random_binary_junk_never_crashes(rng, tmp_path):
    valid = SMALL.encode()
    for i in range(200):
        kind = i % 3
        if kind == 0:
            data = rng.integers(0, 256, size=int(rng.integers(0, 400)), dtype=np.uint8).tobytes()
        elif kind == 1:  # a valid file with a few bytes flipped
            b = bytearray(valid)
            for k in rng.integers(0, len(b), size=3):
                b[k] = int(rng.integers(0, 256))
            data = bytes(b)
        else:  # a valid file cut anywhere
            data = valid[: int(rng.integers(0, len(valid)))]
        try:
            m = mlayer.read_bvh_string(data, name="junk.bvh")
        except mlayer.ParseError as e:
            assert e.path == "junk.bvh" and (e.line is None or e.line >= 1)
        else:
            assert np.isfinite(m.positions()).all()


def test_truncated_real_clip(mocap, tmp_path):
    data = (mocap / "cmu_131_01_mj_style_walk.bvh").read_bytes()
    f = tmp_path / "cut.bvh"
    f.write_bytes(data[: len(data) // 2])
    with pytest.raises(mlayer.ParseError) as ei:
        mlayer.read_bvh(f)
    assert ei.value.line > 100 and str(ei.value).startswith(f"{f}:")
