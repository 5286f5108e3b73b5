"""Self-checks of the plausibility bench's own definitions (python -m pytest bench/python).

bench_plausibility.py measures with definitions of its own; these tests check them on data
where the answer is known: its forward kinematics against the library's, a foot-acceleration
spike, a point pushed below the floor, a scaled sinusoidal bob, a foot that stops and moves,
knees and elbows found on a skeleton whose names say nothing, folds and reversals of a leg
whose knee angle is known. The last tests check plausibility.py, the older library-assisted
measures that render_worst.py and bindings/python/tests/test_wild_corpus.py still use.
"""
from __future__ import annotations

import pathlib
import sys
import warnings

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

import mlayer  # noqa: E402
from mlayer import quat  # noqa: E402

import bench_plausibility as B  # noqa: E402
import corpus  # noqa: E402
import plausibility as P  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
SHARED = REPO.parent / "shared" / "data" / "mocap"
WILD = REPO / "tests" / "data" / "wild"

NAMES = ["Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToe"]
PARENTS = [-1, 0, 1, 2, 3]
OFFSETS = np.array([[0, 0, 0], [1, 0, 0], [0, -4, 0], [0, -4, 0], [0, 0, 1.0]])


def leg(knee_deg: np.ndarray | list[float], root_y: float | np.ndarray = 8.0) -> mlayer.Motion:
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


def _random_rot(rng: np.random.Generator, shape: tuple[int, ...], scale: float = 0.5
                ) -> np.ndarray:
    q = np.concatenate([np.ones(shape + (1,)), scale * rng.standard_normal(shape + (3,))], -1)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


# ---- forward kinematics -------------------------------------------------------------------


def _check_fk(m: mlayer.Motion) -> None:
    pos, wrot = B.forward_kinematics(m)
    np.testing.assert_allclose(pos, m.positions(), rtol=0, atol=1e-9)
    np.testing.assert_allclose(B.end_site_positions(m, pos, wrot), m.end_site_positions(),
                               rtol=0, atol=1e-9)


def test_fk_matches_positions_with_translation_channels_and_end_sites() -> None:
    rng = np.random.default_rng(1)
    names = ["root", "a", "b", "c", "d"]
    parents = [-1, 0, 1, 1, 3]
    offsets = rng.standard_normal((5, 3))
    pos6 = "Xposition Yposition Zposition Zrotation Xrotation Yrotation"
    channels = [pos6, "Zrotation Xrotation Yrotation", pos6, "Zrotation Xrotation Yrotation",
                "Zrotation Xrotation Yrotation"]
    N = 7
    m = mlayer.Motion.from_arrays(
        names, parents, offsets, rng.standard_normal((N, 3)), _random_rot(rng, (N, 5)),
        fps=30, channels=channels, trans=rng.standard_normal((N, 1, 3)),
        end_site_parents=[2, 4], end_site_offsets=rng.standard_normal((2, 3)))
    assert list(m.skeleton.trans_joints) == [2]
    _check_fk(m)


@pytest.mark.skipif(not SHARED.is_dir(), reason="no ../shared/data/mocap")
@pytest.mark.parametrize("name", ["cmu_131_01_mj_style_walk.bvh",   # End Sites, 120 fps
                                  "bandai1_walk_happy_001.bvh",     # position channels
                                  "lafan1_clip_a.bvh"])             # root OFFSET
def test_fk_matches_positions_on_shared_clips(name: str) -> None:
    m, _ = corpus.read_clip(SHARED / name, 400)
    _check_fk(m)


def test_fk_matches_positions_on_a_wild_clip_with_a_root_offset() -> None:
    m, _ = corpus.read_clip(WILD / "pymo_av_8walk_meredith_first600.bvh", 200)
    assert np.abs(m.offsets[0]).max() > 0
    _check_fk(m)


# ---- pop, floor, bob, contacts --------------------------------------------------------------


def test_foot_acceleration_spike_ratio() -> None:
    t = np.arange(40, dtype=float)
    p_in = np.zeros((40, 2, 3))
    p_in[:, :, 0] = 0.5 * t[:, None]                 # straight line: no acceleration
    p_ref = p_in.copy()
    p_ref[:, 1, 1] = 0.05 * t ** 2                   # constant 0.1 per frame^2
    p_out = p_in.copy()
    p_out[17, 0, 2] += 0.3                           # a spike: |p(t+1) - 2p(t) + p(t-1)| = 0.6
    assert B.accel_max(p_ref)[0] == pytest.approx(0.1)
    a, t0, k = B.accel_max(p_out)
    assert a == pytest.approx(0.6) and (t0, k) == (17, 0)
    assert B.pop_ratio(p_out, p_in, p_ref) == pytest.approx(6.0)
    assert B.pop_ratio(p_out, p_ref, p_in) == pytest.approx(6.0)   # the larger reference
    assert np.isnan(B.pop_ratio(p_out, p_in, p_in))                  # nothing to compare with


def test_floor_depth_counts_only_what_the_output_adds() -> None:
    h_in = np.ones((20, 4))
    h_in[5, 2] = -0.2                 # the input is already 0.2 below the floor there
    h_out = h_in.copy()
    h_out[5, 2] = -0.25               # 0.05 deeper than the input
    h_out[9, 1] = -0.3                # 0.3 below where the input was above
    h_out[12, 3] = 0.01               # lower, but above the floor
    d, t, k = B.floor_depth(h_out, h_in, 0.0)
    assert d == pytest.approx(0.3) and (t, k) == (9, 1)
    h_out[9, 1] = 1.0
    d, t, k = B.floor_depth(h_out, h_in, 0.0)
    assert d == pytest.approx(0.05) and (t, k) == (5, 2)
    assert B.floor_depth(h_in, h_in, 0.0) == (0.0, -1, -1)


def test_floor_and_depth_of_a_motion_pushed_down() -> None:
    k = np.full(40, 10.0)
    inp = leg(k)
    pts, _ = B.all_points(inp)
    up = np.array([0.0, 1.0, 0.0])
    h = pts @ up
    H = B.body_height(h[:, :inp.n_joints])
    floor = B.floor_level(h)
    assert floor == pytest.approx(h.min())           # the toe, the same in every frame
    y = np.full(40, 8.0)
    y[5:8] -= 0.02 * H                               # 2 % of H below in three frames
    out = leg(k, y)
    d, t, _ = B.floor_depth(B.all_points(out)[0] @ up, h, floor)
    assert 100.0 * d / H == pytest.approx(2.0)
    assert t in (5, 6, 7)


def test_bob_ratio_of_a_scaled_sinusoid() -> None:
    fps = 30.0
    t = np.arange(300) / fps
    wave = 0.03 * np.sin(2 * np.pi * 1.8 * t)
    y_in = 0.9 + wave
    for s in (0.5, 1.0, 2.5):
        assert B.bob(0.9 + s * wave, fps) / B.bob(y_in, fps) == pytest.approx(s, rel=1e-12)
    # a slow drift (0.1 Hz) is mostly taken out by the 1 s moving average
    drift = 0.2 * np.sin(2 * np.pi * 0.1 * t)
    assert B.bob(y_in + drift, fps) / B.bob(y_in, fps) == pytest.approx(1.0, abs=0.05)
    assert B.bob(np.full(50, 3.0), fps) == 0.0


def test_contact_rule_on_a_foot_that_stops_and_moves() -> None:
    fps, H = 30.0, 1.0
    up = np.array([0.0, 1.0, 0.0])
    N = 120
    p = np.zeros((N, 1, 3))
    x = 0.0
    for t in range(N):
        if 30 <= t < 60:             # slides along the floor at 1 H/s
            x += 1.0 / fps
        p[t, 0, 0] = x
        if 60 <= t < 90:             # held still 10 % H above the floor
            p[t, 0, 1] = 0.1
    c = B.contact_frames(p, up, 0.0, H, fps)[:, 0]
    k = max(1, round(B.SPEED_SPAN_S * fps))       # the speed's half-span, in frames
    assert c[:30 - k].all()                        # standing
    assert not c[30 + k:60 - k].any()              # moving
    assert not c[60:90].any()                      # lifted
    assert c[90:].all()                            # standing again
    sp = B.horizontal_speed(p, up, fps)[:, 0]
    assert sp[40] == pytest.approx(1.0) and sp[100] == 0.0


def test_horizontal_speed_ignores_vertical_motion() -> None:
    fps = 60.0
    t = np.arange(100) / fps
    p = np.zeros((100, 1, 3))
    p[:, 0, 2] = np.sin(t)       # up is Z: this is all vertical
    p[:, 0, 0] = 0.5 * t         # 0.5 units per second horizontally
    sp = B.horizontal_speed(p, np.array([0.0, 0.0, 1.0]), fps)
    np.testing.assert_allclose(sp, 0.5, rtol=1e-9)


# ---- limbs, folds, reversals, bones, up ---------------------------------------------------


def humanoid(n_frames: int = 6, names: list[str] | None = None,
             rng: np.random.Generator | None = None) -> mlayer.Motion:
    """A 21-joint Y-up figure 1.7 tall standing on the floor (toes at 0)."""
    par = [-1, 0, 1, 2, 3, 0, 5, 6, 7, 0, 9, 10, 11, 10, 13, 14, 15, 10, 17, 18, 19]
    off = np.array([[0, 0, 0],
                    [0.1, 0, 0], [0, -0.45, 0], [0, -0.45, 0], [0, -0.05, 0.15],
                    [-0.1, 0, 0], [0, -0.45, 0], [0, -0.45, 0], [0, -0.05, 0.15],
                    [0, 0.25, 0], [0, 0.25, 0], [0, 0.15, 0], [0, 0.1, 0],
                    [0.18, 0.1, 0], [0.3, 0, 0], [0.25, 0, 0], [0.08, 0, 0],
                    [-0.18, 0.1, 0], [-0.3, 0, 0], [-0.25, 0, 0], [-0.08, 0, 0]])
    default = ["Hips", "LHip", "LKnee", "LAnkle", "LToe", "RHip", "RKnee", "RAnkle", "RToe",
               "Spine", "Chest", "Neck", "Head", "LShoulder", "LElbow", "LWrist", "LHand",
               "RShoulder", "RElbow", "RWrist", "RHand"]
    rot = np.zeros((n_frames, 21, 4))
    rot[..., 0] = 1.0
    if rng is not None:
        rot = _random_rot(rng, (n_frames, 21), 0.05)
    root = np.tile([0.0, 0.95, 0.0], (n_frames, 1))
    return mlayer.Motion.from_arrays(names or default, par, off, root, rot, fps=30,
                                     end_site_parents=[4, 8, 12, 16, 20],
                                     end_site_offsets=[[0, 0, 0.05], [0, 0, 0.05],
                                                       [0, 0.1, 0], [0.05, 0, 0],
                                                       [-0.05, 0, 0]])


@pytest.mark.parametrize("named", [True, False])
def test_knees_and_elbows_by_the_tree(named: bool) -> None:
    names = None if named else [f"j{i}" for i in range(21)]   # names that say nothing
    m = humanoid(names=names)
    pts, _ = B.all_points(m)
    rig = B.make_rig(m, pts)
    assert rig.H == pytest.approx(1.7)
    assert rig.floor == pytest.approx(0.0, abs=1e-12)
    assert sorted(rig.limbs.knees) == [(1, 2, 3), (5, 6, 7)]
    assert sorted(rig.limbs.elbows) == [(13, 14, 15), (17, 18, 19)]
    assert rig.limbs.pelvis == 0
    feet = {rig.point_names[f] for f in rig.feet}
    toes = {m.joint_names[j] for j in (4, 8)}
    assert toes <= feet <= toes | {m.joint_names[j] for j in (3, 7)} | {
        f"{t}/End" for t in toes}
    assert set(rig.parts["legs"]) == set(range(1, 9))
    assert set(rig.parts["arms"]) == set(range(13, 21))
    assert set(rig.parts["spine"]) == {0, 9, 10, 11, 12}


def test_fold_and_reversal_counts() -> None:
    inp = leg(np.linspace(10, 60, 20))
    out_k = np.linspace(10, 60, 20)
    out_k[3] = 155.0     # > 150 and > 60 + 10: a fold
    out_k[4] = 65.0      # within input max + 10: not a fold
    out_k[7] = -20.0     # the other way, beyond the input's min (10 > 0, so beyond 0 - 1)
    out_k[8] = -0.5      # within the 1-degree tolerance: not a reversal
    pi, wi = B.forward_kinematics(inp)
    po, wo = B.forward_kinematics(leg(out_k))
    np.testing.assert_allclose(B.flexion(pi, (1, 2, 3)), np.linspace(10, 60, 20), atol=1e-9)
    nf, nr, wf, wr = B.hinge_frames(pi, wi, po, wo, inp.parents, [(1, 2, 3)])
    assert (nf, nr) == (1, 1)
    assert wf[:2] == (3, 2) and wf[2] == pytest.approx(155.0)
    assert wr[:2] == (7, 2) and wr[2] == pytest.approx(-20.0)
    ax = B.hinge_axis(pi, wi, inp.parents, (1, 2, 3))
    assert ax is not None
    np.testing.assert_allclose(B.signed_flexion(pi, wi, inp.parents, (1, 2, 3), ax),
                               np.linspace(10, 60, 20), atol=1e-9)


def test_bone_change_leaves_out_moving_translations() -> None:
    m = leg(np.full(5, 30.0))
    p = B.forward_kinematics(m)[0]
    q = p.copy()
    q[:, 3] = p[:, 2] + 1.1 * (p[:, 3] - p[:, 2])   # shin 10 % longer
    q[:, 4] += q[:, 3] - p[:, 3]
    assert B.bone_change(p, q, m.parents, 1.0) == pytest.approx(0.1)
    p2 = p.copy()
    p2[:, 1:] += np.linspace(0, 1, 5)[:, None, None]  # joint 1 carried by a moving translation
    q2 = p2.copy()
    q2[:, 1:] *= 2.0
    # every bone below joint 1 doubled (100 %); joint 1's distance to the root moves in the
    # input: not a bone, left out
    assert B.bone_change(p2, q2, m.parents, 1.0) == pytest.approx(1.0)


def test_own_up_axis() -> None:
    m = humanoid()
    pos = B.forward_kinematics(m)[0]
    assert B.own_up(pos, m.joint_names, m.parents) == (1, 1, True)
    zup = pos[..., [0, 2, 1]] * np.array([1.0, 1.0, -1.0])   # feet above the hips along -z
    assert B.own_up(zup, m.joint_names, m.parents) == (2, -1, True)


def test_rms_angle() -> None:
    m = leg(np.full(4, 30.0))
    base = leg(np.zeros(4))
    assert B.rms_angle(m.rot, base.rot, np.array([2])) == pytest.approx(np.radians(30.0))


# ---- a whole clip, targets ------------------------------------------------------------------


def test_measure_clip_end_to_end() -> None:
    m, _ = corpus.read_clip(WILD / "pymo_av_8walk_meredith_first600.bvh", 240)
    res = B.measure_clip(m, [2.0], "pymo")
    assert [r["case"] for r in res["rows"]] == ["denoise", "stylize 2"]
    info = res["info"]
    assert len(info["knees"]) == 2 and len(info["elbows"]) == 2 and info["feet"]
    den = res["rows"][0]
    assert den["bob"] == pytest.approx(1.0, abs=0.3)
    assert den["bone"] < 1e-6
    for row in res["rows"]:
        assert row["pop"] >= 0 and row["floor"] >= 0 and row["ref"]["floor"] >= 0


def test_targets_and_summary() -> None:
    rows = [{"op": "denoise", "alpha": 1.0, "case": "denoise", "pop": 1.2, "floor": 0.7,
             "clean": 0.2, "clean_applies": True, "bob": 1.1, "bone": 0.0,
             "knee_fold": 0, "knee_rev": 2, "elbow_fold": None, "elbow_rev": None},
            {"op": "stylize", "alpha": 2.0, "case": "stylize 2", "pop": 1.6, "floor": 0.1,
             "clean": float("nan"), "clean_applies": False, "bob": 1.5, "bone": 0.0,
             "knee_fold": 0, "knee_rev": 0, "elbow_fold": None, "elbow_rev": None}]
    s = B.summarize([{"clip": "a", "rows": rows}, {"refused": "x", "clip": "b"}])
    assert s["pop"]["clips"] == 1 and s["pop"]["meeting"] == 0
    assert [f[:2] for f in s["pop"]["failing"]] == [("a", "stylize 2")]
    assert s["floor"]["failing"][0][:2] == ("a", "denoise")
    assert s["clean"]["meeting"] == 1
    assert s["bob"]["meeting"] == 1          # 1.1 and 1.5 / 2 = 0.75: both within 30 %
    assert s["knee_rev"]["meeting"] == 0
    assert s["elbow_fold"]["clips"] == 0     # no elbows: the target does not apply


def test_find_clips(tmp_path: pathlib.Path) -> None:
    (tmp_path / "sub").mkdir()
    (tmp_path / ".hidden").mkdir()
    for p in ("a.bvh", "sub/b.BVH", ".hidden/c.bvh", "d.txt"):
        (tmp_path / p).write_text("")
    names = [c.name for c in corpus.find_clips([tmp_path])]
    assert names == ["a.bvh", "sub/b.BVH"]
    assert [c.name for c in corpus.find_clips([tmp_path], "b*")] == ["sub/b.BVH"]


# ---- plausibility.py (render_worst.py, test_wild_corpus.py) ---------------------------------


def test_legacy_flexion_and_hinge_report() -> None:
    angles = np.array([0.0, 30.0, 90.0, 140.0])
    m = leg(angles)
    ch = P.limb_chains(m)["knee"]
    assert [m.joint_names[c[1]] for c in ch] == ["LeftLeg"]
    np.testing.assert_allclose(P.flexion(m.positions(), ch[0]), angles, atol=1e-9)
    inp = leg(np.linspace(10, 60, 20))
    out_k = np.linspace(10, 60, 20)
    out_k[3], out_k[7] = 155.0, -20.0
    rep = P.hinge_report(inp, leg(out_k))["knee"]
    assert rep["fold_frames"] == 1 and rep["reversal_frames"] == 1


def test_legacy_floor_penetration_depth() -> None:
    k = np.full(40, 10.0)
    inp = leg(k)
    H = mlayer.metrics.body_height(inp)
    feet = P.foot_points(inp)
    floor = P.floor_level(inp, feet)
    y = np.full(40, 8.0)
    y[5:8] -= 0.02 * H             # 2 % of H below: penetrates
    y[20] -= 0.003 * H             # 0.3 % of H: within tolerance
    rep = P.floor_report(inp, leg(k, y), feet, floor, H)
    assert rep["frames"] == 3
    assert rep["deepest_pct"] == pytest.approx(2.0, abs=1e-6)
    # where the input itself is 1 % of H under the floor, only the depth beyond it counts
    yin = np.full(40, 8.0)
    yin[5:8] -= 0.01 * H
    rep = P.floor_report(leg(k, yin), leg(k, y), feet, floor, H)
    assert rep["frames"] == 3
    assert rep["deepest_pct"] == pytest.approx(1.0, abs=1e-6)


def _axis_angle(axis: list[float] | np.ndarray, deg: float) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    h = np.radians(deg) / 2.0
    return np.concatenate([[np.cos(h)], np.sin(h) * a])


def test_legacy_swing_twist_excess() -> None:
    inp = leg(np.linspace(10, 60, 20))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lim = mlayer.joint_limits(inp)
    assert max(P.swing_twist_excess(lim, inp.rot).values()) < 1e-9  # the input is inside
    name = next(n for n in P.swing_twist_excess(lim, inp.rot))
    j = inp.joint_names.index(name)
    g, r = lim.geometry(j), lim.range(j)
    t = g["bone_out"] / np.linalg.norm(g["bone_out"])
    perp = np.cross(t, [1.0, 0.0, 0.0] if abs(t[0]) < 0.9 else [0.0, 1.0, 0.0])
    swung = inp.rot.copy()
    swung[5, j] = quat.mul(g["centre"], _axis_angle(perp, np.degrees(r["swing"]) + 7.0))
    assert P.swing_twist_excess(lim, swung)[name] == pytest.approx(7.0, abs=1e-6)


def test_joint_flips() -> None:
    """A joint that snaps a half turn in one frame where the input and the synthesis turn a few
    degrees is a flip; a turn the synthesis makes too is not."""
    n = 20
    ang = np.radians(np.linspace(0.0, 40.0, n))  # 2.1 degrees a frame about z
    q = np.zeros((n, 2, 4))
    q[:, :, 0], q[:, :, 3] = np.cos(ang / 2)[:, None], np.sin(ang / 2)[:, None]
    out = q.copy()
    out[10:, 0] = [B.qmul(np.array([0.0, 1.0, 0.0, 0.0]), r) for r in q[10:, 0]]  # half turn
    count, worst = B.joint_flips(out, q, q)
    assert count == 1 and worst is not None
    assert worst[0] == 10 and worst[1] == 0 and abs(worst[2] - 180.0) < 1e-6
    assert B.joint_flips(out, q, out)[0] == 0  # the synthesis flips there too
    assert B.joint_flips(q, q, q) == (0, None)
