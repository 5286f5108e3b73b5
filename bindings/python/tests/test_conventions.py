"""Conventions users expect (issue 22): progress bars through tqdm with a progress= switch and
the `mlayer` logger instead of prints; figures returned as matplotlib Figures without touching
the user's backend; outputs that honour the umask; `render` writing what the extension says;
`-o -` putting the BVH on stdout; `mlayer generate` refusing a file that is not a model in
one line."""
import ast
import io
import logging
import os
import pathlib
import stat
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import mlayer
from conftest import need, requires
from mlayer.cli import main

PACKAGE = pathlib.Path(mlayer.__file__).parent


@pytest.fixture(scope="module")
def small_model(tmp_path_factory):
    """A small primitives model of the bundled walk, saved."""
    m = mlayer.data.load_sample()[:240]
    model = mlayer.PrimitiveModel.fit(m, k=3, som=(6, 6), lattice=(3, 3), epochs=5,
                                      progress=False)
    p = tmp_path_factory.mktemp("model") / "p.npz"
    model.save(p)
    return p


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# ---- progress and logging --------------------------------------------------------------------

def test_library_code_does_not_print():
    """No print() in the package outside the command line (cli/) and the viewer's log
    (viewer/server.py and viewer/manifold.py write to the log stream the server is given)."""
    found = []
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel.startswith("cli/") or rel in ("viewer/server.py", "viewer/manifold.py"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
                found.append(f"{rel}:{node.lineno}")
    assert found == []


@requires("render", "progress")
def test_progress_switch(tmp_path, capsys):
    from mlayer.plotting.render import render_gif
    m = mlayer.data.load_sample()[:60]
    # default: a bar only when stderr is a terminal (it is captured here: none)
    n = render_gif([m], tmp_path / "a.gif", fps=10)
    assert capsys.readouterr() == ("", "")
    # a stream: tqdm's bar on it, ending at n/n
    buf = io.StringIO()
    render_gif([m], tmp_path / "b.gif", fps=10, progress=buf)
    assert f"{n}/{n}" in buf.getvalue() and "frame" in buf.getvalue()
    # True: on stderr
    render_gif([m], tmp_path / "c.gif", fps=10, progress=True)
    out, err = capsys.readouterr()
    assert out == "" and f"{n}/{n}" in err
    # a callable: (done, total) after every frame
    seen = []
    render_gif([m], tmp_path / "d.gif", fps=10, progress=lambda d, t: seen.append((d, t)))
    assert seen == [(k + 1, n) for k in range(n)]
    render_gif([m], tmp_path / "e.gif", fps=10, progress=False)
    assert capsys.readouterr() == ("", "")
    with pytest.raises(mlayer.InvalidArgumentError, match="progress must be"):
        render_gif([m], tmp_path / "f.gif", progress="yes")
    assert not (tmp_path / "f.gif").exists()


@requires("render", "progress")
def test_progress_default_on_a_terminal(tmp_path, monkeypatch):
    from mlayer.plotting.render import render_gif

    class Terminal(io.StringIO):
        def isatty(self):
            return True
    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    n = render_gif([mlayer.data.load_sample()[:30]], tmp_path / "a.gif", fps=10)
    assert f"{n}/{n}" in term.getvalue()


def test_fit_logs_its_steps_and_prints_nothing(caplog, capsys):
    m = mlayer.data.load_sample()[:240]
    with caplog.at_level(logging.INFO, logger="mlayer"):
        mlayer.PrimitiveModel.fit(m, k=3, som=(6, 6), lattice=(3, 3), epochs=5)
    assert capsys.readouterr() == ("", "")
    msgs = [r.getMessage() for r in caplog.records if r.name == "mlayer.manifold.primitives"]
    assert any(s.startswith("features: 1 clip(s), 240 frames") for s in msgs), msgs
    assert any(s.startswith("GRBF: thin_plate, 3x3 centres") for s in msgs), msgs
    assert all(r.levelno == logging.INFO for r in caplog.records if r.name.startswith("mlayer"))
    steps = []
    mlayer.PrimitiveModel.fit(m, k=3, som=(6, 6), lattice=(3, 3), epochs=5,
                              progress=lambda d, t: steps.append((d, t)))
    assert steps == [(k, 5) for k in range(1, 6)]


def test_the_package_logger_has_a_null_handler():
    assert any(isinstance(h, logging.NullHandler) for h in logging.getLogger("mlayer").handlers)


@requires("batch")
def test_batch_progress_callable_and_quiet_default(tmp_path, capsys, walk_1s):
    seen = []
    res = mlayer.batch("features", [str(walk_1s)], tmp_path / "a", n_workers=1,
                       metrics=False, progress=lambda d, t: seen.append((d, t)))
    assert res.exit_code == 0 and seen == [(1, 1)]
    assert capsys.readouterr().err == ""  # no bar, no line: stderr is not a terminal
    res = mlayer.batch("features", [str(walk_1s)], tmp_path / "b", n_workers=1,
                       metrics=False)
    assert res.exit_code == 0 and capsys.readouterr().err == ""


# ---- figures ---------------------------------------------------------------------------------

_FIGURES = textwrap.dedent("""
    import sys
    import matplotlib
    backend = dict.__getitem__(matplotlib.rcParams, "backend")
    import numpy as np
    import mlayer
    from matplotlib.figure import Figure
    from mlayer.plotting.plot import (plot_contacts, plot_elbow, plot_layers,
                                      plot_resample_variance, plot_som, plot_stream, plot_timewarp,
                                      plot_transitions)
    m = mlayer.data.load_sample()[:120]
    figs = [plot_layers(m, mlayer.decompose(m))]
    names, c = mlayer.detect_contacts(m)
    figs.append(plot_contacts(names, c, m.fps))
    out, var = mlayer.resample(m, fps=60, return_var=True)
    figs.append(plot_resample_variance(var, out.fps, np.arange(m.n_frames) * 0.5, title="v"))
    t = mlayer.timewarp_map(m)
    figs.append(plot_timewarp(m, mlayer.timewarp(m, time_map=t), t, title="t"))
    model = mlayer.PrimitiveModel.fit(m, k="auto", ks=range(2, 5), som=(5, 5),
                                      lattice=(3, 3), epochs=3, progress=False)
    figs += [plot_som(model), plot_elbow(model), plot_transitions(model)]
    y = np.cumsum(np.ones((20, 3 + 4 * m.n_joints)), axis=0)
    figs.append(plot_stream(m[:20], y, y, y, y, joint=0, component=0, lag=1, lam=1.0,
                            sigma=1.0, cutoff=2.0, beta=0.0))
    assert all(isinstance(f, Figure) for f in figs), [type(f) for f in figs]
    assert "matplotlib.pyplot" not in sys.modules, "pyplot was imported"
    assert dict.__getitem__(matplotlib.rcParams, "backend") == backend, "backend changed"
    print(len(figs), "OK")
""")


@requires("plot")
def test_figures_are_returned_and_leave_the_backend_alone(tmp_path):
    env = dict(os.environ, MPLBACKEND="svg")
    r = subprocess.run([sys.executable, "-c", _FIGURES], capture_output=True, text=True,
                       cwd=tmp_path, env=env, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "8 OK", r.stderr[-3000:]
    assert os.listdir(tmp_path) == []  # no path, no file


@requires("plot")
def test_plot_layers_writes_only_when_given_a_path(tmp_path):
    from mlayer.plotting.plot import layer_choice, plot_layers
    m = mlayer.data.load_sample()[:120]
    L = mlayer.decompose(m)
    fig = plot_layers(m, L, tmp_path / "l.svg", joint="LeftKnee")
    assert (tmp_path / "l.svg").read_text().lstrip().startswith("<?xml")
    joint, axis = layer_choice(m, L, "LeftKnee")
    assert joint == "LeftKnee" and axis in (0, 1, 2)
    assert "LeftKnee" in fig.axes[2].get_ylabel() and len(fig.axes) == 4
    with pytest.raises(mlayer.InvalidArgumentError, match="no joint"):
        layer_choice(m, L, "Nope")


# ---- outputs honour the umask ----------------------------------------------------------------

@requires("plot", "render", "video")
@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_every_cli_output_honours_the_umask(tmp_path, capsys, walk_1s, small_model, mask):
    runs = [
        (["layers", walk_1s, "--plot", "l.png", "--npz", "l.npz"], ["l.png", "l.npz"]),
        (["layers", walk_1s, "--plot", "l.svg"], ["l.svg"]),
        (["contacts", walk_1s, "--plot", "c.pdf"], ["c.pdf"]),
        (["render", walk_1s, "-o", "r.gif", "--fps", "5"], ["r.gif"]),
        (["render", walk_1s, "-o", "r.mp4", "--fps", "5"], ["r.mp4"]),
        (["render", walk_1s, "-o", "r.png", "--strip-frames", "3"], ["r.png"]),
        (["stream", walk_1s, "-o", "s.bvh", "--plot", "s.png"], ["s.bvh", "s.png"]),
        (["resample", walk_1s, "--fps", "60", "-o", "rs.bvh", "--report", "v.png"],
         ["rs.bvh", "v.png"]),
        (["timewarp", walk_1s, "-o", "t.bvh", "--plot", "t.png"], ["t.bvh", "t.png"]),
        (["generate", small_model, "--frames", "20", "-o", "g.bvh"], ["g.bvh"]),
    ]
    old_cwd, old = os.getcwd(), os.umask(mask)
    try:
        os.chdir(tmp_path)
        for argv, _files in runs:
            code, _, err = run(capsys, *argv)
            assert code == 0, (argv, err)
    finally:
        os.umask(old)
        os.chdir(old_cwd)
    made = sorted(os.listdir(tmp_path))
    assert made == sorted(f for _, fs in runs for f in fs)
    for f in made:
        assert stat.S_IMODE((tmp_path / f).stat().st_mode) == 0o666 & ~mask, (f, oct(mask))


# ---- render by extension ---------------------------------------------------------------------

@requires("render")
def test_render_writes_what_the_extension_says(tmp_path, capsys, walk_1s):
    from PIL import Image
    gif, mp4, png = tmp_path / "a.GIF", tmp_path / "a.mp4", tmp_path / "a.png"
    code, out, err = run(capsys, "render", walk_1s, walk_1s, "-o", gif, "--fps", "10",
                         "--size", "100x120")
    assert code == 0, err
    assert gif.read_bytes()[:6] in (b"GIF87a", b"GIF89a")
    n_gif = Image.open(gif).n_frames
    assert n_gif == 10 and f"({n_gif} frames at 10 fps)" in out

    code, out, err = run(capsys, "render", walk_1s, walk_1s, "--labels", "a,b", "-o",
                         png, "--size", "100x120", "--strip-frames", "4")
    assert code == 0, err
    im = Image.open(png)
    assert im.format == "PNG" and im.size == (4 * 100, 2 * 120), im.size
    # every cell of the strip shows a figure (pixels of the bone colours)
    a = np.asarray(im.convert("RGB")).astype(int)
    for r in range(2):
        for c in range(4):
            cell = a[r * 120:(r + 1) * 120, c * 100:(c + 1) * 100]
            ink = (np.abs(cell - [38, 110, 200]).sum(-1) < 10) | \
                (np.abs(cell - [205, 60, 50]).sum(-1) < 10)
            assert ink.sum() > 20, (r, c)
    assert "(4 frames in the strip)" in out

    need("video")
    import imageio_ffmpeg as ffmpeg
    code, out, err = run(capsys, "render", walk_1s, "-o", mp4, "--fps", "10",
                         "--size", "100x120")
    assert code == 0, err
    head = mp4.read_bytes()[:12]
    assert head[4:8] == b"ftyp", head
    frames, _ = ffmpeg.count_frames_and_secs(str(mp4))
    assert frames == 10
    # the size is padded to whole 16-pixel macro blocks, not resized
    reader = ffmpeg.read_frames(str(mp4))
    meta = next(reader)
    reader.close()
    assert tuple(meta["size"]) == (112, 128), meta["size"]


def test_render_refuses_other_extensions_before_any_work(tmp_path):
    from mlayer.plotting.render import render
    m = mlayer.data.load_sample()[:30]
    for name in ("x.avi", "x.webm", "noext"):
        with pytest.raises(mlayer.InvalidArgumentError, match="ending in .gif, .mp4 or .png"):
            render([m], tmp_path / name)
    assert os.listdir(tmp_path) == []


# ---- -o - ------------------------------------------------------------------------------------

def _stdout_cases(clip, model):
    return {
        "denoise": ["denoise", clip],
        "stylize": ["stylize", clip, "--alpha", "1.5"],
        "resample": ["resample", clip, "--fps", "60"],
        "timewarp": ["timewarp", clip, "--strength", "0.5"],
        "stream": ["stream", clip, "--lag", "5"],
        "generate": ["generate", model, "--frames", "30"],
    }


@pytest.mark.parametrize("name", ["denoise", "stylize", "resample", "timewarp", "stream",
                                  "generate"])
def test_dash_writes_the_bvh_to_stdout(tmp_path, walk_1s, small_model, name):
    """`mlayer CMD ... -o - > x.bvh` gives the file `-o x.bvh` gives; the summary goes to
    stderr."""
    argv = [str(a) for a in _stdout_cases(walk_1s, small_model)[name]]
    cmd = [sys.executable, "-m", "mlayer", *argv]
    with open(tmp_path / "piped.bvh", "wb") as f:
        r = subprocess.run(cmd + ["-o", "-"], stdout=f, stderr=subprocess.PIPE, text=True,
                           cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "(standard output)" in r.stderr, r.stderr
    f = subprocess.run(cmd + ["-o", "file.bvh"], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300)
    assert f.returncode == 0, f.stderr
    assert "file.bvh" in f.stdout  # the summary is on stdout when the BVH is a file
    piped, written = (tmp_path / "piped.bvh").read_bytes(), (tmp_path / "file.bvh").read_bytes()
    assert piped.startswith(b"HIERARCHY") and piped == written
    assert sorted(os.listdir(tmp_path)) == ["file.bvh", "piped.bvh"]  # no file named '-'


def test_dash_is_refused_where_the_output_is_not_one_bvh(tmp_path, capsys, walk_1s):
    for argv in (["layers", walk_1s, "--npz", "-"], ["render", walk_1s, "-o", "-"],
                 ["contacts", walk_1s, "--plot", "-"]):
        code, out, err = run(capsys, *argv)
        assert code == 1 and err.count("\n") == 1, err
    assert os.listdir(tmp_path) == []


# ---- mlayer generate on a file that is not a model -------------------------------------------

def test_generate_on_a_bvh_is_one_clear_line(tmp_path, walk_1s):
    np.save(tmp_path / "a.npy", np.zeros(3))
    (tmp_path / "empty.npz").write_bytes(b"")
    for model, what in ((walk_1s, "a BVH file"), (tmp_path / "a.npy", "a .npy array"),
                        (tmp_path / "empty.npz", "an empty file")):
        r = subprocess.run([sys.executable, "-W", "always", "-m", "mlayer", "generate",
                            str(model), "-o", "g.bvh"], capture_output=True, text=True,
                           cwd=tmp_path, timeout=120)
        assert r.returncode == 1
        assert r.stderr == (f"mlayer generate: error: {model}: not a primitives model "
                            f"({what}); expected the .npz file `mlayer primitives` writes\n"), \
            r.stderr
        assert "pickle" not in r.stderr and not (tmp_path / "g.bvh").exists()
    with pytest.raises(mlayer.MlayerIOError, match="not a primitives model"):
        mlayer.PrimitiveModel.load(walk_1s)
