"""The guards' corrections enter and leave smoothly: no foot pops at contact edges.

The measure is the one issue 38 judges by: the largest second difference of any foot point
(joints named foot, toe or ankle) of the output, over the larger of the input's and the
unguarded synthesis's. Before the contact cleanup ramped its offsets in and out (contacts_fix.c,
ramp_runs), a floor frame held next to a touch-down joined the two in one frame: CMU 131_01 at
alpha 0.5 gave 13.2 (the ankle jumped 12% of the body's height in 1/120 s), the AI4Animation dog
5.8, Bandai's walk 4.6, PyMO's optical walk 33.5.
"""
import re
import warnings

import numpy as np
import pytest

import mlayer

from conftest import REPO

FOOT = re.compile(r"(foot|toe|ankle)", re.I)
OFF = dict(limits=False, floor=False, keep_contacts=False)


def _max_accel(m: mlayer.Motion, idx: list[int]) -> float:
    P = np.asarray(m.positions())[:, idx]
    return float(np.linalg.norm(P[2:] - 2 * P[1:-1] + P[:-2], axis=-1).max())


def _pop_ratio(m: mlayer.Motion, alpha: float) -> float:
    feet = [j for j, n in enumerate(m.joint_names) if FOOT.search(n) and "index" not in n.lower()]
    assert feet
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = mlayer.stylize(m, alpha)
        ref = mlayer.stylize(m, alpha, **OFF)
    return _max_accel(out, feet) / max(_max_accel(m, feet), _max_accel(ref, feet))


@pytest.mark.parametrize("name, alpha", [
    ("cmu_131_01_mj_style_walk.bvh", 0.5),  # 13.2 before the ramps
    ("cmu_131_01_mj_style_walk.bvh", 2.0),  # 2.8
    ("ai4a_dog_D1_008_KAN01_002.bvh", 0.5),  # 5.8
    ("bandai1_walk_happy_001.bvh", 0.5),  # 4.6
])
def test_no_foot_pops_on_the_shared_clips(mocap, name, alpha):
    m = mlayer.read_bvh(mocap / name)
    assert _pop_ratio(m, alpha) <= 1.5


def test_no_foot_pop_on_an_optical_walk_in_odd_units():
    m = mlayer.read_bvh(REPO / "tests" / "data" / "wild" / "pymo_av_8walk_meredith_first600.bvh")
    assert _pop_ratio(m, 0.5) <= 1.5  # 33.5 before the ramps


@pytest.mark.parametrize("alpha", [0.5, 2.0, 3.0])
def test_corners_where_guards_meet_are_smoothed(alpha):
    """FAIR's jump (tests/data/wild): the landings' corners, where the contact cleanup, the
    limits and the floor meet, popped the feet 3.8x (alpha 2) and 3.7x (alpha 3) the larger of
    the input's and the synthesis's acceleration; 2.5x and 3.1x with the limits eased
    (limits_ease.c); 2.15x and 2.4x with the corners smoothed (depop.c), and 1.74x at alpha
    0.5. The contact ramps now cross-fade along the reference's motion (the foot meets its run
    with the run's velocity) and the smoothing's hinge clamp is eased in time instead of
    clamping single frames: 0.86x, 1.19x and 1.21x."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = mlayer.read_bvh(REPO / "tests" / "data" / "wild" / "fair1_jumping_zup_first400.bvh")
    assert _pop_ratio(m, alpha) <= 1.5


def test_ramp_limits_fade_in_from_the_contact():
    """A ramp's IK limited in full from its first frame met the contact's own frames (not
    limited in the cleanup's second pass) in a corner where the limited leg could not reach:
    the toes popped 1.53x at alpha 2 at the start of this work, 1.44x with the ramps following
    the reference's motion, 0.84x with the hip's and knee's limits faded in from the contact's
    edge (the ankle's stay in full: faded too, the dog's paw went 1.9 degrees past its range)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = mlayer.read_bvh(REPO / "tests" / "data" / "wild" / "assimp_boxing_toes_first500.bvh")
    assert _pop_ratio(m, 2.0) <= 1.5


def test_a_planted_foot_whose_pin_moves_is_smoothed():
    """PyMO's optical walk at alpha 3: the toe's corner was inside a contact run (the limits and
    the IK moving the pin from frame to frame), where the corners' smoothing (depop.c) left the
    planted chain alone: 2.82x. Its later rounds now smooth the planted limb of a point that
    still pops (its joints up to the thigh; not the hips, which carry the other foot) near the
    pops the first round left (DEPOP_RELEASE): 1.24x."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = mlayer.read_bvh(REPO / "tests" / "data" / "wild"
                            / "pymo_av_8walk_meredith_first600.bvh")
    assert _pop_ratio(m, 3.0) <= 1.5


def _corpus_clip(name: str) -> mlayer.Motion:
    """A clip of the benchmark's corpus (not in the repo: $MLR_TEST_CORPUS_DIR, or corpus
    beside the repo), skipped when absent."""
    import os
    import pathlib
    env = os.environ.get("MLR_TEST_CORPUS_DIR")
    path = (pathlib.Path(env) if env else REPO.parent / "corpus") / name
    if not path.is_file():
        pytest.skip(f"corpus clip not found at {path}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return mlayer.read_bvh(path)


@pytest.mark.parametrize("alpha", [0.5, 2.0, 3.0])
def test_toe_joints_are_not_measured_against_the_toe_tips(alpha):
    """An Xsens capture at 240 fps (toes in contact on every frame): the smoothing measured its
    points (toe and ankle joints, toe tips) against one base, the largest acceleration of any of
    them, which the toe tips set at 8x the joints': the toe joints' corners (1.81x, 2.14x,
    2.65x their own base at alpha 0.5, 2, 3) were under its bar. Joints and End Sites now have
    a base each: 1.10x, 1.04x, 1.13x."""
    assert _pop_ratio(_corpus_clip("ammr_xsens_s02_trial01.bvh"), alpha) <= 1.5


def test_a_smoothing_round_that_makes_a_pop_larger_is_not_kept():
    """Assimp's full boxing clip at alpha 2: the contact cleanup leaves a toe 1.44x its base,
    and with the joints measured against their own base (above) the smoothing acts on it, but
    its rounds made it larger (1.87x kept: the averaged corrections of a foot the floor lifted).
    The rounds' results are compared and the one with the smallest pop kept: 1.44x, as before
    the smoothing. (A guard for the change above: the build before it gave 1.44x too.)"""
    assert _pop_ratio(_corpus_clip("assimp_boxing_toes.bvh"), 2.0) <= 1.5


def test_large_limit_corrections_get_more_smoothing_rounds():
    """A Bandai dance at alpha 3, where the guards move a toe by up to 90% of body height: the
    smoothing's 4 rounds left it 1.55x its base; 6 rounds, 0.82x."""
    assert _pop_ratio(_corpus_clip("bandai1_dance_short_normal_001.bvh"), 3.0) <= 1.5
