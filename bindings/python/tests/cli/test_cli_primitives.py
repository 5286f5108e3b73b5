"""`mlayer primitives` and `mlayer generate` of issue 23: criteria and held-out likelihoods
printed, checks before training, --through / --keys / --second-likely / --allow-unseen, and
bad input as one line naming the argument, exit status 1, nothing written."""
import numpy as np
import pytest

import mlayer
from conftest import requires
from mlayer.cli import main

BANDAI = "bandai1_walk_happy_001.bvh"


@pytest.fixture(scope="module")
def model_file(mocap, tmp_path_factory):
    clip = mocap / BANDAI
    if not clip.exists():
        pytest.skip(f"{BANDAI} not found")
    d = tmp_path_factory.mktemp("cli_primitives")
    out = d / "m.npz"
    assert main(["primitives", str(clip), "-o", str(out), "--som", "8x8", "--lattice", "6x6",
                 "--epochs", "8", "--ks", "2..9", "--order", "auto", "--plots", ""]) == 0
    return clip, out


@requires("plot")  # (its elbow figure, on by default)
def test_primitives_prints_the_criteria_and_orders(mocap, tmp_path, capsys):
    clip = mocap / BANDAI
    if not clip.exists():
        pytest.skip(f"{BANDAI} not found")
    out = tmp_path / "m.npz"
    assert main(["primitives", str(clip), "-o", str(out), "--som", "8x8", "--lattice", "6x6",
                 "--epochs", "8", "--ks", "2..9", "--criterion", "bic", "--cluster", "gmm",
                 "--order", "2", "--min-count", "2"]) == 0
    text = capsys.readouterr().out
    model = mlayer.PrimitiveModel.load(out)
    c = model.criteria
    rows = [ln.split() for ln in text.splitlines() if ln.strip()[:1].isdigit()]
    assert [int(r[0]) for r in rows] == list(range(2, 10))
    for r, i in zip(rows, range(8)):
        assert float(r[2]) == pytest.approx(c.silhouette[i], abs=1e-4)
        assert float(r[3]) == pytest.approx(c.bic[i], rel=1e-4)
    assert f"k = {model.centers.shape[0]} (cluster gmm, picked by bic)" in text
    assert model.centers.shape[0] <= c.picks["bic"] and model.markov.order == 2
    for o in (1, 2, 3):
        assert f"order {o}: {model.order_loglik[o][0]:.4f} nats" in text
    assert "order 2: " in text and "<- used" in text
    assert (tmp_path / "m_elbow.png").stat().st_size > 1000


def _one_error(capsys, command: str) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith(f"mlayer {command}: error")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@requires("plot")  # (without matplotlib, the default --plots is the first error)
def test_primitives_bad_input_before_training(mocap, tmp_path, capsys):
    clip = str(mocap / BANDAI)
    out = tmp_path / "bad.npz"
    cases = [
        (["--k", "100", "--som", "6x6"], "--k = 100 exceeds the SOM's 6x6 = 36 units"),
        (["--k", "500", "--som", "30x30", "--lattice", "4x4"], "--k = 500 exceeds the number "
                                                                 "of training frames (213)"),
        (["--lattice", "20x20", "--som", "8x8"], "--lattice 20x20 = 400 GRBF centres exceeds"),
        (["--order", "0"], "--order must be an integer in 1 .. 3, got 0"),
        (["--order", "x"], "--order must be 1, 2, 3 or auto"),
        (["--min-count", "0"], "--min-count must be an integer >= 1"),
        (["--ks", "40..50", "--som", "5x5"], "--ks: every candidate k exceeds"),
        # a range beyond the map or the frames: refused up front, not cut in silence
        (["--ks", "2..900", "--som", "6x6"], "--ks = 2..900 exceeds the SOM's 6x6 = 36 units (a "
                                              "SOM gives at most that many distinct manifold "
                                              "points): give candidates up to 36 (such as 2..36)"),
        (["--ks", "2..300", "--pca", "--lattice", "4x4"],
         "--ks = 2..300 exceeds the number of training frames (213): give candidates up to 213"),
        (["--k", "3", "--ks", "30..40", "--som", "5x5"], "--ks: every candidate k exceeds"),
    ]
    for extra, text in cases:
        capsys.readouterr()
        assert main(["primitives", clip, "-o", str(out), *extra]) == 1, extra
        err = capsys.readouterr().err
        line = [ln for ln in err.splitlines() if "error" in ln]
        assert len(line) == 1 and text in line[0], (extra, err)
        assert "batch epochs" not in err and "features:" not in err  # nothing trained
        assert not out.exists()


def test_the_k_source_is_true(model_file, tmp_path, capsys):
    """An integer --k is reported as given, even when a criterion picks the same k."""
    clip, model = model_file
    picked = mlayer.PrimitiveModel.load(model)
    assert picked.k_source == "elbow"
    k = picked.criteria.picks["elbow"]
    out = tmp_path / "k.npz"
    capsys.readouterr()
    assert main(["primitives", str(clip), "-o", str(out), "--som", "8x8", "--lattice", "6x6",
                 "--epochs", "8", "--ks", "2..9", "--k", str(k), "--plots", ""]) == 0
    text = capsys.readouterr().out
    assert f"k = {k} (cluster kmeans, given by --k)" in text and "picked by" not in text
    assert mlayer.PrimitiveModel.load(out).k_source == "given"


def test_default_ks_cut_to_the_map_with_a_note(mocap, tmp_path, capsys):
    clip = mocap / BANDAI
    if not clip.exists():
        pytest.skip(f"{BANDAI} not found")
    out = tmp_path / "s.npz"
    assert main(["primitives", str(clip), "-o", str(out), "--som", "3x3", "--lattice", "2x2",
                 "--epochs", "2", "--plots", ""]) == 0
    err = capsys.readouterr().err
    notes = [ln for ln in err.splitlines() if "candidate ks" in ln]
    assert notes == ["primitives: candidate ks 2..20 cut to 2..9: at most the SOM's 3x3 = 9 "
                     "units (a SOM gives at most that many distinct manifold points)"]
    assert list(mlayer.PrimitiveModel.load(out).criteria.ks) == list(range(2, 10))


def test_generate_through_keys_and_likely(model_file, tmp_path, capsys):
    clip, model = model_file
    m = mlayer.PrimitiveModel.load(model)
    runs = [
        (["--through", "1,1;6,3;2,6.5"], None),
        (["--keys", f"{BANDAI}:10,0:100,{clip}:200"], [10, 100, 200]),
        (["--start-frame", "3", "--second-likely"], None),
        (["--start-frame", "3", "--most-likely", "--noise", "0.3", "--allow-unseen"], None),
        (["--start-frame", "3", "--noise", "0.1", "--seed", "4"], None),
    ]
    for extra, _key_frames in runs:
        out = tmp_path / "g.bvh"
        assert main(["generate", str(model), "--frames", "90", "-o", str(out), *extra]) == 0
        g = mlayer.read_bvh(out)
        assert g.n_frames == 90 and np.isfinite(g.rot).all()
        out.unlink()
    # --through x,y: x the lattice column, y the row; the same as the API with (row, column)
    assert main(["generate", str(model), "--frames", "60", "--no-guards", "-o",
                 str(tmp_path / "t.bvh"), "--through", "1,2;6,5"]) == 0
    ref = m.generate(60, through=[[2.0, 1.0], [5.0, 6.0]], guards=False)
    np.testing.assert_allclose(mlayer.read_bvh(tmp_path / "t.bvh").positions(),
                               ref.positions(), atol=1e-3)  # BVH keeps 6 decimals
    # second likely: the printed primitives follow rank 2 of the jump model
    capsys.readouterr()
    assert main(["generate", str(model), "--frames", "200", "--start-frame", "3",
                 "--second-likely", "-o", str(tmp_path / "s.bvh")]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "primitives" in ln][0]
    seq = [int(v) for v in line.split("primitives ")[1].rstrip(")").split()]
    for a, b in zip(seq[:-1], seq[1:]):
        assert b == m.markov.ranked_next([a], 2)


def test_generate_bad_input(model_file, mocap, tmp_path, capsys):
    clip, model = model_file
    out = tmp_path / "x.bvh"
    cmu = mocap / "cmu_131_01_mj_style_walk.bvh"
    cases = [
        (["--through", "1,1;9,3"], "--through: point 1 (row 3, column 9) is outside the map"),
        (["--through", "1,1;a"], "--through: point 1 'a' is not x,y"),
        (["--through", ";"], "--through: no points"),
        (["--keys", "0:213"], "--keys: frame 213 is beyond clip 0"),
        (["--keys", f"{BANDAI}:999"], "--keys: frame 999 is beyond clip"),
        (["--keys", "5:1"], "--keys: clip index 5 out of range"),
        (["--keys", "nope.bvh:1"], "--keys: no training clip 'nope.bvh'"),
        (["--keys", "0"], "--keys: '0' is not CLIP:FRAME"),
        (["--keys", f"{cmu}:3"], "has another skeleton than the model"),
        (["--through", "1,1", "--keys", "0:1"], "--through and --keys exclude each other"),
        (["--most-likely", "--second-likely"], "--most-likely and --second-likely exclude"),
        (["--through", "1,1;2,2", "--noise", "0.5"], "--noise applies to the primitives' path"),
        (["--noise", "-1"], "noise must be"),
        (["--frames", "1"], "--frames must be >= 3"),
        (["--frames", "2"], "--frames must be >= 3"),  # the spline's LGS needs 3
    ]
    for extra, text in cases:
        if not cmu.exists() and str(cmu) in " ".join(extra):
            continue
        capsys.readouterr()
        assert main(["generate", str(model), "-o", str(out), *extra]) == 1, extra
        line = _one_error(capsys, "generate")
        assert text in line, (extra, line)
        assert not out.exists()
