"""Every Python example of examples/python runs on the bundled clip and writes sane outputs.

Each example is run as a user would run it (a fresh interpreter, ``--out`` a temporary folder);
the checks read its outputs back.
"""
from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mlayer
from conftest import requires

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "python"
pytestmark = pytest.mark.skipif(not EXAMPLES.is_dir(), reason="examples/ not in this tree")


def run(name: str, out: Path) -> str:
    """Run examples/python/NAME.py with --out OUT; its stdout."""
    done = subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py"), "--out", str(out)],
                          capture_output=True, text=True, timeout=300, cwd=EXAMPLES)
    assert done.returncode == 0, done.stderr
    assert done.stderr == "", done.stderr
    return done.stdout


def read(path: Path) -> mlayer.Motion:
    """A written BVH, read back strictly, with finite frames."""
    m = mlayer.read_bvh(path, strict=True)
    assert np.isfinite(m.root_pos).all() and np.isfinite(m.rot).all()
    return m


def test_every_example_is_tested() -> None:
    tested = {"denoise_folder", "stylize_body_parts", "retime", "primitives_generate",
              "plot_layers"}
    assert {p.stem for p in EXAMPLES.glob("*.py") if not p.stem.startswith("_")} == tested


def test_denoise_folder(tmp_path: Path) -> None:
    run("denoise_folder", tmp_path)
    takes = sorted((tmp_path / "takes").glob("*.bvh"))
    clean = sorted((tmp_path / "clean").glob("*.bvh"))
    assert [p.name for p in takes] == [p.name for p in clean] and len(clean) == 3
    for t, c in zip(takes, clean):
        assert read(c).n_frames == read(t).n_frames
    rows = list(csv.DictReader(open(tmp_path / "report.csv")))
    assert [r["take"] for r in rows] == [p.name for p in takes]
    for r in rows:
        # the seeded noise is removed: far less jitter and foot sliding than the noisy take
        assert float(r["jitter_after"]) < 0.05 * float(r["jitter_before"])
        assert float(r["sliding_after"]) < 0.5 * float(r["sliding_before"])


def test_stylize_body_parts(tmp_path: Path) -> None:
    run("stylize_body_parts", tmp_path)
    m = mlayer.data.load_sample()
    denoised = mlayer.denoise(m)
    names = list(m.joint_names)

    def change(out: mlayer.Motion, joint: str) -> float:
        """RMS angle (radians) between the output's and the denoised rotations of a joint."""
        j = names.index(joint)
        d = np.abs(np.sum(out.rot[:, j] * denoised.rot[:, j], axis=-1)).clip(0, 1)
        return float(np.sqrt(np.mean((2 * np.arccos(d)) ** 2)))

    arms, legs = read(tmp_path / "arms.bvh"), read(tmp_path / "legs_calm.bvh")
    bold = read(tmp_path / "all_bold.bvh")
    assert arms.n_frames == legs.n_frames == bold.n_frames == m.n_frames
    # each body part moves where its alpha says, the others stay as denoised
    assert change(arms, "LeftElbow") > 10 * change(arms, "Head")
    assert change(legs, "LeftKnee") > 10 * change(legs, "LeftElbow")
    assert change(bold, "LeftElbow") > 0 and change(bold, "LeftKnee") > 0


def test_retime(tmp_path: Path) -> None:
    out = run("retime", tmp_path)
    m = mlayer.data.load_sample()
    m30 = read(tmp_path / "walk_30fps.bvh")
    assert m30.fps == pytest.approx(30.0) and m30.n_frames == (m.n_frames - 1) // 4 + 1
    keys = read(tmp_path / "from_keys.bvh")
    assert keys.n_frames == (m.n_frames - 1) // 10 * 10 + 1
    # the LGS follows the clip between its keys better than SLERP (both printed)
    errs = [float(line.split("MPJPE ")[1].split("%")[0]) for line in out.splitlines()
            if "MPJPE" in line]
    assert len(errs) == 2 and errs[0] < errs[1]
    slow = read(tmp_path / "timewarped.bvh")
    assert slow.fps == pytest.approx(m.fps) and slow.n_frames >= m.n_frames


def test_primitives_generate(tmp_path: Path) -> None:
    run("primitives_generate", tmp_path)
    model = mlayer.PrimitiveModel.load(tmp_path / "model.npz")
    assert model.centers.shape[0] >= 2
    m = mlayer.data.load_sample()
    for name, frames in (("generated.bvh", 240), ("through_points.bvh", 120)):
        g = read(tmp_path / name)
        assert g.n_frames == frames and list(g.joint_names) == list(m.joint_names)
        # new motion, not a frozen pose
        assert np.ptp(g.positions(), axis=0).max() > 0.05 * mlayer.metrics.body_height(m)


@requires("plot")
def test_plot_layers(tmp_path: Path) -> None:
    run("plot_layers", tmp_path)
    png = (tmp_path / "layers.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    with np.load(tmp_path / "layers.npz") as z:
        assert z["control"].shape[0] == mlayer.data.load_sample().n_frames
