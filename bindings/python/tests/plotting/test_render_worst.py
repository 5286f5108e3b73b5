"""bench/python/render_worst.py: the worst frames drawn along the clip's own vertical axis.

A Z-up clip (MakeHuman, tests/data/wild) is drawn with Z vertical and a Y-up one (CMU 131_01)
with Y vertical, and each writes a PNG with a row per worst frame found. Before, the script
drew every clip with Y vertical, so a Z-up figure lay on its side.
"""
from __future__ import annotations

import sys

import pytest

import mlayer
from conftest import REPO, mocap_dir, need

sys.path.insert(0, str(REPO / "bench" / "python"))
need("plot")
import render_worst as R  # noqa: E402


def _vertical_axes(monkeypatch, path, out):
    seen = []
    draw = R._draw

    def spy(ax, pos, parents, h_ax, v_ax, *args):
        seen.append((h_ax, v_ax))
        return draw(ax, pos, parents, h_ax, v_ax, *args)

    monkeypatch.setattr(R, "_draw", spy)
    rows = R.render(str(path), "stylize", 3.0, str(out), 40)
    return rows, seen


@pytest.mark.parametrize("clip, up", [
    (REPO / "tests" / "data" / "wild" / "makehuman_walk1_zup.bvh", 2),
    ("cmu_131_01_mj_style_walk.bvh", 1),
])
def test_worst_frames_are_drawn_with_the_clips_up_axis_vertical(monkeypatch, tmp_path, clip, up):
    path = clip if not isinstance(clip, str) else mocap_dir() / clip
    if not path.exists():
        pytest.skip(f"{path} not present")
    assert "xyz".index(mlayer.read_bvh(str(path)).up_axis.lower()) == up
    out = tmp_path / "worst.png"
    rows, seen = _vertical_axes(monkeypatch, path, out)
    assert rows, "stylize at alpha 3 unguarded has a fold, reversal or floor frame"
    assert len(seen) == 4 * len(rows)  # side and front, unguarded and guarded, per row
    assert {v for _, v in seen} == {up}
    assert {h for h, _ in seen} == {k for k in range(3) if k != up}
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ---- issue 38, item 10: --pop and --clean, saved per build and compared ----------------------

def test_pop_strip_is_saved_and_drawn_around_the_worst_foot_acceleration(mocap, tmp_path):
    """--pop saves the output's foot accelerations (the measure of test_guards_pops.py) and
    --compare draws STRIP consecutive frames per file around the first file's worst one; a jump
    of the foot point between two frames is named in red on its panel."""
    import numpy as np
    path = mocap / "cmu_131_01_mj_style_walk.bvh"
    if not path.exists():
        pytest.skip(f"{path} not present")
    npz = tmp_path / "after.npz"
    assert R.main([str(path), "--pop", "0.5", "--save", str(npz)]) == 0
    (c,) = R.load_cases(str(npz))
    feet = list(c["feet"])
    assert [str(c["names"][j]) for j in feet] == ["LeftAnkle", "LeftToe", "RightAnkle",
                                                  "RightToe"]
    acc = R.foot_accel(c["pos"][:, feet])
    np.testing.assert_allclose(c["accel"], acc)
    assert c["ratio"] == pytest.approx(acc.max() / max(c["a_in"], c["a_ref"]))
    t = c["frame"]
    assert acc[t - 1].max() == acc.max() and c["point"] in feet
    # a copy where the body jumps 10% of its height at the middle frame, as the "before"
    t = len(c["pos"]) // 2
    jumped = dict(c, pos=c["pos"].copy(), es=c["es"].copy(), frame=t)
    step = np.zeros(3)
    step[(c["up"] + 1) % 3] = 0.1 * c["H"]
    jumped["pos"][t:] += step
    jumped["es"][t:] += step
    out = tmp_path / "pops.png"
    fig = R.draw_cases([[jumped], [c]], ["before", "after"], str(out), 40)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(fig.axes) == 2 * R.STRIP
    titles = [a.get_title() for a in fig.axes]
    assert [s.split("\n")[0] for s in titles[:R.STRIP]] == [
        f"frame {f - 1} → {f}" for f in range(t - R.STRIP // 2, t + R.STRIP // 2 + 1)]
    red = [a.get_title() for a in fig.axes if a.title.get_color() == R.JUMP_C]
    pt = c["point"]
    s = 100 * np.linalg.norm(jumped["pos"][t, pt] - jumped["pos"][t - 1, pt]) / c["H"]
    assert s > 9
    assert red == [f"frame {t - 1} → {t}\n{c['names'][pt]} moved {s:.1f}% of body height"]


def test_clean_overlay_is_saved_and_drawn_at_the_worst_frame(tmp_path):
    """--clean saves the guarded and unguarded denoise and their joints' distance in % of body
    height; --compare draws a panel per clip and file at the first file's worst frame."""
    import numpy as np
    path = REPO / "tests" / "data" / "wild" / "assimp_cmu_01_03_first600.bvh"
    npz = tmp_path / "clean.npz"
    assert R.main([str(path), "--clean", "--save", str(npz)]) == 0
    (c,) = R.load_cases(str(npz))
    d = 100 * np.linalg.norm(c["pos"] - c["pos_u"], axis=-1) / c["H"]
    np.testing.assert_allclose(c["change"], d)
    assert d[c["frame"], c["joint"]] == d.max()
    out = tmp_path / "clean.png"
    assert R.main(["--compare", str(npz), str(npz), "-o", str(out), "--dpi", "40"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    fig = R.draw_cases([[c], [c]], ["before", "after"], str(out), 40)
    assert len(fig.axes) == 2
    assert all(f"frame {c['frame']}" in a.get_title() for a in fig.axes)
    assert f"moved {d.max():.2f}% of body height" in fig.axes[0].get_xlabel()


def test_floor_panels_are_saved_and_drawn_at_the_deepest_point(mocap, tmp_path):
    """--floor saves stylize's depth of every joint and End Site below the input's floor beyond
    the input's own, in % of body height; --compare draws the skeleton at the first file's
    deepest frame with the point ringed and its depth under the panel."""
    import numpy as np
    import mlayer
    path = mocap / "cmu_131_01_mj_style_walk.bvh"
    npz = tmp_path / "floor.npz"
    assert R.main([str(path), "--floor", "2", "--save", str(npz)]) == 0
    (c,) = R.load_cases(str(npz))
    m = mlayer.read_bvh(path)
    up = c["up"]
    pin = np.concatenate([m.positions(), m.end_site_positions()], axis=1)[..., up]
    pout = np.concatenate([c["pos"], c["es"]], axis=1)[..., up]
    fl = np.percentile(pin.min(axis=1), 5)
    ex = 100 * (np.maximum(0, fl - pout) - np.maximum(0, fl - pin)) / c["H"]
    np.testing.assert_allclose(c["excess"], ex)
    assert ex[c["frame"], c["point"]] == ex.max()
    out = tmp_path / "floor.png"
    fig = R.draw_cases([[c], [c]], ["before", "after"], str(out), 40)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(fig.axes) == 2
    assert all(f"frame {c['frame']}" in a.get_title() for a in fig.axes)
    assert "below the floor" in fig.axes[0].get_xlabel()
