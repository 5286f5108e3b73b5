"""The SMPL and SMPL-H joint trees and the rest joint offsets mlayer gives them.

Joint order and parents are the published ones of the SMPL family (Loper et al. 2015, SMPL;
Romero et al. 2017, SMPL-H = SMPL + MANO hands; SMPL-X keeps the same body and hands and adds
jaw and eyes): 22 body joints (SMPL's 24 without ``L_Hand`` and ``R_Hand``, which SMPL-H
replaces by 15 finger joints per hand), then the left hand's and the right hand's fingers.
The template is Y-up, +X the body's left, +Z forward, metres; AMASS's root orientation turns
it Z-up.

Rest offsets (each joint relative to its parent in the template, metres). The SMPL model
files are not redistributable, and neither is a J_regressor applied to their template, so
the offsets come from published code instead:

- the 21 body bones are ``smpl_offsets`` of EDGE (Tseng, Castellon and Liu, "EDGE: Editable
  Dance Generation From Music", CVPR 2023), file ``vis.py`` of github.com/Stanford-TML/EDGE
  (commit 17c3428669ed6733edd9d8c66f7dc62060b8e46d), under the MIT licence: "Copyright (c)
  2023 Jonathan Tseng. Permission is hereby granted, free of charge, to any person obtaining
  a copy of this software [...] The above copyright notice and this permission notice shall
  be included in all copies or substantial portions of the Software." EDGE does not say
  which SMPL model (neutral, male, female) they were taken from; they agree to 0.3 mm with
  the ``m_avg_*`` bones of the SMPL rig for Unity (x mirrored; hips to feet, as quoted in
  other projects), i.e. most likely the mean *male* body (betas 0), not the gender-neutral
  model. Like EDGE, the pelvis sits at ``trans`` (its rest location is taken as the origin):
  the SMPL models put it at ``trans + J[0]``, J[0] about 0.22 m from the origin, mostly
  along the template's -Y (the models' ``J`` as quoted in GPL-licensed code, not copied
  here). Pass ``joint_positions`` to :func:`mlayer.read_amass` for an exact body.
- the 30 finger joints of SMPL-H have no permissively licensed published source that was
  found. They are derived here (:func:`_hand_offsets`) from a documented alternative: the
  finger segment lengths as fractions of hand length of Buchholz, Armstrong and Goldstein,
  "Anthropometric data for describing the kinematics of the human hand", Ergonomics 35(3),
  1992 (the commonly quoted table), for a hand of 0.19 m (about 11% of a 1.7 m stature), the
  palm down and the fingers straight along the arm as in the SMPL-H T-pose, the knuckles
  spread across a 6 cm palm. They are an approximation, not checked against the SMPL-H
  model; pass ``joint_positions`` for the subject's hands.
"""
from __future__ import annotations

import numpy as np

__all__ = ["SMPL_BODY_NAMES", "SMPL_BODY_PARENTS", "SMPLH_NAMES", "SMPLH_PARENTS",
           "SMPL_BODY_OFFSETS", "SMPLH_OFFSETS", "tree"]

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

# EDGE vis.py smpl_offsets[0:22] (see the module docstring: source, licence, which body)
SMPL_BODY_OFFSETS = np.array([
    [0.0, 0.0, 0.0],
    [0.05858135, -0.08228004, -0.01766408],
    [-0.06030973, -0.09051332, -0.01354254],
    [0.00443945, 0.12440352, -0.03838522],
    [0.04345142, -0.38646945, 0.008037],
    [-0.04325663, -0.38368791, -0.00484304],
    [0.00448844, 0.1379564, 0.02682033],
    [-0.01479032, -0.42687458, -0.037428],
    [0.01905555, -0.4200455, -0.03456167],
    [-0.00226458, 0.05603239, 0.00285505],
    [0.04105436, -0.06028581, 0.12204243],
    [-0.03483987, -0.06210566, 0.13032329],
    [-0.0133902, 0.21163553, -0.03346758],
    [0.07170245, 0.11399969, -0.01889817],
    [-0.08295366, 0.11247234, -0.02370739],
    [0.01011321, 0.08893734, 0.05040987],
    [0.12292141, 0.04520509, -0.019046],
    [-0.11322832, 0.04685326, -0.00847207],
    [0.2553319, -0.01564902, -0.02294649],
    [-0.26012748, -0.01436928, -0.03126873],
    [0.26570925, 0.01269811, -0.00737473],
    [-0.26910836, 0.00679372, -0.00602676],
])
SMPL_BODY_OFFSETS.setflags(write=False)

_HAND_LENGTH = 0.19  # metres, wrist crease to the middle fingertip
# Buchholz et al. 1992: segment lengths / hand length (metacarpal, proximal, middle, distal
# phalanx; the thumb's metacarpal, proximal and distal phalanx)
_SEGMENTS = {"Index": (0.374, 0.245, 0.143, 0.097), "Middle": (0.373, 0.266, 0.170, 0.108),
             "Pinky": (0.295, 0.204, 0.117, 0.093), "Ring": (0.336, 0.244, 0.165, 0.107),
             "Thumb": (0.251, 0.196, 0.158)}
# where the metacarpals end across the palm (+Z: the thumb side of the left hand, palm down)
_SPREAD = {"Index": 0.024, "Middle": 0.004, "Ring": -0.015, "Pinky": -0.032}


def _hand_offsets(sign: float) -> np.ndarray:
    """(15, 3) offsets of one hand's finger joints in SMPL-H order; sign +1 the left hand
    (fingers along +X), -1 the right (the mirror image in x)."""
    h = _HAND_LENGTH
    rows = []
    for finger in _FINGERS:
        seg = _SEGMENTS[finger]
        if finger == "Thumb":
            # the thumb's carpometacarpal joint near the wrist, the thumb pointing forward and
            # out at 45 degrees in the plane of the palm
            d = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)
            rows.append([0.02, -0.008, 0.018])
            rows += [list(seg[0] * h * d), list(seg[1] * h * d)]
        else:
            rows.append([seg[0] * h, -0.005, _SPREAD[finger]])
            rows += [[seg[1] * h, 0.0, 0.0], [seg[2] * h, 0.0, 0.0]]
    out = np.array(rows)
    out[:, 0] *= sign
    return out


SMPLH_OFFSETS = np.concatenate([SMPL_BODY_OFFSETS, _hand_offsets(1.0), _hand_offsets(-1.0)])
SMPLH_OFFSETS.setflags(write=False)


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
        Names, parent indices (-1 for the pelvis) and (J, 3) rest offsets in metres.
    """
    if hands:
        return SMPLH_NAMES, SMPLH_PARENTS, SMPLH_OFFSETS
    return SMPL_BODY_NAMES, SMPL_BODY_PARENTS, SMPL_BODY_OFFSETS
