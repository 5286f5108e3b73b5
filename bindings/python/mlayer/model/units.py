"""Length units of clips: the names mlayer knows, and a guess from the body height."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._native import ffi, lib
from ._rig import c_rig
from ..errors import InvalidArgumentError

if TYPE_CHECKING:
    from .motion import Motion

__all__ = ["UNITS", "units_arg", "length_unit", "human_leg_length", "HUMAN_HEIGHT", "HUMAN_LEG"]

#: Length units a clip may be in, and their size in metres (Motion.units, read_bvh(units=)).
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}


def units_arg(units: str | None, where: str) -> str | None:
    """Check a length unit argument.

    Parameters
    ----------
    units : str or None
        One of :data:`UNITS` (any case) or None.
    where : str
        The caller, named in the error.

    Returns
    -------
    str or None
        The unit in lowercase, or None.

    Raises
    ------
    mlayer.InvalidArgumentError
        For any other value.
    """
    if units is None:
        return None
    if isinstance(units, str) and units.lower() in UNITS:
        return units.lower()
    raise InvalidArgumentError(f"{where}: units must be one of {', '.join(UNITS)} or None, got "
                               f"{units!r}")


# Body heights (a person or an animal standing: 0.3 to 2.5 m) in each metric length unit.
_UNIT_RANGES = (("m", 0.3, 2.5), ("cm", 30.0, 250.0), ("mm", 300.0, 2500.0))
#: A person's body height (the joints' extent along up, head End Site excluded, median over
#: frames: 0.9 lets a crouching or sitting clip through) and leg length (hip to knee to ankle,
#: about 0.47 of the stature: 0.58 m for 1.25 m, so a teenager or an adult), in metres: the
#: sizes a unit must give a human rig. Smaller people are left without a guess rather than
#: risk one (AnimatedDrawings' captures, 41 units tall with 22-unit legs, are children's
#: sizes in inches and nothing in any other unit).
HUMAN_HEIGHT = (0.9, 2.3)
HUMAN_LEG = (0.58, 1.2)


def length_unit(height: float, *, leg: float | None = None) -> str | None:
    """A guess at a clip's length unit from its body height in file units.

    Parameters
    ----------
    height : float
        The body height (:func:`mlayer.guards.metrics.body_height`) in the file's units.
    leg : float, optional
        For a human rig, its leg's length (hip to knee to ankle, from the skeleton's offsets)
        in the file's units: then every unit of :data:`UNITS` is tried, and the one that gives
        a person's height (:data:`HUMAN_HEIGHT`) and leg (:data:`HUMAN_LEG`) is the guess, so
        that a clip in inches (Biovision's and PyMO's samples, about 55 units tall) is not
        taken as centimetres. A clip of a lying or sitting person, or at an odd scale, fits
        none and gets None.

    Returns
    -------
    str or None
        Without ``leg``: ``"m"``, ``"cm"`` or ``"mm"`` when the height is one of a person's or
        an animal's (0.3 to 2.5 m) in just that unit, else None (CMU's converted files, about
        24 units for a person, are in none of them). With ``leg``: the one unit of
        :data:`UNITS` that gives a person's size, else None. Never a unit that fits the body
        only together with another.
    """
    if leg is not None:
        found = [u for u, s in UNITS.items()
                 if HUMAN_HEIGHT[0] <= height * s <= HUMAN_HEIGHT[1]
                 and HUMAN_LEG[0] <= leg * s <= HUMAN_LEG[1]]
        return found[0] if len(found) == 1 else None
    found = [u for u, lo, hi in _UNIT_RANGES if lo <= height <= hi]
    return found[0] if len(found) == 1 else None


def human_leg_length(motion: Motion) -> float | None:
    """The leg length (hip to knee to ankle) of a human rig, in its units, else None.

    A rig is human here when the C core finds exactly two feet by name
    (``mlr_contacts_find_feet``, without positions: a quadruped's front paws do not count),
    and it has a joint named head and none named tail. The leg runs from each ankle up through
    two bones of nonzero length (CMU's zero-length hip joints skipped); the mean of the two.

    Parameters
    ----------
    motion : Motion
        The clip (only its skeleton is read).

    Returns
    -------
    float or None
        The leg length in the clip's units; None for a rig that is not human by this rule.
    """
    sk = motion.skeleton
    names = [n.lower() for n in sk.joint_names]
    if not any("head" in n for n in names) or any("tail" in n for n in names):
        return None
    J = len(names)
    rig, keep = c_rig(sk)
    joints = np.empty(2 * J, dtype=np.int32)
    ends = np.empty(2 * J, dtype=np.int32)
    n_feet = ffi.new("size_t *")
    code = lib.mlr_contacts_find_feet(
        rig, 0, ffi.NULL, 1, J, ffi.cast("int32_t *", ffi.from_buffer(joints)),
        ffi.cast("int32_t *", ffi.from_buffer(ends)), n_feet, ffi.NULL, ffi.NULL)
    del keep
    if code != lib.MLR_OK or int(n_feet[0]) != 2:
        return None
    parents = np.asarray(sk.parents)
    offsets = np.asarray(sk.offsets, dtype=float)
    legs = []
    for ankle in joints[0:4:2]:
        j, bones, total = int(ankle), 0, 0.0
        while j > 0 and bones < 2:
            n = float(np.linalg.norm(offsets[j]))
            if n > 0.0:
                total, bones = total + n, bones + 1
            j = int(parents[j])
        if bones == 2:
            legs.append(total)
    return float(np.mean(legs)) if len(legs) == 2 else None
