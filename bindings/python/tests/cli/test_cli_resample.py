"""`mlayer resample` and `mlayer timewarp`: outputs parse and have the right frame counts; bad
input gives one line and exit status 1 and leaves no output file."""
import os

import numpy as np
import pytest

import mlayer
from conftest import requires
from mlayer.cli import main

SAMPLE = mlayer.data.sample_path()  # 994 frames at 120 fps (Frame Time .0083333)


def run(capsys, *argv):
    code = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def only(tmp_path):
    """The files in tmp_path (no temporary leftovers)."""
    return sorted(p.name for p in tmp_path.iterdir())


def test_resample_fps(capsys, tmp_path):
    out = tmp_path / "out.bvh"
    code, text, err = run(capsys, "resample", SAMPLE, "--fps", 30, "-o", out)
    assert code == 0 and err == ""
    m = mlayer.read_bvh(out)
    assert len(m) == 249 and m.fps == pytest.approx(30, rel=1e-6)
    assert f"{out}: 249 frames at 30 fps (LGS" in text
    ref = mlayer.resample(mlayer.read_bvh(SAMPLE), fps=30)
    assert mlayer.metrics.mpjpe(m, ref) < 1e-3  # the file's rounding only
    assert only(tmp_path) == ["out.bvh"]


def test_resample_frames_and_slerp(capsys, tmp_path):
    code, _, err = run(capsys, "resample", SAMPLE, "--frames", 40, "-o", tmp_path / "a.bvh")
    assert code == 0 and err == ""
    a = mlayer.read_bvh(tmp_path / "a.bvh")
    assert len(a) == 40
    assert a.frame_time == pytest.approx(993 * 0.0083333 / 39, rel=1e-6)
    code, text, _ = run(capsys, "resample", SAMPLE, "--fps", 60, "--slerp", "-o",
                        tmp_path / "b.bvh")
    assert code == 0 and "SLERP" in text
    assert len(mlayer.read_bvh(tmp_path / "b.bvh")) == 497  # 993 * 60 / 120.0005 = 496.498


def test_style_in_the_same_run(capsys, tmp_path):
    code, text, err = run(capsys, "resample", SAMPLE, "--fps", 30, "--style", 2, "-o",
                          tmp_path / "s.bvh")
    assert code == 0 and err == "" and "style x2" in text
    want = mlayer.resample(mlayer.read_bvh(SAMPLE), fps=30, style=2.0)
    assert mlayer.metrics.mpjpe(mlayer.read_bvh(tmp_path / "s.bvh"), want) < 1e-3
    code, text, err = run(capsys, "timewarp", SAMPLE, "--style", 0.5, "-o", tmp_path / "t.bvh")
    assert code == 0 and "style x0.5" in text
    assert len(mlayer.read_bvh(tmp_path / "t.bvh")) == 994


def test_contacts_kept_by_default_and_no_contacts_skips(capsys, tmp_path):
    m = mlayer.read_bvh(SAMPLE)
    for cmd, extra, fn in (("resample", ["--fps", 30],
                            lambda **k: mlayer.resample(m, fps=30, **k)),
                           ("timewarp", [], lambda **k: mlayer.timewarp(m, **k))):
        for flag, keep in (([], True), (["--no-contacts"], False)):
            out = tmp_path / f"{cmd}{keep}.bvh"
            code, _, err = run(capsys, cmd, SAMPLE, *extra, "--style", 2, *flag, "-o", out)
            assert code == 0 and err == ""
            style = 2.0 if keep else {"alpha": 2.0, "keep_contacts": False}
            got = mlayer.read_bvh(out)
            assert mlayer.metrics.mpjpe(got, fn(style=style, keep_contacts=keep)) < 1e-3
            # the other setting moves some joint by more than 0.4% of body height (the
            # retiming's contact pass acts on a few frames, after the style's guards have pinned
            # the feet: its mean over all joints and frames is 0.008, its largest 0.76)
            other = fn(style=2.0, keep_contacts=not keep)
            assert np.abs(got.positions() - other.positions()).max() > 0.1


@requires("plot")
def test_resample_report_prints_and_plots_the_variance(capsys, tmp_path):
    out, png = tmp_path / "up.bvh", tmp_path / "var.png"
    code, text, err = run(capsys, "resample", SAMPLE, "--fps", 240, "-o", out, "--report", png)
    assert code == 0 and err == ""
    lines = text.splitlines()
    # 993 frames of 1 / 120.0005 s: the last 240 fps frame within them is frame 1985
    assert lines[0].startswith("posterior variance per output frame (1986 frames")
    vals = {ln.split()[0]: float(ln.split()[1]) for ln in lines[1:4]}
    assert 0 < vals["min"] <= vals["median"] <= vals["max"]
    assert "at frame" in lines[1] and "at frame" in lines[3]
    assert lines[4].startswith("  within 5 % of the max: frames ")
    assert len(mlayer.read_bvh(out)) == 1986
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert only(tmp_path) == ["up.bvh", "var.png"]


def test_resample_report_without_a_plot_path_prints_the_summary(capsys, tmp_path):
    out = tmp_path / "up.bvh"
    code, text, err = run(capsys, "resample", SAMPLE, "--frames", 100, "-o", out, "--report")
    assert code == 0 and err == "", err
    assert text.splitlines()[0].startswith("posterior variance per output frame (100 frames")
    assert "median" in text
    assert only(tmp_path) == ["up.bvh"]


@requires("plot")
def test_timewarp_plot(capsys, tmp_path):
    out, png = tmp_path / "tw.bvh", tmp_path / "timemap.png"
    code, text, err = run(capsys, "timewarp", SAMPLE, "--strength", 1.5, "-o", out,
                          "--plot", png)
    assert code == 0 and err == ""
    m = mlayer.read_bvh(out)
    assert len(m) == 994 and m.frame_time == pytest.approx(0.0083333, rel=1e-6)
    assert "strength 1.5" in text and "slowest at input frame" in text
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert only(tmp_path) == ["timemap.png", "tw.bvh"]


def test_timewarp(capsys, tmp_path):
    out = tmp_path / "tw.bvh"
    code, text, err = run(capsys, "timewarp", SAMPLE, "--strength", 1.5, "-o", out)
    assert code == 0 and err == ""
    m = mlayer.read_bvh(out)
    assert len(m) == 994 and m.frame_time == pytest.approx(0.0083333, rel=1e-6)
    assert "strength 1.5" in text and "slowest at input frame" in text
    code, _, _ = run(capsys, "timewarp", SAMPLE, "--frames", 1500, "-o", tmp_path / "long.bvh")
    assert code == 0 and len(mlayer.read_bvh(tmp_path / "long.bvh")) == 1500
    # an explicit map from a text file
    t = np.arange(994) * 2.0
    np.savetxt(tmp_path / "map.txt", t)
    code, text, err = run(capsys, "timewarp", SAMPLE, "--map", tmp_path / "map.txt", "-o",
                          tmp_path / "slow.bvh")
    assert code == 0 and err == "", err
    assert len(mlayer.read_bvh(tmp_path / "slow.bvh")) == 1987


@pytest.mark.parametrize("argv,message", [
    (["resample", SAMPLE, "--fps", "0"], "fps must be finite and > 0"),
    (["resample", SAMPLE, "--fps", "-30"], "fps must be finite and > 0"),
    (["resample", SAMPLE, "--fps", "0.0083333"], "beyond 100x"),
    (["resample", SAMPLE, "--frames", "1"], "an integer >= 2"),
    (["resample", SAMPLE, "--fps", "30", "--slerp", "--report"], "--report needs the LGS"),
    (["resample", "NOFILE.bvh", "--fps", "30"], "NOFILE.bvh"),
    (["timewarp", SAMPLE, "--strength", "20"], "strength must be in [0, 10]"),
    (["timewarp", SAMPLE, "--frames", "200000"], "beyond 100x"),
])
def test_bad_input_one_line_status_1_no_output(capsys, tmp_path, argv, message):
    out = tmp_path / "out.bvh"
    code, text, err = run(capsys, *argv, "-o", out)
    assert code == 1
    assert err.count("\n") == 1 and message in err, err
    assert err.startswith(f"mlayer {argv[0]}: error: ")
    assert "allow_extreme" not in err  # the CLI names its own option
    assert only(tmp_path) == []


def test_extreme_factor_needs_the_flag(capsys, tmp_path):
    code, _, err = run(capsys, "resample", SAMPLE, "--fps", "1", "-o", tmp_path / "x.bvh")
    assert code == 1 and "--allow-extreme" in err
    code, _, _ = run(capsys, "resample", SAMPLE, "--fps", "1", "--allow-extreme", "-o",
                     tmp_path / "x.bvh")
    assert code == 0 and len(mlayer.read_bvh(tmp_path / "x.bvh")) == 9


def test_bad_maps_and_files_leave_nothing(capsys, tmp_path):
    out = tmp_path / "out.bvh"
    t = np.arange(994, dtype=float)
    t[10], t[11] = t[11], t[10]
    np.savetxt(tmp_path / "bad.txt", t)
    code, _, err = run(capsys, "timewarp", SAMPLE, "--map", tmp_path / "bad.txt", "-o", out)
    assert code == 1 and "not strictly increasing" in err and err.count("\n") == 1
    (tmp_path / "words.txt").write_text("a b c\n")
    code, _, err = run(capsys, "timewarp", SAMPLE, "--map", tmp_path / "words.txt", "-o", out)
    assert code == 1 and "not a list of numbers" in err and err.count("\n") == 1
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n  OFFSET 0 0 0\n")
    code, _, err = run(capsys, "resample", bad, "--fps", 30, "-o", out)
    assert code == 1 and f"{bad}:3:" in err and err.count("\n") == 1
    # an output directory that does not exist: neither the figure nor the BVH is written
    code, _, err = run(capsys, "timewarp", SAMPLE, "-o", out, "--plot",
                       tmp_path / "nodir" / "tm.png")
    assert code == 1 and "does not exist" in err and err.count("\n") == 1
    code, _, err = run(capsys, "resample", SAMPLE, "--fps", 30, "-o", tmp_path / "no" / "o.bvh",
                       "--report", tmp_path / "v.png")
    assert code == 1 and "does not exist" in err
    assert sorted(only(tmp_path)) == ["bad.txt", "broken.bvh", "words.txt"]


@requires("plot")
def test_a_failed_write_leaves_no_figure(capsys, tmp_path, monkeypatch):
    """The figure and the BVH appear together or not at all."""
    from mlayer.cli import retiming as cli_resample

    def fail(motion, path):
        raise mlayer.MlayerIOError(f"{path}: disk full")
    monkeypatch.setattr(cli_resample, "write_bvh", fail)
    code, _, err = run(capsys, "timewarp", SAMPLE, "-o", tmp_path / "o.bvh", "--plot",
                       tmp_path / "tm.png")
    assert code == 1 and "disk full" in err
    assert only(tmp_path) == []
    assert not os.path.exists(tmp_path / "tm.png")
