"""The rest joints of mlayer.io.smpl: the neutral SMPL-H body with betas = 0, checked against
independently generated tables of other permissively licensed projects (the numbers only,
rounded as those projects publish them)."""
from __future__ import annotations

import numpy as np
import pytest

import mlayer
from mlayer.io import smpl

# The body offsets (SMPL order, joints 1..21, template frame, metres) of the neutral SMPL model
# with betas = 0 as written, at 4 decimals, in smpl_sim/data/assets/mjcf/smpl_humanoid.xml of
# github.com/ZhengyiLuo/SMPLSim (commit b5c08720503ad5fff64050c4d289c42d947fcf8d, BSD
# 3-Clause, "Copyright (c) 2024, Zhengyi Luo"); its pelvis location is (-0.0018, -0.2233,
# 0.0282). SMPLSim names Spine1-3 Torso, Spine, Chest, the feet L_Toe, the collars L_Thorax.
SMPLSIM_NEUTRAL_BODY = np.array([
    (0.0695, -0.0914, -0.0068), (-0.0677, -0.0905, -0.0043), (-0.0025, 0.109, -0.0267),
    (0.0343, -0.3752, -0.0045), (-0.0383, -0.3826, -0.0089), (0.0055, 0.1352, 0.0011),
    (-0.0136, -0.398, -0.0437), (0.0158, -0.3984, -0.0423), (0.0015, 0.0529, 0.0254),
    (0.0264, -0.0558, 0.1193), (-0.0254, -0.0481, 0.1233), (-0.0028, 0.2139, -0.0429),
    (0.0788, 0.1217, -0.0341), (-0.0818, 0.1188, -0.0386), (0.0052, 0.065, 0.0513),
    (0.091, 0.0305, -0.0089), (-0.096, 0.0326, -0.0091), (0.2596, -0.0128, -0.0275),
    (-0.2537, -0.0133, -0.0214), (0.2492, 0.009, -0.0012), (-0.2553, 0.0078, -0.0056)])
SMPLSIM_NEUTRAL_PELVIS = np.array([-0.0018, -0.2233, 0.0282])

# The finger offsets (SMPL-H order, joints 22..51) of the neutral SMPL-X model with betas = 0
# (MANO hands like SMPL-H's, on another template) in test.xml of the same SMPLSim commit.
SMPLSIM_NEUTRAL_SMPLX_FINGERS = np.array([
    (0.1019, -0.0087, 0.0194), (0.0319, 0.0022, 0.003), (0.0225, -0.0024, 0.0001),
    (0.1094, -0.0063, -0.004), (0.0306, 0.0008, -0.004), (0.0235, -0.002, -0.0041),
    (0.084, -0.0145, -0.0437), (0.0155, -0.0011, -0.012), (0.0155, -0.0017, -0.0112),
    (0.0974, -0.0093, -0.0273), (0.028, 0.0015, -0.0053), (0.0228, -0.0015, -0.0071),
    (0.0406, -0.018, 0.0256), (0.017, 0.001, 0.025), (0.0205, -0.0052, 0.0155),
    (-0.0999, -0.0118, 0.0196), (-0.0319, 0.0022, 0.003), (-0.0225, -0.0023, 0.0001),
    (-0.1074, -0.0094, -0.0037), (-0.0306, 0.0008, -0.004), (-0.0235, -0.002, -0.0041),
    (-0.082, -0.0176, -0.0435), (-0.0155, -0.0011, -0.012), (-0.0155, -0.0017, -0.0112),
    (-0.0954, -0.0124, -0.0271), (-0.028, 0.0015, -0.0053), (-0.0228, -0.0015, -0.0071),
    (-0.0386, -0.0211, 0.0259), (-0.017, 0.001, 0.025), (-0.0205, -0.0052, 0.0155)])

# half a unit of the 4th decimal, plus the float32 rounding of the two projects' differences
ROUNDING = 0.5e-4 + 1e-7
WRISTS = {"L": 20, "R": 21}


def _rest_positions(offsets: np.ndarray, parents) -> np.ndarray:
    pos = np.zeros_like(offsets)
    for j, p in enumerate(parents):
        pos[j] = offsets[j] + (pos[p] if p >= 0 else 0.0)
    return pos


def _hand_relative(offsets: np.ndarray, side: str) -> np.ndarray:
    """(15, 3) locations of one hand's finger joints relative to its wrist."""
    first = smpl.SMPLH_NAMES.index(f"{side}_Index1")
    pos = _rest_positions(np.asarray(offsets), smpl.SMPLH_PARENTS)
    return pos[first:first + 15] - pos[WRISTS[side]]


def test_offsets_are_the_rest_joints_less_their_parents():
    J, par = smpl.SMPLH_REST_JOINTS, smpl.SMPLH_PARENTS
    assert J.shape == (52, 3) and len(par) == 52 and len(smpl.SMPLH_NAMES) == 52
    np.testing.assert_allclose(_rest_positions(smpl.SMPLH_OFFSETS, par), J, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(smpl.SMPL_BODY_OFFSETS, smpl.SMPLH_OFFSETS[:22])
    assert smpl.tree(False)[2] is smpl.SMPL_BODY_OFFSETS
    assert smpl.tree(True)[2] is smpl.SMPLH_OFFSETS
    for a in (smpl.SMPLH_REST_JOINTS, smpl.SMPLH_OFFSETS, smpl.SMPL_BODY_OFFSETS):
        assert not a.flags.writeable


def test_body_is_the_neutral_body_of_an_independent_table():
    np.testing.assert_allclose(smpl.SMPL_BODY_OFFSETS[1:], SMPLSIM_NEUTRAL_BODY, rtol=0,
                               atol=ROUNDING)
    np.testing.assert_allclose(smpl.SMPLH_REST_JOINTS[0], SMPLSIM_NEUTRAL_PELVIS, rtol=0,
                               atol=ROUNDING)


def test_neutral_body_height():
    # the joints' extent at rest (ankle/foot joints to the head joint): 1.496 m for the
    # neutral mean body; the mean male body used before (EDGE's offsets) had 1.575 m
    n, p, o = smpl.tree(True)
    rot = np.zeros((1, 52, 4))
    rot[..., 0] = 1.0
    m = mlayer.Motion.from_arrays(list(n), list(p), o, o[:1].copy(), rot, fps=30)
    assert 1.45 < mlayer.metrics.body_height(m) < 1.55
    pos = m.positions()[0]
    head, feet = m.joint_names.index("Head"), [m.joint_names.index(f"{s}_Foot") for s in "LR"]
    assert pos[feet, 2].min() > pos[head, 2] + 0.05  # the feet point forward (+Z), not back


def test_left_and_right_mirror_each_other():
    # the SMPL template is not exactly symmetric (up to 9.5 mm); a swapped side or an
    # unmirrored axis would be off by centimetres to decimetres
    names, off = smpl.SMPLH_NAMES, smpl.SMPLH_OFFSETS
    pairs = [(j, names.index("R_" + n[2:])) for j, n in enumerate(names) if n.startswith("L_")]
    assert len(pairs) == 23
    for left, right in pairs:
        gap = np.linalg.norm(off[left] - off[right] * [-1.0, 1.0, 1.0])
        assert gap < 0.01, (names[left], gap)
    # +X is the body's left: every left finger joint lies beyond the left wrist, and mirrored
    for side, sign in (("L", 1.0), ("R", -1.0)):
        assert (sign * _hand_relative(off, side)[:, 0] > 0.015).all()


@pytest.mark.parametrize("side", ["L", "R"])
def test_fingers_are_mano_hands_in_smplh_order(side):
    ours = _hand_relative(smpl.SMPLH_OFFSETS, side)
    smplx = np.concatenate([np.zeros((22, 3)), SMPLSIM_NEUTRAL_SMPLX_FINGERS])
    theirs = _hand_relative(smplx, side)
    d = np.linalg.norm(ours[:, None] - theirs[None], axis=-1)
    # each joint within 1 cm of SMPL-X's namesake (8.3 mm at most) and nearest to it
    assert (d.diagonal() < 0.01).all(), d.diagonal()
    assert (d.argmin(axis=1) == np.arange(15)).all()
    # the knuckles across the palm, index in front (+Z) down to the pinky
    knuckles = [smpl.SMPLH_NAMES.index(f"{side}_{f}1") - smpl.SMPLH_NAMES.index(
        f"{side}_Index1") for f in ("Index", "Middle", "Ring", "Pinky")]
    assert np.all(np.diff(ours[knuckles, 2]) < -0.01)


def test_read_amass_puts_the_pelvis_at_trans_plus_its_rest_location(tmp_path):
    F = 5
    rng = np.random.default_rng(24)
    trans = rng.normal(size=(F, 3))
    path = tmp_path / "c.npz"
    with open(path, "wb") as f:
        np.savez(f, poses=rng.normal(0.0, 0.3, (F, 156)), trans=trans,
                 mocap_framerate=np.array(30.0))
    m = mlayer.read_amass(path)
    np.testing.assert_allclose(m.root_pos, trans + smpl.SMPLH_REST_JOINTS[0], rtol=0,
                               atol=1e-15)
    pelvis = m.joint_names.index("Pelvis")
    np.testing.assert_allclose(m.positions()[:, pelvis], m.root_pos, rtol=0, atol=1e-15)
    mlayer.write_amass(m, tmp_path / "back.npz")
    with np.load(tmp_path / "back.npz") as z:
        np.testing.assert_allclose(z["trans"], trans, rtol=0, atol=1e-15)
