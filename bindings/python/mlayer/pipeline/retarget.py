"""Retargeting: a motion of one humanoid rig put onto another (in the C core:
include/mlayer/mlr_retarget.h).

:func:`retarget` moves a clip from one rig to another whose joint names, proportions, rest
pose (T-pose, A-pose, other bone axes) or up axis differ. Each rig's joints get humanoid roles
(:func:`retarget_roles`): the feet, hands and head by name (the side by the Left/Right, _L/_R,
l/r rules of :func:`mlayer.mirror_pairs`), the rest from the tree (the legs and arms up from
the feet and hands, the hips where the legs meet, the spine from the hips to where the arms
meet, the neck from there to the head, the shoulders and toes). Every matched target bone
then points the way the source's bone points in the world (its roll follows the source's
too), whatever the two rest poses are; spine and neck chains of other lengths are spread
along each other; the hips follow the source's, scaled by the ratio of the leg lengths;
joints without a role follow a source joint of the same name or, for the fingers, the same
finger of the same hand (thumb, index, middle, ring, pinky), else keep their rest pose.
"""
from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from .. import _arrays
from .._args import name_pair_items, name_pairs
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..io.amass import read_amass
from ..io.bvh import read_bvh
from ..io.gltf import read_gltf
from ..model._rig import axis, c_rig, motion_axis
from ..model.motion import Motion, Skeleton


__all__ = ["retarget", "retarget_roles", "parse_map", "ROLES"]

#: the role names, in the C core's order (``mlr_role``)
ROLES: tuple[str, ...] = tuple(ffi.string(lib.mlr_role_name(r)).decode()
                               for r in range(lib.MLR_ROLE_COUNT))

#: what ``mapping`` accepts: "auto", {source: target}, (source, target) pairs or "A=B,C=D"
MapArg = str | Mapping[str, str] | Iterable[tuple[str, str]]


def parse_map(text: str) -> list[tuple[str, str]]:
    """A map written ``"SRC=TGT,SRC2=TGT2"`` (the command line's ``--mapping``) as pairs.

    Parameters
    ----------
    text : str
        Comma-separated ``SOURCE=TARGET`` items; spaces around names are dropped.

    Returns
    -------
    list of (str, str)
        The (source joint, target joint) pairs in the order given.

    Raises
    ------
    InvalidArgumentError
        An item without exactly one ``=`` or with an empty name.
    """
    return name_pairs(text, "retarget: map", "SOURCE=TARGET", "a map is written")


def _map_pairs(mapping: MapArg) -> list[tuple[str, str]]:
    if isinstance(mapping, str):
        return [] if mapping == "auto" else parse_map(mapping)
    return name_pair_items(mapping, "retarget: mapping", "source", "target")


def _target_of(target: Any) -> tuple[Skeleton, Motion | None]:
    """(skeleton, motion or None) of a target given as a Skeleton, a Motion or a file."""
    if isinstance(target, Motion):
        return target.skeleton, target
    if isinstance(target, Skeleton):
        return target, None
    if isinstance(target, (str, os.PathLike)):
        path = os.fspath(target)
        low = path.lower()
        if low.endswith((".gltf", ".glb")):
            m = read_gltf(path)
        elif low.endswith(".npz"):
            m = read_amass(path)
        else:
            m = read_bvh(path)
        return m.skeleton, m
    raise InvalidArgumentError("retarget: target must be a mlayer.Skeleton, a Motion or a file "
                               f"path, got {type(target).__name__}")


def retarget_roles(skeleton: Skeleton | Motion) -> dict[str, str]:
    """The humanoid roles of a rig's joints, ``{role: joint name}``; the roles found only.

    Parameters
    ----------
    skeleton : Skeleton or Motion
        The rig.

    Returns
    -------
    dict of str to str
        Role names (:data:`ROLES`: "Hips", "Spine0".., "Neck0".., "Head", "LeftShoulder",
        "LeftUpperArm", "LeftLowerArm", "LeftHand", the right ones, "LeftUpperLeg",
        "LeftLowerLeg", "LeftFoot", "LeftToes", the right ones) to joint names.

    Raises
    ------
    InvalidArgumentError
        A rig that is not a humanoid: without the hips, both legs, both arms with hands or a
        head (the message names the missing role), or with a quadruped's proportions (arms and
        torso as long as the legs; the message names the arms and the ratios).
    """
    sk = skeleton.skeleton if isinstance(skeleton, Motion) else skeleton
    roles = np.empty(lib.MLR_ROLE_COUNT, dtype=np.int32)
    rig, keep = c_rig(sk)
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_retarget_roles(rig, ffi.cast("int32_t *", ffi.from_buffer(roles,
                                                                              require_writable=True)),
                                  ffi.NULL, diag)
    del keep
    check(code, "retarget", diag)
    names = sk.joint_names
    return {ROLES[r]: names[j] for r, j in enumerate(roles.tolist()) if j >= 0}


def retarget(motion: Motion, target: Skeleton | Motion | str | os.PathLike[str], *,
             mapping: MapArg = "auto", feet: bool = True,
             target_up: str | None = None) -> Motion:
    """The motion put onto another humanoid rig.

    Parameters
    ----------
    motion : Motion
        The clip, on the source rig.
    target : Skeleton, Motion or path
        The target rig: a skeleton, a motion (its skeleton; its up axis and units are carried
        over) or a file (BVH, glTF ``.gltf``/``.glb`` or AMASS ``.npz``) whose skeleton is
        taken. Its rest pose is the OFFSETs with identity rotations.
    mapping : "auto", mapping, sequence of (str, str) or str, optional
        "auto" (default): joints matched by their humanoid roles (:func:`retarget_roles`).
        Explicit pairs ``{source_joint: target_joint}`` (or ``"A=B,C=D"``) override: the target
        joint takes the role of the source joint.
    feet : bool, optional
        True (default): the source's foot contacts (:func:`mlayer.detect_contacts` on the
        source's ankles and toes) become the target's and the contact cleanup plants them (the
        same two-bone IK and corrections spread in time as the guards of
        :func:`mlayer.stylize`; C: ``mlr_retarget_feet``): each contact run follows the scaled
        source's ankle and toe trajectories (shifted sideways by the run's mean offset), so the
        feet slide as the source's do and a way back puts them back; knees bend the way the
        target's bend; a target toe joint that no source toe drives keeps its rest pitch
        against the ground on its foot's contact frames (flat, eased in and out within 0.2 s);
        the soles of the contact frames are put together; and, as the guards' last step, the
        whole body is raised smoothly wherever a foot is below the ground (the target's or the
        scaled source's, the higher), also where the source's own foot went below it.
        False: the bones follow the source's exactly.
    target_up : {"x", "y", "z"}, optional
        The target's world up axis. Default: the target motion's :attr:`~mlayer.Motion.up_axis`
        (a Motion or a file), or, for a Skeleton, the up of its rest pose (hips to head); give
        it for a skeleton whose rest pose lies along another axis than the world's up (a bind
        pose along x, as Bandai's). The source's is its ``up_axis``.

    Returns
    -------
    Motion
        A new motion on the target's skeleton with the source's frame time: every matched bone
        points in the world as the source's does, the hips follow the source's scaled by the
        target's leg length over the source's, the fingers follow the source's same fingers,
        the other joints are at rest.

    Raises
    ------
    InvalidArgumentError
        A rig that is not a humanoid (no hips, legs, arms with hands or head, or a quadruped's
        proportions; the message names the rig and the role or the ratios), a map naming a
        joint that is not in its rig or a source joint without a role (named in the message).
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(f"retarget: expected a mlayer.Motion, got "
                                   f"{type(motion).__name__}")
    tsk, tmotion = _target_of(target)
    pairs = _map_pairs(mapping)
    s_up = motion_axis(motion, None, "retarget")
    if target_up is not None:
        t_up = axis(target_up, "retarget: target_up")
    else:
        t_up = motion_axis(tmotion, None, "retarget") if tmotion is not None else -1
    keep_names = [ffi.new("char[]", n.encode("utf-8", errors="surrogateescape"))
                  for p in pairs for n in p]
    c_map = ffi.new("const char *[]", keep_names) if keep_names else ffi.NULL
    sk = motion.skeleton
    root_pos, rot, trans = motion._frames()
    N, Jt, Pt = rot.shape[0], tsk.n_joints, tsk.trans_joints.shape[0]
    out_root = np.empty((N, 3))
    out_rot = np.empty((N, Jt, 4))
    out_trans = np.empty((N, Pt, 3))
    info = ffi.new("mlr_retarget_info *")
    src_rig, keep_s = c_rig(sk)
    dst_rig, keep_t = c_rig(tsk)
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_retarget(src_rig, N, _arrays.ptr(root_pos), _arrays.ptr(rot),
                            _arrays.ptr(trans) if trans.size else ffi.NULL, dst_rig, s_up, t_up,
                            c_map,
                            len(pairs), _arrays.ptr_out(out_root), _arrays.ptr_out(out_rot),
                            _arrays.ptr_out(out_trans) if Pt else ffi.NULL, info, ffi.NULL, diag)
    check(code, "retarget", diag)
    if feet and N >= 3:
        code = lib.mlr_retarget_feet(
            src_rig, N, 1.0 / motion.frame_time, s_up,
            _arrays.ptr(root_pos), _arrays.ptr(rot),
            _arrays.ptr(trans) if trans.size else ffi.NULL, dst_rig, t_up, c_map, len(pairs),
            _arrays.ptr_out(out_root), _arrays.ptr_out(out_rot),
            _arrays.ptr(out_trans) if Pt else ffi.NULL, ffi.NULL, ffi.NULL, diag)
        check(code, "retarget", diag)
    del keep_s, keep_t, keep_names
    out = Motion(tsk, motion.frame_time, out_root, out_rot, out_trans, _trusted=True)
    if tmotion is not None:
        out._same_up(tmotion)
    if t_up >= 0:
        out.up_axis = "xyz"[t_up]
    return out
