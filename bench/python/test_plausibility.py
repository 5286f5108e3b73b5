"""Self-checks of plausibility.py on small synthetic motions (python -m pytest bench/python).

A planar three-joint leg whose knee angle is known by construction, a motion pushed below
its floor by a known depth, and a root path with a known offset.
"""
from __future__ import annotations

import pathlib
import sys

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

import mlayer  # noqa: E402
from mlayer import quat  # noqa: E402

import plausibility as P  # noqa: E402

NAMES = ["Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToe"]
PARENTS = [-1, 0, 1, 2, 3]
OFFSETS = np.array([[0, 0, 0], [1, 0, 0], [0, -4, 0], [0, -4, 0], [0, 0, 1.0]])


def leg(knee_deg, root_y=8.0):
    """A leg hanging down from the hips, the knee bent by knee_deg about X (positive: the
    shin swings backwards, -Z)."""
    k = np.asarray(knee_deg, dtype=float)
    n = k.size
    rot = np.zeros((n, 5, 4))
    rot[..., 0] = 1.0
    rot[:, 2] = quat.from_euler(np.stack([-k, np.zeros(n), np.zeros(n)], -1), "XYZ")
    root = np.zeros((n, 3))
    root[:, 1] = root_y
    return mlayer.Motion.from_arrays(NAMES, PARENTS, OFFSETS, root, rot, fps=30)


def test_flexion_matches_construction():
    angles = np.array([0.0, 30.0, 90.0, 140.0])
    m = leg(angles)
    ch = P.limb_chains(m)["knee"]
    assert [m.joint_names[c[1]] for c in ch] == ["LeftLeg"]
    f = P.flexion(m.positions(), ch[0])
    np.testing.assert_allclose(f, angles, atol=1e-9)


def test_fold_and_reversal_counts():
    inp = leg(np.linspace(10, 60, 20))
    out_k = np.linspace(10, 60, 20)
    out_k[3] = 155.0     # > 150 and > 60 + 10: a fold
    out_k[4] = 65.0      # within input max + 10: not a fold
    out_k[7] = -20.0     # the other way, beyond the input's min (10 > 0, so beyond 0 - 1)
    out_k[8] = -0.5      # within the 1-degree tolerance: not a reversal
    rep = P.hinge_report(inp, leg(out_k))["knee"]
    assert rep["fold_frames"] == 1 and rep["worst_fold"][0] == 3
    assert rep["worst_fold"][2] == pytest.approx(155.0)
    assert rep["reversal_frames"] == 1 and rep["worst_reversal"][0] == 7
    assert rep["worst_reversal"][2] == pytest.approx(-20.0)


def test_signed_flexion_sign():
    inp = leg(np.linspace(20, 80, 10))
    pos, wrot = inp.forward_kinematics()
    ch = P.limb_chains(inp)["knee"][0]
    ax = P.hinge_axis_local(pos, wrot, inp.parents, ch)
    s = P.signed_flexion(pos, wrot, inp.parents, ch, ax)
    np.testing.assert_allclose(s, np.linspace(20, 80, 10), atol=1e-9)
    o = leg(-np.linspace(20, 80, 10))
    po, wo = o.forward_kinematics()
    np.testing.assert_allclose(P.signed_flexion(po, wo, o.parents, ch, ax),
                               -np.linspace(20, 80, 10), atol=1e-9)


def test_floor_penetration_depth():
    k = np.full(40, 10.0)
    inp = leg(k)
    H = mlayer.metrics.body_height(inp)
    feet = P.foot_points(inp)
    floor = P.floor_level(inp, feet)
    y = np.full(40, 8.0)
    y[5:8] -= 0.2 * H / 100 * 10   # 2 % of H below: penetrates
    y[20] -= 0.003 * H             # 0.3 % of H: within tolerance
    out = leg(k, y)
    rep = P.floor_report(inp, out, feet, floor, H)
    assert rep["frames"] == 3
    assert rep["deepest_pct"] == pytest.approx(2.0, abs=1e-6)


def test_root_path_and_bones():
    t = np.linspace(0, 10, 50)
    root_in = np.stack([t, np.zeros_like(t), np.zeros_like(t)], -1)
    root_out = root_in + np.array([0, 0, 0.3])
    root_out[10, 2] = 1.5
    assert P.root_path_deviation(root_in, root_out) == pytest.approx(1.5)
    m = leg(np.full(5, 30.0))
    p = m.positions()
    q = p.copy()
    q[:, 3] = p[:, 2] + 1.1 * (p[:, 3] - p[:, 2])   # shin 10 % longer
    q[:, 4] += q[:, 3] - p[:, 3]
    assert P.bone_length_change(p, q, m.parents, 1.0) == pytest.approx(0.1)


def test_rms_angle_and_parts():
    m = leg(np.full(4, 30.0))
    base = leg(np.zeros(4))
    parts = P.body_parts(m)
    assert set(parts["legs"]) == {1, 2, 3, 4} and list(parts["spine_head"]) == [0]
    assert P.rms_angle(m.rot, base.rot, np.array([2])) == pytest.approx(np.radians(30.0))


def test_up_axis():
    m = leg(np.full(4, 30.0))
    assert P.up_axis(m) == "Y"


def _axis_angle(axis, deg):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    h = np.radians(deg) / 2.0
    return np.concatenate([[np.cos(h)], np.sin(h) * a])


def test_swing_twist_excess():
    inp = leg(np.linspace(10, 60, 20))
    lim = mlayer.joint_limits(inp)
    assert max(P.swing_twist_excess(lim, inp.rot).values()) < 1e-9  # the input is inside
    name = next(n for n in P.swing_twist_excess(lim, inp.rot))
    j = inp.joint_names.index(name)
    g, r = lim.geometry(j), lim.range(j)
    t = g["bone_out"] / np.linalg.norm(g["bone_out"])
    perp = np.cross(t, [1.0, 0.0, 0.0] if abs(t[0]) < 0.9 else [0.0, 1.0, 0.0])
    swung, twisted = inp.rot.copy(), inp.rot.copy()
    # swing alone, 7 degrees past the bound (the centre's frame: r = conj(c) q)
    swung[5, j] = quat.mul(g["centre"], _axis_angle(perp, np.degrees(r["swing"]) + 7.0))
    # twist alone about the bone, 4 degrees past
    twisted[5, j] = quat.mul(g["centre"], _axis_angle(t, np.degrees(r["twist"]) + 4.0))
    assert P.swing_twist_excess(lim, swung)[name] == pytest.approx(7.0, abs=1e-6)
    assert P.swing_twist_excess(lim, twisted)[name] == pytest.approx(4.0, abs=1e-6)
    if r["widen"]:  # a range widened by alpha: at alpha 2 the bound is twice as far
        s = np.degrees(r["swing"])
        want = max(0.0, s + 7.0 - min(180.0, 2.0 * s))
        assert P.swing_twist_excess(lim, swung, 2.0)[name] == pytest.approx(want, abs=1e-6)
