"""bench/python/render_worst.py: the worst frames drawn along the clip's own vertical axis.

A Z-up clip (MakeHuman, tests/data/wild) is drawn with Z vertical and a Y-up one (CMU 131_01)
with Y vertical, and each writes a PNG with a row per worst frame found. Before, the script
drew every clip with Y vertical, so a Z-up figure lay on its side.
"""
from __future__ import annotations

import sys

import pytest

import mlayer
from conftest import REPO, mocap_dir

sys.path.insert(0, str(REPO / "bench" / "python"))
pytest.importorskip("matplotlib")
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
