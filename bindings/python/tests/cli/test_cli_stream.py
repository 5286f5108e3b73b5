"""`mlayer stream`: a parseable BVH with the input's frame count, the comparison plot, and
one-line errors with exit status 1 that leave no output behind."""
import numpy as np
import pytest

import mlayer
from conftest import requires
from mlayer.cli import main


def run(capsys, *argv):
    code = main(["stream", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_writes_the_streamed_clip(capsys, tmp_path):
    src = mlayer.data.sample_path()
    dst = tmp_path / "out.bvh"
    code, out, err = run(capsys, src, "--lag", 10, "-o", dst)
    assert code == 0 and err == ""
    assert "994 frames streamed with lag 10" in out and "decay rate 0.481" in out
    m, got = mlayer.read_bvh(src), mlayer.read_bvh(dst)
    assert got.n_frames == m.n_frames and got.skeleton == m.skeleton
    assert got.frame_time == pytest.approx(m.frame_time)
    ref = mlayer.stream_motion(m, lam=1.0, sigma=1.0, lag=10)
    np.testing.assert_allclose(got.root_pos, ref.root_pos, atol=1e-6)
    dots = np.abs(np.einsum("fjc,fjc->fj", got.rot, ref.rot))
    assert dots.min() > 1 - 1e-12
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.bvh"]


@requires("plot")
def test_plot(capsys, tmp_path, mocap):
    src = mocap / "cmu_02_03_run_jog_25fps.bvh"
    png = tmp_path / "cmp.png"
    code, out, err = run(capsys, src, "--lag", 4, "--lam", 2, "--sigma", 0.5, "-o",
                         tmp_path / "o.bvh", "--plot", png, "--joint", "lknee",
                         "--component", "x", "--euro-beta", 0.01)
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "lknee q.x" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cmp.png", "o.bvh"]
    assert mlayer.read_bvh(tmp_path / "o.bvh").n_frames == mlayer.read_bvh(src).n_frames


@pytest.mark.parametrize("extra, msg", [
    (["--lag", "-1"], "lag"),
    (["--lam", "-2"], "lam"),
    (["--sigma", "0"], "sigma"),
    # (the options of the plot: without matplotlib, --plot is the first error)
    pytest.param(["--plot", "p.png", "--joint", "Nope"], "Nope", marks=requires("plot")),
    pytest.param(["--plot", "p.png", "--euro-min-cutoff", "0"], "cutoff", marks=requires("plot")),
])
def test_bad_options_one_line_exit_1(capsys, tmp_path, extra, msg):
    code, out, err = run(capsys, mlayer.data.sample_path(), "-o", tmp_path / "o.bvh", *extra)
    assert code == 1 and out == ""
    assert err.count("\n") == 1 and err.startswith("mlayer stream: error:") and msg in err
    assert list(tmp_path.iterdir()) == []


def test_bad_input_files(capsys, tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n")
    for src in (bad, tmp_path / "missing.bvh"):
        code, out, err = run(capsys, src, "-o", tmp_path / "o.bvh")
        assert code == 1 and out == "" and err.count("\n") == 1
        assert str(src) in err
    assert not (tmp_path / "o.bvh").exists()
