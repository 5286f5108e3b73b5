"""Plausibility measures of synthesized motion: knee and elbow angles from the joint positions.

Definitions (used by the limits tests and the benchmark):

flexion      the angle, in degrees, between the thigh vector (hinge joint minus its parent, in
             world space) and the shin vector (the hinge's main child, the child farthest from
             it, or its End Site, minus the hinge joint): 0 = straight, 180 = folded flat.
signed       the same two vectors projected on the plane normal to the hinge axis and measured
             as a signed angle about it; the axis is the one the limits learned from the input
             (mlayer.guards.limits.JointLimits.geometry, in the parent's frame, taken to world
             space by the parent's world rotation), oriented so that the input bends the positive
             way. "Bends the other way" = signed below min(0, the input's smallest signed angle).

The angles come from forward kinematics only (numpy here), independent of the C code that
limits them.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidArgumentError
from ..model import quat as _q
from .limits import JointLimits

if TYPE_CHECKING:
    from ..model.motion import Motion

_LEG_WORDS = ("knee", "leg", "shin", "calf")


def _rotate(q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4), in numpy."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _main_child(motion: Motion, j: int) -> Any:
    sk = motion.skeleton
    t = motion.local_translations().mean(axis=0)
    kids = [c for c in range(sk.n_joints) if sk.parents[c] == j]
    best, blen = None, 0.0
    for c in kids:
        n = float(np.linalg.norm(t[c]))
        if n > blen:
            best, blen = c, n
    return best


def hinge_chains(limits_or_chains: JointLimits | Iterable[Sequence[Any]],
                 motion: Motion | None = None) -> list[tuple[Any, ...]]:
    """The hinges to measure: (parent, joint, child, axis) tuples.

    Parameters
    ----------
    limits_or_chains : JointLimits or iterable of tuples
        The hinges of a JointLimits, or (parent, joint, child[, axis]) tuples.
    motion : Motion, optional
        Needed with a JointLimits, to find the hinges' children.

    Returns
    -------
    list of tuple
        ``(parent, joint, child or ("end", e), axis (3,) or None)``: the axis in the parent's
        frame for a JointLimits, None for triples.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a JointLimits without motion, or tuples of another length.
    """
    if isinstance(limits_or_chains, JointLimits):
        if motion is None:
            raise InvalidArgumentError("motion is needed to find the hinges' children")
        out = []
        for j in limits_or_chains.hinges():
            c = _main_child(motion, j)
            if c is None:
                ends = [e for e, p in enumerate(motion.end_site_parents) if p == j]
                if not ends:
                    continue
                c = ("end", ends[0])
            out.append((int(motion.skeleton.parents[j]), j, c,
                        limits_or_chains.geometry(j)["axis"]))
        return out
    out = []
    for tr in limits_or_chains:
        if len(tr) not in (3, 4):
            raise InvalidArgumentError("chains: expected (parent, joint, child[, axis]) tuples")
        out.append(tuple(tr) if len(tr) == 4 else (*tr, None))
    return out


def hinge_angles(motion: Motion, limits_or_chains: JointLimits | Iterable[Sequence[Any]]
                 ) -> dict[str, dict[str, Any]]:
    """The flexion of every hinge of a motion.

    Parameters
    ----------
    motion : Motion
        The motion.
    limits_or_chains : JointLimits or iterable of tuples
        As for :func:`hinge_chains`.

    Returns
    -------
    dict
        Per hinge joint name: ``{"flexion": (N,) degrees, "signed": (N,) degrees or None,
        "leg": bool}``.
    """
    pos, wrot = motion.forward_kinematics()
    ends = motion.end_site_positions() if len(motion.end_site_parents) else None
    names = motion.joint_names
    out = {}
    for p, j, c, axis in hinge_chains(limits_or_chains, motion):
        thigh = pos[:, j] - pos[:, p]
        if isinstance(c, tuple):
            assert ends is not None  # an End Site child exists only when there are End Sites
            child = ends[:, c[1]]
        else:
            child = pos[:, c]
        shin = child - pos[:, j]
        nt = np.linalg.norm(thigh, axis=1)
        ns = np.linalg.norm(shin, axis=1)
        cosang = np.einsum("ij,ij->i", thigh, shin) / np.maximum(nt * ns, 1e-300)
        flex = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
        signed = None
        if axis is not None and np.linalg.norm(axis) > 0:
            n = _rotate(wrot[:, p], np.broadcast_to(axis, thigh.shape))
            y = np.einsum("ij,ij->i", n, np.cross(thigh, shin))
            x = (np.einsum("ij,ij->i", thigh, shin)
                 - np.einsum("ij,ij->i", thigh, n) * np.einsum("ij,ij->i", shin, n))
            signed = np.degrees(np.arctan2(y, x))
        out[names[j]] = {"flexion": flex, "signed": signed,
                         "leg": any(w in names[j].lower() for w in _LEG_WORDS)}
    return out


def hinge_violations(reference: Motion, synthesized: Motion,
                     limits: JointLimits | Iterable[Sequence[Any]], *,
                     fold_degrees: float = 150.0, fold_margin: float = 10.0
                     ) -> dict[str, Any]:
    """Frames where a synthesized hinge folds or bends the other way beyond the reference.

    "fold": the hinge folds past both ``fold_degrees`` and the reference's largest flexion +
    ``fold_margin``; "reversal": it bends the other way beyond the reference's own (signed
    below min(0, the reference's smallest signed angle)).

    Parameters
    ----------
    reference : Motion
        The input.
    synthesized : Motion
        A synthesis of it, on the same frames.
    limits : JointLimits or iterable of tuples
        The hinges (:func:`hinge_chains`).
    fold_degrees : float, optional
        The fold bound.
    fold_margin : float, optional
        Degrees beyond the reference's flexion.

    Returns
    -------
    dict
        ``fold_frames``, ``reversal_frames``, ``frames`` and ``joints``: per hinge name its
        frames and the largest fold and reversal seen.
    """
    ref = hinge_angles(reference, limits)
    syn = hinge_angles(synthesized, limits)
    n = synthesized.n_frames
    fold_any = np.zeros(n, bool)
    rev_any = np.zeros(n, bool)
    per = {}
    for name, r in ref.items():
        s = syn[name]
        fold_at = max(fold_degrees, float(r["flexion"].max()) + fold_margin)
        fold = s["flexion"] > fold_at
        rev_at = min(0.0, float(r["signed"].min())) if r["signed"] is not None else None
        rev = (s["signed"] < rev_at) if rev_at is not None else np.zeros(n, bool)
        fold_any |= fold
        rev_any |= rev
        per[name] = {"fold_frames": int(fold.sum()), "reversal_frames": int(rev.sum()),
                     "max_flexion": float(s["flexion"].max()),
                     "min_signed": float(s["signed"].min()) if s["signed"] is not None
                     else None, "fold_at": fold_at, "reversal_at": rev_at}
    return {"fold_frames": int(fold_any.sum()), "reversal_frames": int(rev_any.sum()),
            "frames": n, "joints": per}


def body_parts(motion: Motion, limits: JointLimits) -> dict[str, list[int]]:
    """Joint indices per body part.

    Parameters
    ----------
    motion : Motion
        The motion.
    limits : JointLimits
        Its limits (the hinges).

    Returns
    -------
    dict of str to list of int
        ``"legs"`` (each leg hinge's parent and the subtree below it), ``"arms"`` (the same
        for the arm hinges), ``"trunk"`` (the other joints but the root).
    """
    sk = motion.skeleton
    parts: dict[str, set[int]] = {"legs": set(), "arms": set()}
    hinge_info = hinge_angles(motion[:1], limits) if motion.n_frames else {}
    for j in limits.hinges():
        top = int(sk.parents[j])
        part = "legs" if hinge_info.get(sk.joint_names[j], {}).get("leg") else "arms"
        stack = [top]
        while stack:
            k = stack.pop()
            parts[part].add(k)
            stack.extend(c for c in range(sk.n_joints) if sk.parents[c] == k)
    trunk = set(range(1, sk.n_joints)) - parts["legs"] - parts["arms"]
    return {"legs": sorted(parts["legs"]), "arms": sorted(parts["arms"]), "trunk": sorted(trunk)}


def control_amplitude(base_rot: ArrayLike, rot: ArrayLike) -> NDArray[np.float64]:
    """The controllable layer's amplitude as synthesized.

    Parameters
    ----------
    base_rot : array_like, shape (N, J, 4)
        The base layer's rotations.
    rot : array_like, shape (N, J, 4)
        A synthesis's rotations.

    Returns
    -------
    numpy.ndarray, shape (N, J)
        The angle, in radians, of each joint's rotation away from the base layer's:
        ``|log(conj(qb) q)|``.
    """
    d = _q.mul(_q.conj(base_rot), rot)
    w = np.clip(np.abs(d[..., 0]), 0.0, 1.0)
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), w)


def exaggeration_kept(base_rot: ArrayLike, before: ArrayLike, after: ArrayLike,
                      parts: Mapping[str, Sequence[int]]) -> dict[str, float]:
    """How much of the exaggeration the limits kept, per body part.

    Parameters
    ----------
    base_rot : array_like, shape (N, J, 4)
        The base layer's rotations.
    before, after : array_like, shape (N, J, 4)
        The synthesis before and after the limits.
    parts : dict of str to sequence of int
        Joint indices per part (:func:`body_parts`).

    Returns
    -------
    dict of str to float
        RMS of the controllable-layer amplitude after limits / before (1 where it was 0);
        parts without joints are left out.
    """
    a0 = control_amplitude(base_rot, before)
    a1 = control_amplitude(base_rot, after)
    out = {}
    for name, idx in parts.items():
        if not idx:
            continue
        r0 = float(np.sqrt(np.mean(a0[:, idx] ** 2)))
        r1 = float(np.sqrt(np.mean(a1[:, idx] ** 2)))
        out[name] = r1 / r0 if r0 > 0 else 1.0
    return out
