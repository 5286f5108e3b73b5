"""A skeleton as the C core's ``mlr_rig``: borrowed pointers into the Skeleton's arrays.

The skeleton and motion arguments are typed ``Any``: :mod:`mlayer.model.motion` imports this
module, and an import back (even for types only) would be an import circle (test_import_graph).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .. import _arrays
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check


def c_rig(skeleton: Any) -> tuple[Any, tuple[Any, ...]]:
    """``(rig, keep)``: an ``mlr_rig *`` over the skeleton's names, parents, offsets, trans
    joints and End Sites, and the objects that must stay referenced while it is used."""
    names = [ffi.new("char[]", n.encode("utf-8", errors="surrogateescape"))
             for n in skeleton.joint_names]
    cnames = ffi.new("const char *[]", names)
    parents = np.ascontiguousarray(skeleton.parents, dtype=np.int32)
    offsets = np.ascontiguousarray(skeleton.offsets, dtype=np.float64)
    trans = np.ascontiguousarray(skeleton.trans_joints, dtype=np.int32)
    ends = np.ascontiguousarray(skeleton.end_site_parents, dtype=np.int32)
    end_off = np.ascontiguousarray(skeleton.end_site_offsets, dtype=np.float64).reshape(-1, 3)
    r = ffi.new("mlr_rig *")
    r.n_joints = parents.shape[0]
    r.parents = ffi.cast("const int32_t *", ffi.from_buffer(parents))
    r.offsets = ffi.cast("const double *", ffi.from_buffer(offsets))
    r.names = cnames
    r.n_trans = trans.shape[0]
    r.trans_joints = ffi.cast("const int32_t *", ffi.from_buffer(trans)) if trans.size \
        else ffi.NULL
    r.n_end_sites = ends.shape[0]
    if ends.size:
        r.end_site_parents = ffi.cast("const int32_t *", ffi.from_buffer(ends))
        r.end_site_offsets = ffi.cast("const double *", ffi.from_buffer(end_off))
    return r, (names, cnames, parents, offsets, trans, ends, end_off)


def motion_axis(motion: Any, up: str | int | None, where: str) -> int:
    """The up axis argument ``up`` as 0..2; None: the motion's own (:attr:`Motion.up_axis`,
    given when it was read or detected)."""
    return axis(motion.up_axis if up is None else up, where)


def axis(up: str | int | None, where: str) -> int:
    """An up axis given as "x", "y", "z" (any case) or 0, 1, 2."""
    if isinstance(up, str) and up.lower() in ("x", "y", "z"):
        return "xyz".index(up.lower())
    if isinstance(up, (int, np.integer)) and not isinstance(up, bool) and 0 <= int(up) <= 2:
        return int(up)
    raise InvalidArgumentError(f"{where}: up must be 'x', 'y', 'z' or 0..2, got {up!r}")



def body_height_of(positions: ArrayLike, k: int) -> float:
    """The C core's body size (mlr_rig_body_height, the one every C threshold uses) of (N, J, 3)
    world positions along axis k (0..2): the median over frames of the joints' extent."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    if p.shape[0] == 0:
        raise InvalidArgumentError("body_height needs at least one frame")
    h = ffi.new("double *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_rig_body_height(p.shape[0], p.shape[1], _arrays.ptr(p), k, h, ffi.NULL, diag),
          "body_height", diag)
    return float(h[0])
