"""`mlayer denoise / stylize / layers / render / demo`: outputs, one-line errors, no partial
files."""
import os

import numpy as np
import pytest

import mlayer
from conftest import requires
from mlayer.cli import main


@pytest.fixture(scope="module")
def short_clip(tmp_path_factory):
    """The first 2 s of the bundled walk, as a file."""
    p = tmp_path_factory.mktemp("clip") / "walk.bvh"
    mlayer.write_bvh(mlayer.data.load_sample()[:240], p)
    return p


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_denoise_writes_the_denoised_clip(capsys, tmp_path, short_clip):
    out = tmp_path / "den.bvh"
    code, text, err = run(capsys, "denoise", short_clip, "-o", out)
    assert code == 0, err
    m = mlayer.read_bvh(out)
    ref = mlayer.denoise(mlayer.read_bvh(short_clip))
    assert m.n_frames == 240 and np.allclose(m.positions(), ref.positions(), atol=1e-5)
    assert "lam_c median" in text and "jitter" in text


def test_stylize_with_joint_patterns(capsys, tmp_path, short_clip):
    out = tmp_path / "sty.bvh"
    code, text, err = run(capsys, "stylize", short_clip, "--alpha", "1.5", "--joint",
                          "Left*=3", "-o", out)
    assert code == 0, err
    src = mlayer.read_bvh(short_clip)
    ref = mlayer.stylize(src, 1.5, {"Left*": 3.0})
    assert np.allclose(mlayer.read_bvh(out).positions(), ref.positions(), atol=1e-5)
    assert "Left*=3" in text


def test_stylize_alpha_keys(capsys, tmp_path, short_clip):
    """--alpha-keys and --joint PATTERN=T:A,... give mlayer.stylize's motion with the curves."""
    out = tmp_path / "keys.bvh"
    code, text, err = run(capsys, "stylize", short_clip, "--alpha-keys", "0:1,1:3,2:1",
                          "--joint", "Left*=0:0.5,2:2", "-o", out)
    assert code == 0, err
    src = mlayer.read_bvh(short_clip)
    ref = mlayer.stylize(src, mlayer.AlphaCurve("0:1,1:3,2:1"),
                         {"Left*": mlayer.AlphaCurve([(0, 0.5), (2, 2)])})
    assert np.allclose(mlayer.read_bvh(out).positions(), ref.positions(), atol=1e-5)
    const = mlayer.stylize(src, 2.0)
    assert not np.allclose(mlayer.read_bvh(out).positions(), const.positions(), atol=1e-3)
    assert "alpha keys 0:1,1:3,2:1 (peak 3)" in text and "Left*=keys 0:0.5,2:2" in text


@pytest.mark.parametrize("argv, words", [
    (["--alpha-keys", "0:1,2.5"], "--alpha-keys '0:1,2.5': alpha keys: key 1 '2.5' is not "
                                  "TIME:ALPHA"),
    (["--alpha-keys", "0:1,0:2"], "times must increase: key 1"),
    (["--alpha-keys", "0:1,1:nan"], "the alpha of key 1"),
    (["--alpha-keys", "0:1", "--alpha", "2"], "--alpha and --alpha-keys: give one of them"),
    (["--joint", "Left*=0:1,x:2"], "--joint 'Left*=0:1,x:2': alpha keys: key 1 'x:2'"),
])
def test_stylize_bad_alpha_keys_one_line(capsys, tmp_path, short_clip, argv, words):
    out = tmp_path / "bad.bvh"
    code, text, err = run(capsys, "stylize", short_clip, *argv, "-o", out)
    assert code != 0 and not out.exists()
    assert words in err and len(err.strip().splitlines()) == 1, err


def test_batch_refuses_joint_keys_in_one_line(capsys, tmp_path, short_clip):
    code, text, err = run(capsys, "batch", "stylize", short_clip, "-o", tmp_path / "out",
                          "--alpha", "2", "--joint", "Left*=0:1,2:3")
    assert code != 0 and "alpha keys over time (PATTERN=T:A,...) are for mlayer stylize" in err
    assert len(err.strip().splitlines()) == 1, err


@requires("plot")
def test_layers_plot_and_npz(capsys, tmp_path, short_clip):
    fig, npz = tmp_path / "layers.png", tmp_path / "layers.npz"
    code, text, err = run(capsys, "layers", short_clip, "--plot", fig, "--npz", npz)
    assert code == 0, err
    assert fig.stat().st_size > 10000 and fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    z = np.load(npz)
    assert z["control"].shape == (240, 32, 3)
    assert "(root translation)" in text and "LeftKnee" in text


@requires("render")
def test_render_gif(capsys, tmp_path, short_clip):
    out = tmp_path / "clip.gif"
    code, text, err = run(capsys, "render", short_clip, short_clip, "-o", out, "--fps", "10",
                          "--size", "120x140")
    assert code == 0, err
    from PIL import Image
    im = Image.open(out)
    assert im.size == (240, 140) and im.n_frames == 20


@requires("plot")
def test_demo_on_the_bundled_clip(capsys, tmp_path):
    d = tmp_path / "demo"
    code, text, err = run(capsys, "demo", "-o", d, "--no-gif")
    assert code == 0, err
    assert sorted(os.listdir(d)) == ["denoised.bvh", "layers.npz", "layers.png",
                                     "stylized_alpha2.bvh"]
    assert mlayer.read_bvh(d / "denoised.bvh").n_frames == 994


@pytest.mark.parametrize("argv,needle", [
    (["stylize", "{clip}", "--alpha", "nan", "-o", "{out}"], "alpha must be finite"),
    (["stylize", "{clip}", "--joint", "Nope*=2", "-o", "{out}"], "matches no joint"),
    (["stylize", "{clip}", "--joint", "Left*", "-o", "{out}"], "PATTERN=ALPHA"),
    (["denoise", "{clip}", "--gamma", "4", "-o", "{out}"], "gamma"),
    (["denoise", "{bad}", "-o", "{out}"], "bad.bvh:"),
    (["denoise", "{missing}", "-o", "{out}"], "missing.bvh"),
    # (without Pillow, render says so before it reads its options)
    pytest.param(["render", "{clip}", "--size", "big", "-o", "{gif}"], "--size",
                 marks=requires("render")),
])
def test_errors_are_one_line_and_leave_no_output(capsys, tmp_path, short_clip, argv, needle):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0\n")
    out = tmp_path / "out.bvh"
    subs = {"{clip}": str(short_clip), "{out}": str(out), "{bad}": str(bad),
            "{missing}": str(tmp_path / "missing.bvh"), "{gif}": str(tmp_path / "out.gif")}
    code, text, err = run(capsys, *[subs.get(a, a) for a in argv])
    assert code == 1
    assert len(err.strip().splitlines()) == 1 and needle in err, err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.bvh"]


def test_option_names_in_messages_are_spelled_as_flags(capsys, tmp_path, short_clip):
    """A library message quoting an option ("option lam_c", C's and Python's name) reaches the
    user with the command's own flag (--lam-c), by one rule for every command."""
    from mlayer.cli._main import cli_spelling
    out = tmp_path / "x.bvh"
    code, _, err = run(capsys, "stylize", short_clip, "--lam-c", "-1", "-o", str(out))
    assert code == 1 and "--lam-c" in err and "lam_c" not in err, err
    assert not out.exists()
    flags = {"--lam-c", "--allow-extreme"}
    assert cli_spelling("layers: option lam_c = -1 is not > 0", flags) == \
        "layers: --lam-c = -1 is not > 0"
    assert cli_spelling("set the flag allow_extreme", flags) == "set --allow-extreme"
    assert cli_spelling("option gamma = 9", flags) == "option gamma = 9"  # not a flag here
