"""Optional dependencies said up front (issue 22): every feature that needs matplotlib, Pillow,
imageio-ffmpeg, Dask, cryptography, tqdm, pandas or scipy checks it before any work and fails
with one line naming the extra; from the API a MissingDependencyError (an mlayer.Error and an
ImportError), from the CLI one line on stderr, exit status 1 and nothing written.

The modules are hidden by putting None in sys.modules (``import X`` then raises ImportError):
in this process with monkeypatch for the API, in a fresh interpreter for the CLI.
"""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import mlayer
from mlayer import _optional
from conftest import REPO, need, requires


def hide(monkeypatch, *modules):
    for m in modules:
        monkeypatch.setitem(sys.modules, m, None)


def check_error(e, extra: str, module: str):
    msg = str(e.value)
    assert isinstance(e.value, mlayer.MissingDependencyError)
    assert isinstance(e.value, ImportError) and isinstance(e.value, mlayer.Error)
    assert "\n" not in msg and msg.endswith(f"pip install 'mlayer[{extra}]'"), msg
    assert e.value.extra == extra and e.value.module == module and e.value.name == module


# ---- the API ---------------------------------------------------------------------------------

def test_require_names_the_extra(monkeypatch):
    hide(monkeypatch, "matplotlib")
    with pytest.raises(mlayer.MissingDependencyError) as e:
        _optional.require("matplotlib", feature="a figure")
    assert str(e.value) == "a figure needs matplotlib: pip install 'mlayer[plot]'"
    assert _optional.require("numpy", feature="x") is np
    assert not _optional.available("matplotlib") and _optional.available("numpy")


def test_plot_layers_without_matplotlib(monkeypatch, tmp_path):
    from mlayer.plotting.plot import plot_layers
    m = mlayer.data.load_sample()[:60]
    layers = mlayer.decompose(m)
    hide(monkeypatch, "matplotlib")
    with pytest.raises(ImportError) as e:
        plot_layers(m, layers, tmp_path / "x.png")
    check_error(e, "plot", "matplotlib")
    assert os.listdir(tmp_path) == []
    elbow = mlayer.elbow(np.arange(40.0).reshape(20, 2), [1, 2, 3])
    with pytest.raises(ImportError) as e:
        elbow.plot()
    check_error(e, "plot", "matplotlib")


def test_render_without_pillow(monkeypatch, tmp_path):
    from mlayer.plotting.render import render, render_gif
    m = mlayer.data.load_sample()[:30]
    hide(monkeypatch, "PIL")
    for call in (lambda: render_gif([m], tmp_path / "x.gif"),
                 lambda: render([m], tmp_path / "x.png")):
        with pytest.raises(ImportError) as e:
            call()
        check_error(e, "render", "PIL")
    assert os.listdir(tmp_path) == []


@requires("render")  # (an MP4 needs Pillow too, which is checked first)
def test_render_mp4_without_ffmpeg(monkeypatch, tmp_path):
    from mlayer.plotting.render import render
    m = mlayer.data.load_sample()[:30]
    hide(monkeypatch, "imageio_ffmpeg")
    with pytest.raises(ImportError) as e:
        render([m], tmp_path / "x.mp4")
    check_error(e, "video", "imageio_ffmpeg")
    assert os.listdir(tmp_path) == []


def test_batch_without_dask_writes_nothing(monkeypatch, tmp_path, walk_1s):
    """A Dask scheduler needs the batch extra; the default local pool does not."""
    out = tmp_path / "out"
    hide(monkeypatch, "distributed")
    for scheduler in ("tcp://127.0.0.1:8786", "dask"):
        with pytest.raises(ImportError) as e:
            mlayer.batch("denoise", [str(walk_1s)], out, progress=False, scheduler=scheduler)
        check_error(e, "batch", "distributed")
        assert not out.exists()
    res = mlayer.batch("denoise", [str(walk_1s)], out, progress=False, n_workers=1)
    assert res.ok == 1 and (out / walk_1s.name).is_file()


@requires("batch")  # (distributed: checked before cryptography)
def test_batch_embedded_cluster_without_cryptography(monkeypatch, tmp_path, walk_1s):
    out = tmp_path / "out"
    hide(monkeypatch, "cryptography")
    with pytest.raises(ImportError) as e:
        mlayer.batch("denoise", [str(walk_1s)], out, progress=False, scheduler="dask")
    check_error(e, "batch", "cryptography")
    assert "TLS" in str(e.value) and not out.exists()


def test_progress_true_without_tqdm(monkeypatch):
    m = mlayer.data.load_sample()[:60]
    hide(monkeypatch, "tqdm")
    with pytest.raises(ImportError) as e:
        mlayer.PrimitiveModel.fit(m, k=2, som=(3, 3), lattice=(2, 2), epochs=1, progress=True)
    check_error(e, "progress", "tqdm")
    # a callable does not need tqdm
    steps = []
    mlayer.PrimitiveModel.fit(m, k=2, som=(3, 3), lattice=(2, 2), epochs=2,
                              progress=lambda d, t: steps.append((d, t)))
    assert steps == [(k, 5) for k in range(1, 6)]  # the fit's five steps


@requires("render")
def test_render_progress_true_without_tqdm(monkeypatch, tmp_path):
    from mlayer.plotting.render import render_gif
    m = mlayer.data.load_sample()[:30]
    hide(monkeypatch, "tqdm")
    with pytest.raises(ImportError) as e:
        render_gif([m], tmp_path / "x.gif", progress=True)
    check_error(e, "progress", "tqdm")
    assert os.listdir(tmp_path) == []
    # the default (a bar only on a terminal) does not need tqdm
    assert render_gif([m], tmp_path / "x.gif", fps=5) >= 1


def test_dataframe_and_scipy_bridges_without_their_packages(monkeypatch):
    m = mlayer.data.load_sample()[:5]
    hide(monkeypatch, "pandas", "scipy")
    with pytest.raises(ImportError) as e:
        m.to_dataframe()
    check_error(e, "dataframe", "pandas")
    for call in (m.to_scipy, lambda: mlayer.quat.to_scipy(m.rot)):
        with pytest.raises(ImportError) as e:
            call()
        check_error(e, "scipy", "scipy")


def test_every_extra_is_in_pyproject_and_in_all():
    tomllib = pytest.importorskip("tomllib")
    path = REPO / "pyproject.toml"
    if not path.is_file():
        pytest.skip("no pyproject.toml beside the tests")
    extras = tomllib.loads(path.read_text())["project"]["optional-dependencies"]
    named = {extra for _, extra in _optional.EXTRAS.values()}
    assert named <= set(extras), named - set(extras)
    (all_,) = extras["all"]
    inside = set(all_.split("[", 1)[1].rstrip("]").split(","))
    assert all_.startswith("mlayer[") and named <= inside, (named, inside)
    assert inside <= set(extras) - {"all", "test"}
    for module, (dist, extra) in _optional.EXTRAS.items():
        reqs = " ".join(extras[extra]).lower()
        assert dist.split("[")[0].lower() in reqs, (module, extra, reqs)


# ---- the command line ------------------------------------------------------------------------

_DRIVER = textwrap.dedent("""
    import sys
    hidden, argv = sys.argv[1].split(","), sys.argv[2:]
    for name in hidden:
        sys.modules[name] = None
    from mlayer.cli import main
    sys.exit(main(argv))
""")


def run_hidden(cwd, hidden, *argv):
    return subprocess.run([sys.executable, "-c", _DRIVER, ",".join(hidden), *map(str, argv)],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


def cli_cases(clip):
    """(hidden modules, argv, the expected line after 'mlayer CMD: error: ')."""
    plot = "needs matplotlib: pip install 'mlayer[plot]'"
    return [
        (["matplotlib"], ["layers", clip, "--npz", "l.npz", "--plot", "l.png"],
         f"--plot {plot}"),
        (["matplotlib"], ["contacts", clip, "--plot", "c.png"], f"--plot {plot}"),
        (["matplotlib"], ["stream", clip, "-o", "s.bvh", "--plot", "s.png"], f"--plot {plot}"),
        (["matplotlib"], ["resample", clip, "--fps", "60", "-o", "r.bvh", "--report", "r.png"],
         f"--report PLOT {plot}"),
        (["matplotlib"], ["timewarp", clip, "-o", "t.bvh", "--plot", "t.png"], f"--plot {plot}"),
        (["matplotlib"], ["primitives", clip, "-o", "p.npz"],
         f"mlayer primitives --plots (on by default; --plots '' for none) {plot}"),
        (["matplotlib"], ["demo", "--clip", clip, "-o", "demo"],
         f"mlayer demo (its layer figure) {plot}"),
        (["PIL"], ["render", clip, "-o", "x.gif"],
         "mlayer render needs Pillow: pip install 'mlayer[render]'"),
        (["PIL"], ["render", clip, "-o", "x.png"],
         "mlayer render needs Pillow: pip install 'mlayer[render]'"),
        (["imageio_ffmpeg"], ["render", clip, "-o", "x.mp4"],
         "mlayer render -o FILE.mp4 needs imageio-ffmpeg: pip install 'mlayer[video]'"),
        (["distributed"], ["batch", "denoise", clip, "-o", "b", "--scheduler", "tcp://h:8786"],
         "mlayer batch --scheduler needs dask[distributed]: pip install 'mlayer[batch]'"),
        (["cryptography"], ["batch", "denoise", clip, "-o", "b", "--scheduler", "dask"],
         "mlayer batch's embedded Dask cluster (TLS) needs cryptography: "
         "pip install 'mlayer[batch]'"),
    ]


@pytest.mark.parametrize("case", range(12))
def test_cli_without_an_optional_module(tmp_path, walk_1s, case):
    hidden, argv, line = cli_cases(str(walk_1s))[case]
    # the modules checked before the hidden one must be there
    if hidden == ["imageio_ffmpeg"]:
        need("render")
    if hidden == ["cryptography"]:
        need("batch")
    r = run_hidden(tmp_path, hidden, *argv)
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert r.stderr == f"mlayer {argv[0]}: error: {line}\n", r.stderr
    assert r.stdout == ""
    assert os.listdir(tmp_path) == [], "nothing is written"


def test_cli_needs_only_what_the_flags_use(tmp_path, walk_1s):
    """Without matplotlib and Pillow, the commands that draw nothing run as before, and so do
    the drawing commands without their drawing options."""
    hidden = ["matplotlib", "PIL", "tqdm", "pandas", "distributed", "cryptography"]
    for argv, out in ((["denoise", walk_1s, "-o", "d.bvh"], "d.bvh"),
                      (["layers", walk_1s, "--npz", "l.npz"], "l.npz"),
                      (["contacts", walk_1s], None),
                      (["batch", "denoise", walk_1s, "-o", "b", "--no-progress", "--workers", "1"],
                       "b/walk.bvh")):
        r = run_hidden(tmp_path, hidden, *argv)
        assert r.returncode == 0, r.stderr
        if out:
            assert (tmp_path / out).is_file()


# ---- the check of scripts/test.sh: the suite as mlayer[test] alone runs it --------------------

def test_tests_extras_run_blocks_what_mlayer_test_does_not_install(tmp_path):
    """tests/extras/run.py blocks every installed module that mlayer[test] and the build do not
    need (the extras' modules among them, scipy not: `test` installs it), in child processes
    too; conftest.requires then skips, naming the extra."""
    run = REPO / "tests" / "extras" / "run.py"
    if not run.is_file():
        pytest.skip("tests/extras/ not in this tree")
    r = subprocess.run([sys.executable, str(run), "--list"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    blocked = set(r.stdout.split())
    for module, (_, extra) in _optional.EXTRAS.items():
        if extra != "scipy" and _optional.available(module):
            assert module in blocked, (module, extra)
    assert not blocked & {"mlayer", "numpy", "cffi", "pytest", "scipy", "bvhio", "sklearn",
                          "minisom"}, blocked
    probe = textwrap.dedent("""
        import subprocess, sys
        from mlayer import _optional
        from conftest import missing
        try:
            import matplotlib.pyplot
        except ModuleNotFoundError as e:
            print("blocked", e.name)
        print(_optional.available("matplotlib"), missing("plot"))
        child = "import importlib.util as u; print(u.find_spec('matplotlib') is None)"
        print(subprocess.run([sys.executable, "-c", child], capture_output=True,
                             text=True).stdout.strip())
    """)
    env = dict(os.environ, MLAYER_TEST_BLOCK="matplotlib",
               PYTHONPATH=os.pathsep.join([str(run.parent / "site"), str(REPO / "bindings" /
                                                                          "python" / "tests"),
                                           os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env,
                       cwd=tmp_path, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == [
        "blocked matplotlib", "False needs mlayer[plot]: matplotlib is not installed",
        "True"], r.stdout
