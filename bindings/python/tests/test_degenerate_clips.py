"""Every CLI command over degenerate clips: static (no channel moves), 1 to 3 frames, joints
without channels, a root without channels. Each run gives a result or a one-line error with a
non-zero exit, never a traceback, and a failed run leaves no output behind. (`view` serves a
browser session and `batch` runs a Dask cluster: both are left out; their workers call the
same API as `denoise` / `resample`.)"""
import subprocess
import sys

import numpy as np
import pytest

NAMES = ["Hips", "Spine", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg",
         "RightFoot"]
PARENTS = [-1, 0, 0, 2, 3, 0, 5, 6]
OFFSETS = [(0, 0, 0), (0, 10, 0), (3, 0, 0), (0, -15, 0), (0, -15, 0), (-3, 0, 0), (0, -15, 0),
           (0, -15, 0)]
POS, ROT = ["Xposition", "Yposition", "Zposition"], ["Zrotation", "Xrotation", "Yrotation"]


def bvh_text(channels, frames) -> str:
    """A small legged skeleton with the given channel lists and frame rows."""
    out = ["HIERARCHY"]

    def joint(j, ind):
        out.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {NAMES[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}  OFFSET {' '.join(map(str, OFFSETS[j]))}")
        out.append(f"{ind}  CHANNELS {len(channels[j])} {' '.join(channels[j])}".rstrip())
        kids = [k for k, p in enumerate(PARENTS) if p == j]
        for k in kids:
            joint(k, ind + "  ")
        if not kids:
            out.extend([f"{ind}  End Site", f"{ind}  {{", f"{ind}    OFFSET 0 -3 4", f"{ind}  }}"])
        out.append(f"{ind}}}")

    joint(0, "")
    out += ["MOTION", f"Frames: {len(frames)}", "Frame Time: 0.0333333"]
    out += [" ".join(f"{v:.6f}" for v in row) for row in frames]
    return "\n".join(out) + "\n"


def moving(n, n_ch, lift=True):
    t = np.arange(n)[:, None]
    f = 5 * np.sin(0.2 * t + 0.3 * np.arange(n_ch)[None]) + np.arange(n_ch)[None]
    if lift:
        f[:, 1] += 30  # the root's height
    return f


C = 6 + 7 * 3
CLIPS = {
    "static": bvh_text([POS + ROT] + [ROT] * 7, np.tile(np.r_[0, 30, 0, np.zeros(C - 3)], (40, 1))),
    "one_frame": bvh_text([POS + ROT] + [ROT] * 7, moving(1, C)),
    "two_frames": bvh_text([POS + ROT] + [ROT] * 7, moving(2, C)),
    "three_frames": bvh_text([POS + ROT] + [ROT] * 7, moving(3, C)),
    "joints_without_channels": bvh_text([POS + ROT, ROT, ROT, [], ROT, ROT, [], ROT],
                                        moving(40, 6 + 5 * 3)),
    "root_without_channels": bvh_text([[]] + [ROT] * 7, moving(40, 7 * 3, lift=False)),
}

# (command, arguments with IN for the clip and OUT/ for the output folder, outputs on success)
COMMANDS = [
    ("info", ["IN"], []),
    ("denoise", ["IN", "-o", "OUT/d.bvh"], ["d.bvh"]),
    ("stylize", ["IN", "--alpha", "2", "-o", "OUT/s.bvh"], ["s.bvh"]),
    ("layers", ["IN", "--npz", "OUT/l.npz"], ["l.npz"]),
    ("render", ["IN", "-o", "OUT/r.gif", "--seconds", "0.2", "--size", "64x48"], ["r.gif"]),
    ("stream", ["IN", "-o", "OUT/st.bvh"], ["st.bvh"]),
    ("contacts", ["IN"], []),
    ("resample", ["IN", "--fps", "15", "-o", "OUT/rs.bvh"], ["rs.bvh"]),
    ("timewarp", ["IN", "-o", "OUT/tw.bvh"], ["tw.bvh"]),
    ("primitives", ["IN", "-o", "OUT/p.npz", "--lattice", "3x3", "--som", "3x3", "--epochs", "2"],
     ["p.npz"]),
    ("demo", ["--clip", "IN", "-o", "OUT/demo", "--no-gif"], ["demo"]),
    ("convert", ["IN", "OUT/c.glb"], ["c.glb"]),
]


def run(cmd, args, clip, out):
    argv = [str(clip) if a == "IN" else a.replace("OUT/", f"{out}/") for a in args]
    return subprocess.run([sys.executable, "-m", "mlayer", cmd, *argv], capture_output=True,
                          text=True, timeout=300)


@pytest.fixture(scope="module")
def clip_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("degenerate")
    for name, text in CLIPS.items():
        (d / f"{name}.bvh").write_text(text)
    return d


def _check(r, cmd, out, outputs):
    assert "Traceback" not in r.stderr, r.stderr
    if r.returncode == 0:
        for o in outputs:
            assert (out / o).exists(), (cmd, o, r.stdout)
        return True
    assert r.returncode == 1, (r.returncode, r.stderr)
    # progress lines may come first (primitives); the error is the one line from `mlayer`
    errors = [ln for ln in r.stderr.splitlines() if ln.startswith("mlayer")]
    assert len(errors) == 1 and r.stderr.rstrip().endswith(errors[0]), r.stderr
    assert sorted(p.name for p in out.iterdir()) == [], f"{cmd} failed but left outputs"
    return False


@pytest.mark.parametrize("clip", list(CLIPS))
@pytest.mark.parametrize("cmd,args,outputs", COMMANDS, ids=[c[0] for c in COMMANDS])
def test_command_gives_a_result_or_one_line_error(clip_dir, tmp_path, clip, cmd, args, outputs):
    out = tmp_path / "out"
    out.mkdir()
    r = run(cmd, args, clip_dir / f"{clip}.bvh", out)
    ok = _check(r, cmd, out, outputs)
    if cmd == "primitives" and ok:  # generate from the model
        g = tmp_path / "gen"
        g.mkdir()
        rg = subprocess.run([sys.executable, "-m", "mlayer", "generate", str(out / "p.npz"),
                             "--frames", "10", "-o", str(g / "g.bvh")], capture_output=True,
                            text=True, timeout=300)
        _check(rg, "generate", g, ["g.bvh"])


def test_static_clip_denoises(clip_dir, tmp_path):
    """The case of the issue: a clip whose channels do not move is denoised (it was written,
    then a ZeroDivisionError traceback)."""
    r = run("denoise", ["IN", "-o", "OUT/d.bvh"], clip_dir / "static.bvh", tmp_path)
    assert r.returncode == 0, r.stderr
    assert "the input does not move" in r.stdout
    import mlayer
    m, d = mlayer.read_bvh(clip_dir / "static.bvh"), mlayer.read_bvh(tmp_path / "d.bvh")
    assert np.abs(d.positions() - m.positions()).max() < 1e-6 * mlayer.metrics.body_height(m)
