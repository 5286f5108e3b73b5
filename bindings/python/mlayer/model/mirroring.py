"""Left/right mirroring of a motion (in the C core: include/mlayer/mlr_mirror.h).

:func:`mirror` reflects a motion across the body's sagittal plane and swaps its left and right
joints: the mirrored clip of a right-foot kick is a left-foot kick. The joint pairs are found by
name (:func:`mirror_pairs`: Left/Right, left/right, L/R and l/r prefixes and suffixes with
separators, ``_l``/``_r``, ``.L``/``.R``, CMU's ``LHipJoint``/``RHipJoint``, Daz's
``lShldr``/``rShldr``, MakeHuman's ``lcollar``/``rcollar``, Mixamo's ``mixamorig:LeftArm``);
joints without a partner are on the mid-plane. The plane is normal to a world axis: by default
the body's left-right axis, the axis along which the paired joints' rest positions differ most.

Rotations are reflected (for a reflection M, a rotation R becomes M R M: in quaternions, w and
the component along the plane's normal are kept, the other two negated), translations have
their component along the normal negated, and joint j of the result takes the mirrored data of
its partner. By default the skeleton's OFFSETs are mirrored and swapped too, so that the result
is the exact mirror image (its positions are the reflected positions of the input, left and
right swapped); real skeletons are not symmetric, so with ``keep_skeleton=True`` the input's
OFFSETs are kept and only the motion is mirrored (per-frame translations, the root's and the
position channels', are motion and are mirrored either way). Mirroring twice gives the input
back exactly (only signs and joint order change).
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from .. import _arrays
from .._args import name_pair_items, name_pairs
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ._rig import c_rig
from .motion import Motion, Skeleton


__all__ = ["mirror", "mirror_pairs", "mirror_plane", "parse_pairs"]

#: what ``pairs`` accepts: "auto", a mapping {left: right}, (a, b) pairs, or "A=B,C=D"
PairsArg = str | Mapping[str, str] | Iterable[tuple[str, str]]

_PLANES = {"auto": -1, "x": 0, "y": 1, "z": 2}


def parse_pairs(text: str) -> list[tuple[str, str]]:
    """Pairs written as ``"A=B,C=D"`` (the command line's ``--pairs``), as (a, b) tuples.

    Parameters
    ----------
    text : str
        Comma-separated ``A=B`` items; spaces around names are dropped.

    Returns
    -------
    list of (str, str)
        The pairs in the order given.

    Raises
    ------
    InvalidArgumentError
        An item without exactly one ``=`` or with an empty name.
    """
    return name_pairs(text, "mirror: pairs", "NAME=NAME", "pairs are written")


def _given_pairs(pairs: PairsArg) -> list[tuple[str, str]]:
    if isinstance(pairs, str):
        return parse_pairs(pairs)
    return name_pair_items(pairs, "mirror: pairs", "left", "right")



def _partner(skeleton: Skeleton, pairs: PairsArg, by_name: bool) -> tuple[np.ndarray,
                                                                            np.ndarray]:
    """(partner, side) of every joint by the C core (mlr_mirror_pairs)."""
    J = skeleton.n_joints
    given = [] if (isinstance(pairs, str) and pairs == "auto") else _given_pairs(pairs)
    keep = [ffi.new("char[]", n.encode("utf-8", errors="surrogateescape"))
            for p in given for n in p]
    c_given = ffi.new("const char *[]", keep) if keep else ffi.NULL
    partner = np.empty(J, dtype=np.int32)
    side = np.empty(J, dtype=np.int8)
    n_pairs = ffi.new("size_t *")
    diag = ffi.new("mlr_diag *")
    rig, keep_rig = c_rig(skeleton)
    code = lib.mlr_mirror_pairs(
        rig, c_given, len(given), 0 if by_name else lib.MLR_MIRROR_GIVEN_ONLY,
        ffi.cast("int32_t *", ffi.from_buffer(partner, require_writable=True)),
        ffi.cast("int8_t *", ffi.from_buffer(side, require_writable=True)), n_pairs, ffi.NULL,
        diag)
    del keep_rig, keep
    check(code, "mirror", diag)
    return partner, side


def _skeleton_of(obj: Any, where: str) -> Skeleton:
    if isinstance(obj, Motion):
        return obj.skeleton
    if isinstance(obj, Skeleton):
        return obj
    raise InvalidArgumentError(f"{where}: expected a mlayer.Motion or Skeleton, got "
                               f"{type(obj).__name__}")


def mirror_pairs(motion: Motion | Skeleton, pairs: PairsArg = "auto", *,
                 by_name: bool = True) -> list[tuple[str, str]]:
    """The left/right joint pairs :func:`mirror` uses, as (left, right) names.

    Parameters
    ----------
    motion : Motion or Skeleton
        The skeleton to pair.
    pairs : "auto", mapping, sequence of (str, str) or str, optional
        "auto" (default): by name. Explicit pairs (``{"LeftHand": "RightHand"}``,
        ``[("a", "b")]`` or ``"A=B,C=D"``) override the pairs found by name for the joints
        they name.
    by_name : bool, optional
        Find the joints no explicit pair names by name (default True); False: only the
        explicit pairs.

    Returns
    -------
    list of (str, str)
        One entry per pair, in joint order of its first joint; the left joint first where the
        names tell the side.

    Raises
    ------
    InvalidArgumentError
        A name that is no joint (named in the message), a pair naming one joint twice, a joint
        in two pairs, or pairs that do not map the hierarchy onto itself.
    """
    sk = _skeleton_of(motion, "mirror_pairs")
    partner, side = _partner(sk, pairs, by_name)
    names = sk.joint_names
    out = []
    for j, k in enumerate(partner.tolist()):
        if k > j:
            out.append((names[k], names[j]) if side[j] < 0 else (names[j], names[k]))
    return out


def _plane_arg(plane: Any) -> int:
    key = plane.lower() if isinstance(plane, str) else plane
    if key not in _PLANES:
        raise InvalidArgumentError(f"mirror: plane must be 'auto', 'x', 'y' or 'z', got "
                                   f"{plane!r}")
    return _PLANES[key]


def mirror_plane(motion: Motion | Skeleton, pairs: PairsArg = "auto", *,
                 by_name: bool = True) -> str:
    """The axis normal to the mirror plane that ``plane="auto"`` picks: "x", "y" or "z".

    Parameters
    ----------
    motion : Motion or Skeleton
        The skeleton.
    pairs, by_name
        As for :func:`mirror_pairs`.

    Returns
    -------
    str
        The axis along which the paired joints' rest positions (OFFSETs summed from the root)
        differ most: the body's left-right axis.

    Raises
    ------
    InvalidArgumentError
        No pairs, or pairs whose rest positions coincide.
    """
    sk = _skeleton_of(motion, "mirror_plane")
    partner, _ = _partner(sk, pairs, by_name)
    return "xyz"[_c_plane(sk, partner, -1)]


def _c_plane(sk: Skeleton, partner: np.ndarray, plane: int) -> int:
    rig, keep = c_rig(sk)
    ax = ffi.new("int *")
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_mirror_plane(rig, ffi.cast("const int32_t *", ffi.from_buffer(partner)), plane,
                                ax, diag)
    del keep
    check(code, "mirror", diag)
    return int(ax[0])


def mirror(motion: Motion, *, plane: str = "auto", pairs: PairsArg = "auto",
           keep_skeleton: bool = False, by_name: bool = True) -> Motion:
    """The motion mirrored across the body's sagittal plane, left and right swapped.

    Parameters
    ----------
    motion : Motion
        The clip.
    plane : {"auto", "x", "y", "z"}, optional
        The axis normal to the mirror plane (through the origin); "auto" (default): the body's
        left-right axis (:func:`mirror_plane`).
    pairs : "auto", mapping, sequence of (str, str) or str, optional
        The left/right joint pairs (:func:`mirror_pairs`): "auto" by name, or explicit pairs
        that override those found by name for the joints they name.
    keep_skeleton : bool, optional
        False (default): the OFFSETs and End Sites are mirrored and swapped as well, the result
        is the exact mirror image. True: the input's skeleton is kept and only the motion is
        mirrored (the rotations of the swapped joints drive the other side's bones).
    by_name : bool, optional
        With explicit pairs: also pair the other joints by name (default True).

    Returns
    -------
    Motion
        A new motion with the same joint names, parents and channels (and up axis and units).

    Raises
    ------
    InvalidArgumentError
        A bad plane (the message names ``plane``), an unknown joint in ``pairs``, a pair
        naming one joint twice, pairs that break the hierarchy, or "auto" with no pairs.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"mirror: expected a mlayer.Motion, got "
                                   f"{type(motion).__name__}")
    if not isinstance(keep_skeleton, bool):
        raise InvalidArgumentError(f"mirror: keep_skeleton must be True or False, got "
                                   f"{keep_skeleton!r}")
    plane_c = _plane_arg(plane)
    sk = motion.skeleton
    root_pos, rot, trans = motion._frames()
    partner, _ = _partner(sk, pairs, by_name)
    ax = _c_plane(sk, partner, plane_c)
    N, J, E = rot.shape[0], sk.n_joints, sk.n_end_sites
    out_root, out_rot, out_trans = np.empty_like(root_pos), np.empty_like(rot), \
        np.empty_like(trans)
    offsets, end_offsets = np.empty((J, 3)), np.empty((E, 3))
    rig, keep = c_rig(sk)
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_mirror_motion(
        rig, ffi.cast("const int32_t *", ffi.from_buffer(partner)), ax,
        lib.MLR_MIRROR_KEEP_SKELETON if keep_skeleton else 0, N, _arrays.ptr(root_pos),
        _arrays.ptr(rot), _arrays.ptr(trans), _arrays.ptr_out(out_root), _arrays.ptr_out(out_rot),
        _arrays.ptr_out(out_trans), _arrays.ptr_out(offsets), _arrays.ptr_out(end_offsets), diag)
    del keep
    check(code, "mirror", diag)
    if keep_skeleton:
        new_sk = sk
    else:
        new_sk = Skeleton(sk.joint_names, sk.parents, offsets, sk.channels, sk.end_site_parents,
                          end_offsets)
    return Motion(new_sk, motion.frame_time, out_root, out_rot, out_trans,
                  _trusted=True)._same_up(motion)
