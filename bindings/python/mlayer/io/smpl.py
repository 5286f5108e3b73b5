"""The SMPL and SMPL-H joint trees and the rest joint offsets mlayer gives them.

Joint order and parents are the published ones of the SMPL family (Loper et al. 2015, SMPL;
Romero et al. 2017, SMPL-H = SMPL + MANO hands; SMPL-X keeps the same body and hands and adds
jaw and eyes): 22 body joints (SMPL's 24 without ``L_Hand`` and ``R_Hand``, which SMPL-H
replaces by 15 finger joints per hand), then the left hand's and the right hand's fingers.
The template is Y-up, +X the body's left, +Z forward, metres; AMASS's root orientation turns
it Z-up.

Rest joints (:data:`SMPLH_REST_JOINTS`): the joint locations of the gender-neutral SMPL-H
model with zero shape coefficients (betas = 0: the model's ``J_regressor`` applied to its
template; the body is SMPL's neutral body, the hands flat along the arms), as published in
``data_loaders/amasstools/smpl_neutral_nobetas_J.npz`` of github.com/Murrol/StableMotion
(Mu et al., "StableMotion: Training Motion Cleanup Models with Unpaired Corrupted Data",
SIGGRAPH Asia 2025; commit 45d8836ce5cd7ae70f0065fdac672debfdfd6066, the file unchanged since
it was added in 21d44fe8d7830fc0aa5471a0ec71f3a6c60df6e0), under the MIT licence: "Copyright
(c) 2025 Yuxuan Mu. Permission is hereby granted, free of charge, to any person obtaining a
copy of this software [...] The above copyright notice and this permission notice shall be
included in all copies or substantial portions of the Software." (the full notice is in
mlayer's LICENSE). The file holds float32 values; they are written below at their shortest
round-trip decimals. No SMPL model file or code is used: the SMPL models are not
redistributable. (NVIDIA's ProtoMotions ships the same neutral body in its
``smpl_humanoid.xml`` but states that file is not under its Apache-2.0 licence but under the
SMPL model terms; mlayer takes nothing from it.)

How they were checked to be the neutral body with betas = 0: the file's name (the code that
wrote it is not in the repository); its 21 body bones agree to 0.05 mm (the rounding of 4
decimals) with the independently generated ``smpl_sim/data/assets/mjcf/smpl_humanoid.xml`` of
github.com/ZhengyiLuo/SMPLSim (commit b5c08720503ad5fff64050c4d289c42d947fcf8d, BSD 3-Clause
licence, "Copyright (c) 2024, Zhengyi Luo"), which its ``SMPL_Robot`` writes from the neutral
SMPL model with zero betas (its default gender 0), and its pelvis location J[0] with that
file's; and they differ by 6 to 37 mm per bone from the offsets mlayer used before (EDGE's
``smpl_offsets``, which match the mean *male* body), the neutral body about 7 cm shorter from
the ankles to the head joint. Relative to the wrist, the finger joints are within 8.3 mm of
those of the neutral SMPL-X model with zero betas in SMPLSim's ``test.xml`` (same commit and
licence, written by its ``smpl_local_robot.py``; SMPL-X has MANO hands too), each nearest to
its namesake. The SMPL template is not exactly symmetric: a left bone and the mirrored right
one differ by up to 9.5 mm.

Offsets (:data:`SMPLH_OFFSETS`, :data:`SMPL_BODY_OFFSETS`): each joint less its parent; the
pelvis row is its rest location ``J[0]``, so that :func:`mlayer.read_amass` puts the pelvis at
``trans + J[0]`` as the SMPL models do. Pass ``joint_positions`` to :func:`mlayer.read_amass`
for the subject's own body (its ``betas``, its gender).
"""
from __future__ import annotations

import numpy as np

__all__ = ["SMPL_BODY_NAMES", "SMPL_BODY_PARENTS", "SMPLH_NAMES", "SMPLH_PARENTS",
           "SMPLH_REST_JOINTS", "SMPL_BODY_OFFSETS", "SMPLH_OFFSETS", "tree"]

SMPL_BODY_NAMES: tuple[str, ...] = (
    "Pelvis", "L_Hip", "R_Hip", "Spine1", "L_Knee", "R_Knee", "Spine2", "L_Ankle", "R_Ankle",
    "Spine3", "L_Foot", "R_Foot", "Neck", "L_Collar", "R_Collar", "Head", "L_Shoulder",
    "R_Shoulder", "L_Elbow", "R_Elbow", "L_Wrist", "R_Wrist")
"""The 22 body joints of SMPL, SMPL-H and SMPL-X, in the models' order."""

SMPL_BODY_PARENTS: tuple[int, ...] = (
    -1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19)

_FINGERS = ("Index", "Middle", "Pinky", "Ring", "Thumb")  # SMPL-H / MANO order

SMPLH_NAMES: tuple[str, ...] = SMPL_BODY_NAMES + tuple(
    f"{side}_{finger}{k}" for side in ("L", "R") for finger in _FINGERS for k in (1, 2, 3))
"""The 52 joints of SMPL-H (and SMPL-X without jaw and eyes): the body, then 15 finger joints
of the left hand and 15 of the right (index, middle, pinky, ring, thumb; 1 at the palm)."""


def _hand_parents(wrist: int, first: int) -> tuple[int, ...]:
    out = []
    for f in range(5):
        base = first + 3 * f
        out += [wrist, base, base + 1]
    return tuple(out)


SMPLH_PARENTS: tuple[int, ...] = (SMPL_BODY_PARENTS + _hand_parents(20, 22)
                                  + _hand_parents(21, 37))

# StableMotion's smpl_neutral_nobetas_J.npz, "J" (see the module docstring: source, licence,
# checks), in SMPL-H order, template frame, metres
SMPLH_REST_JOINTS = np.array([
    [   -0.00179506,    -0.22333343,    0.028219126],  # Pelvis
    [   0.067724675,    -0.31473967,    0.021403788],  # L_Hip
    [   -0.06946554,     -0.3138551,    0.023899302],  # R_Hip
    [ -0.0043279277,    -0.11437022,   0.0015228116],  # Spine1
    [    0.10200122,     -0.6899383,    0.016907988],  # L_Knee
    [   -0.10775559,     -0.6964241,    0.015049275],  # R_Knee
    [  0.0011591054,    0.020810215,   0.0026152844],  # Spine2
    [    0.08840552,     -1.0878987,   -0.026785344],  # L_Ankle
    [   -0.09198183,     -1.0948389,   -0.027262524],  # R_Ankle
    [   0.002616115,     0.07373245,     0.02803985],  # Spine3
    [    0.11476366,     -1.1436896,    0.092503056],  # L_Foot
    [   -0.11735357,     -1.1429827,     0.09608543],  # R_Foot
    [-0.00016228575,      0.2876028,   -0.014817184],  # Neck
    [    0.08146084,     0.19548175,  -0.0060497527],  # L_Collar
    [  -0.079143085,     0.19256528,   -0.010575429],  # R_Collar
    [   0.004989555,      0.3525724,    0.036531787],  # Head
    [    0.17243777,     0.22595066,   -0.014917907],  # L_Shoulder
    [   -0.17515546,     0.22511646,   -0.019718502],  # R_Shoulder
    [    0.43205002,     0.21317856,    -0.04237434],  # L_Elbow
    [   -0.42889744,     0.21178724,   -0.041119482],  # R_Elbow
    [    0.68128365,     0.22216462,   -0.043545254],  # L_Wrist
    [   -0.68419546,     0.21955952,   -0.046678685],  # R_Wrist
    [     0.7837674,     0.21318334,   -0.022053843],  # L_Index1
    [     0.8155676,     0.21611525,   -0.018787764],  # L_Index2
    [     0.8379634,     0.21438736,   -0.018139567],  # L_Index3
    [     0.7910633,     0.21604961,   -0.044867147],  # L_Middle1
    [     0.8215783,     0.21726954,   -0.048936233],  # L_Middle2
    [     0.8451276,      0.2157849,   -0.052424736],  # L_Middle3
    [    0.76589024,     0.20831612,   -0.084165156],  # L_Pinky1
    [     0.7816927,      0.2079174,   -0.094991595],  # L_Pinky2
    [    0.79757243,     0.20666657,    -0.10512309],  # L_Pinky3
    [     0.7790954,     0.21341538,   -0.067854896],  # L_Ring1
    [    0.80692977,     0.21505947,    -0.07222788],  # L_Ring2
    [     0.8295919,      0.2136715,   -0.078704536],  # L_Ring3
    [    0.72321683,     0.20221838,   -0.017008059],  # L_Thumb1
    [     0.7409179,      0.2039859,    0.007191635],  # L_Thumb2
    [     0.7621495,      0.2003786,     0.02206016],  # L_Thumb3
    [    -0.7834938,      0.2109108,   -0.022043541],  # R_Index1
    [    -0.8156752,     0.21381027,    -0.01967585],  # R_Index2
    [   -0.83797055,     0.21203166,    -0.02005934],  # R_Index3
    [    -0.7913525,     0.21408215,    -0.04589621],  # R_Middle1
    [   -0.82170033,     0.21553564,    -0.05005672],  # R_Middle2
    [   -0.84483737,     0.21410951,   -0.053970776],  # R_Middle3
    [   -0.76722586,     0.20591722,    -0.08604367],  # R_Pinky1
    [    -0.7828581,     0.20559388,   -0.097170174],  # R_Pinky2
    [    -0.7985731,      0.2045548,    -0.10728417],  # R_Pinky3
    [   -0.77998495,     0.21129364,   -0.069580756],  # R_Ring1
    [   -0.80758065,     0.21301551,    -0.07415211],  # R_Ring2
    [   -0.82999915,     0.21162197,   -0.081115544],  # R_Ring3
    [    -0.7220125,     0.19941473,   -0.016552763],  # R_Thumb1
    [    -0.7394514,     0.20024887,   0.0079318015],  # R_Thumb2
    [    -0.7607945,     0.19526307,    0.022366066],  # R_Thumb3
])
SMPLH_REST_JOINTS.setflags(write=False)
"""(52, 3) rest joint locations of the neutral SMPL-H body (betas = 0), in the template frame
(Y-up, +X left, +Z forward), metres, in :data:`SMPLH_NAMES` order."""


def _offsets(joints: np.ndarray, parents: tuple[int, ...]) -> np.ndarray:
    """Each joint less its parent; the root keeps its location."""
    out = joints - joints[np.maximum(np.asarray(parents), 0)]
    out[0] = joints[0]
    out.setflags(write=False)
    return out


SMPLH_OFFSETS = _offsets(SMPLH_REST_JOINTS, SMPLH_PARENTS)
"""(52, 3) rest offsets of the SMPL-H tree (the pelvis row: its rest location), metres."""
SMPL_BODY_OFFSETS = _offsets(SMPLH_REST_JOINTS[:len(SMPL_BODY_NAMES)], SMPL_BODY_PARENTS)
"""(22, 3) rest offsets of the SMPL body tree, the first 22 rows of :data:`SMPLH_OFFSETS`."""


def tree(hands: bool) -> tuple[tuple[str, ...], tuple[int, ...], np.ndarray]:
    """``(names, parents, offsets)`` of the SMPL body tree (22 joints) or, with ``hands``, the
    SMPL-H tree (52), in the models' joint order (not depth-first).

    Parameters
    ----------
    hands : bool
        The 52-joint SMPL-H tree rather than the 22 body joints.

    Returns
    -------
    tuple
        Names, parent indices (-1 for the pelvis) and (J, 3) rest offsets in metres (the
        pelvis row: its rest location in the template).
    """
    if hands:
        return SMPLH_NAMES, SMPLH_PARENTS, SMPLH_OFFSETS
    return SMPL_BODY_NAMES, SMPL_BODY_PARENTS, SMPL_BODY_OFFSETS
