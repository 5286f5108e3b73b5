"""Length units of clips: the names mlayer knows, and a guess from the body height."""
from __future__ import annotations

from .errors import InvalidArgumentError

__all__ = ["UNITS", "units_arg", "length_unit"]

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


# Body heights (a person or an animal standing: 0.3 to 2.5 m) in each length unit.
_UNIT_RANGES = (("m", 0.3, 2.5), ("cm", 30.0, 250.0), ("mm", 300.0, 2500.0))


def length_unit(height: float) -> str | None:
    """A guess at a clip's length unit from its body height in file units.

    Parameters
    ----------
    height : float
        The body height (:func:`mlayer.metrics.body_height`) in the file's units.

    Returns
    -------
    str or None
        ``"m"``, ``"cm"`` or ``"mm"`` when the height is one of a person's or an animal's (0.3
        to 2.5 m) in just that unit, else None (CMU's converted files, about 24 units for a
        person, are in none of them).
    """
    found = [u for u, lo, hi in _UNIT_RANGES if lo <= height <= hi]
    return found[0] if len(found) == 1 else None
