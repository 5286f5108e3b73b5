"""The up axis of a motion: which world axis points up, detected from the motion itself.

BVH has no field for it. Most files are Y-up; Blender, 3ds Max and many video pose estimators
write Z-up files. The C core decides (``mlr_rig_up_axis``, include/mlayer/mlr_rig.h):

- with joints named foot / ankle / toe / paw / hoof, up is opposite the mean offset of those
  joints from the hips they hang from (their grandparents): a leg points down, on bipeds and
  quadrupeds alike, whatever the torso does;
- without such names, the floor is the side along which the lowest joint keeps one height
  while the others move.

``confidence`` is in [0, 1]; from :data:`SURE` (0.8) on, :attr:`Motion.up_axis` follows the
guess, below it stays ``"y"`` (the BVH convention) and ``mlayer info`` says it is unsure.
``read_bvh(path, up="z")`` (``--up z`` on the command line) overrides the detection.
"""
from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from .. import _arrays
from .._native import ffi, lib
from ._rig import c_rig
from ..errors import InvalidArgumentError, check

if TYPE_CHECKING:
    from .motion import Motion

__all__ = ["UpGuess", "detect_up", "SURE"]

SURE = 0.8  # MLR_RIG_UP_SURE (a macro: cffi sees no macros)

_METHODS = {0: "none", 1: "feet", 2: "floor"}

# The default up axis of clips read while the CLI's --up is given (None: detect).
_UP: contextvars.ContextVar[str | None] = contextvars.ContextVar("mlayer_up", default=None)


class UpGuess(NamedTuple):
    """What :func:`detect_up` found.

    Attributes
    ----------
    axis : str
        ``"x"``, ``"y"`` or ``"z"``.
    sign : int
        +1 (up is +axis) or -1 (the clip stands upside down along it).
    confidence : float
        In [0, 1].
    method : str
        ``"feet"``, ``"floor"`` or ``"none"`` (no frames or no extent: ``"y"`` assumed).
    """
    axis: str
    sign: int
    confidence: float
    method: str

    @property
    def sure(self) -> bool:
        """Whether the guess can be trusted, found by a method with confidence >= :data:`SURE`."""
        return self.method != "none" and self.confidence >= SURE


def detect_up(motion: Motion, positions: ArrayLike | None = None) -> UpGuess:
    """The up axis of a motion from its world positions.

    Parameters
    ----------
    motion : Motion
        The motion.
    positions : array_like, shape (N, J, 3), optional
        Its world positions (computed when not given).

    Returns
    -------
    UpGuess
        The axis, its sign, the confidence and the method.

    Raises
    ------
    mlayer.InvalidArgumentError
        For positions of another shape.
    """
    sk = motion.skeleton
    if positions is None:
        positions = motion.positions()
    pos = np.ascontiguousarray(positions, dtype=np.float64)
    if pos.ndim != 3 or pos.shape[1:] != (sk.n_joints, 3):
        raise InvalidArgumentError(f"detect_up: positions must be (N, {sk.n_joints}, 3), got "
                                   f"{pos.shape}")
    rig, keep = c_rig(sk)
    g = ffi.new("mlr_up_guess *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_rig_up_axis(rig, pos.shape[0], _arrays.ptr(pos), g, ffi.NULL, diag),
          "detect_up", diag)
    del keep
    return UpGuess("xyz"[g.axis], int(g.sign), float(g.confidence), _METHODS[int(g.method)])


def axis_name(up: str | int | None, where: str) -> str | None:
    """An up axis argument ("x", "y", "z" in any case, 0..2, or None) as "x" / "y" / "z" or
    None."""
    if up is None:
        return None
    if isinstance(up, str) and up.lower() in ("x", "y", "z"):
        return up.lower()
    if isinstance(up, (int, np.integer)) and not isinstance(up, bool) and 0 <= int(up) <= 2:
        return "xyz"[int(up)]
    raise InvalidArgumentError(f"{where}: up must be 'x', 'y', 'z' (or 0..2, or None to detect "
                               f"it), got {up!r}")


# Scalar-first unit quaternions of the proper rotations that take each up axis to +Y:
# X-up: +90 degrees about Z (X -> Y); Z-up: -90 degrees about X (Z -> Y).
_H = float(np.sqrt(0.5))
_TO_Y_UP = {"x": np.array([_H, 0.0, 0.0, _H]), "y": np.array([1.0, 0.0, 0.0, 0.0]),
            "z": np.array([_H, -_H, 0.0, 0.0])}


def to_y_up(up: str, positions: ArrayLike | None = None,
            world_rot: ArrayLike | None = None) -> Any:
    """World positions (..., 3) and world rotations (..., 4) of a clip whose up axis is ``up``,
    turned so that up is +Y (a proper rotation: the clip is not mirrored); None passes through.
    The features, the renderer and the primitives' heading work in this frame."""
    q = _TO_Y_UP[axis_name(up, "to_y_up") or "y"]
    out = []
    if positions is not None:
        p = np.asarray(positions, dtype=np.float64)
        if up == "x":
            p = np.stack([-p[..., 1], p[..., 0], p[..., 2]], axis=-1)
        elif up == "z":
            p = np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)
        out.append(p)
    if world_rot is not None:
        r = np.asarray(world_rot, dtype=np.float64)
        if up != "y":
            w, x, y, z = q
            a, b, c, d = r[..., 0], r[..., 1], r[..., 2], r[..., 3]
            r = np.stack([w * a - x * b - y * c - z * d, w * b + x * a + y * d - z * c,
                          w * c - x * d + y * a + z * b, w * d + x * c - y * b + z * a], axis=-1)
        out.append(r)
    return out[0] if len(out) == 1 else tuple(out)


@contextlib.contextmanager
def reading_up(up: str | int | None) -> Iterator[None]:
    """Within the block, clips read with ``read_bvh(..., up=None)`` get this up axis (None:
    detected); the CLI's ``--up`` uses it."""
    token = _UP.set(axis_name(up, "--up"))
    try:
        yield
    finally:
        _UP.reset(token)


def default_up() -> str | None:
    """The up axis a clip read now gets when none is given (None: detect)."""
    return _UP.get()
