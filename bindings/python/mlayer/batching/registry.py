"""The table of batch operations: what each operation does to one clip.

An :class:`Operation` names a function ``run(motion, variants, **options)`` that returns one
result per variant (a Motion, written as BVH, or a dict of arrays, written as .npz).
:func:`register_operation` adds one to the table that :func:`mlayer.batch` and ``mlayer batch``
use; :func:`variants` turns ``alphas`` into the variants of one run.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InvalidArgumentError
from ..manifold.features import pose_features
from ..layers.layers import _PARAMS
from ..pipeline.retiming import resample, timewarp

if TYPE_CHECKING:
    from ..model.motion import Motion
    from ..pipeline.pipeline import Clip

__all__ = ["Operation", "register_operation", "operations", "parse_alphas", "variants"]


@dataclasses.dataclass(frozen=True)
class Operation:
    """A batch operation.

    Parameters
    ----------
    name : str
        The name used by :func:`mlayer.batch` and the CLI.
    run : callable
        ``run(motion, variants, **options) -> list`` with one result per variant dict (e.g.
        ``[{"alpha": 1.5}, {"alpha": 2}]``, or ``[{}]``): a Motion (written as BVH) or a dict
        of numpy arrays (written as .npz).
    extension : {".bvh", ".npz"}, optional
        The outputs' extension.
    options : frozenset of str, optional
        The keyword options ``run`` accepts (checked before anything runs).
    uses_alphas : bool, optional
        True when the variants are alphas (stylize): one output per alpha.
    help : str, optional
        One line for the CLI.
    takes_clip : bool, optional
        True when ``run`` takes the input's :class:`mlayer.pipeline.pipeline.Clip` instead of its
        Motion (the built-in operations: the forward kinematics, contacts and layers of the
        input are then computed once for the outputs and the figures).
    """
    name: str
    run: Callable[..., list[Any]]
    extension: str = ".bvh"
    options: frozenset[str] = frozenset()
    uses_alphas: bool = False
    help: str = ""
    takes_clip: bool = False


_OPERATIONS: dict[str, Operation] = {}


def register_operation(op: Operation) -> Operation:
    """Add (or replace) an operation in the table :func:`mlayer.batch` and ``mlayer batch`` use.

    Parameters
    ----------
    op : Operation
        The operation.

    Returns
    -------
    Operation
        ``op``.

    Raises
    ------
    TypeError
        When ``op`` is not an Operation.
    mlayer.InvalidArgumentError
        For an extension other than .bvh or .npz.
    """
    if not isinstance(op, Operation):
        raise TypeError("register_operation: expected a mlayer.batching.Operation")
    if op.extension not in (".bvh", ".npz"):
        raise InvalidArgumentError(f"operation {op.name}: extension must be .bvh or .npz")
    _OPERATIONS[op.name] = op
    return op


def operations() -> dict[str, Operation]:
    """The registered operations.

    Returns
    -------
    dict of str to Operation
        A copy of the table, by name.
    """
    return dict(_OPERATIONS)


def lookup(operation: str | Operation) -> Operation:
    """The operation named `operation` (or `operation` itself when it is an Operation)."""
    op = _OPERATIONS.get(operation) if isinstance(operation, str) else operation
    if not isinstance(op, Operation):
        raise InvalidArgumentError(f"unknown batch operation {operation!r}; available: "
                                   f"{', '.join(sorted(_OPERATIONS))}")
    return op


_LAYER_OPTIONS = frozenset({"gamma", "lam_c", "sigma_c", "lam_b", "sigma_b", "base_cutoff"})


def _op_denoise(clip: Clip, variants: list[dict[str, Any]], keep_contacts: bool = True,
                **options: Any) -> list[Motion]:
    """mlayer.denoise of the input (one synthesis, whatever the number of variants)."""
    out = clip.denoise(keep_contacts=keep_contacts, **options)[0]
    return [out for _ in variants]


def _op_stylize(clip: Clip, variants: list[dict[str, Any]], keep_contacts: bool = True,
                joints: Any = None, root_alpha: float | None = None,
                **options: Any) -> list[Motion]:
    """mlayer.stylize for every alpha, sharing one decomposition and one set of guards
    (mlayer.pipeline.pipeline.Clip.synthesis)."""
    s = clip.synthesis(keep_contacts=keep_contacts, **options)
    return [s.run(v["alpha"], joints, root_alpha=root_alpha)[0] for v in variants]


def _op_features(clip: Clip, variants: list[dict[str, Any]], keep_contacts: bool = True,
                 **options: Any) -> list[dict[str, Any]]:
    """Arrays for machine learning: the input frames, world joint positions, foot contacts,
    every layer and its parameters (as Layers.save_npz), and mlayer.pose_features."""
    del keep_contacts  # accepted for a uniform CLI; nothing is synthesized
    motion = clip.motion
    layers = clip.layers(**options)
    names, contacts = clip.contacts
    arrays = {
        "fps": np.float64(motion.fps), "frame_time": np.float64(motion.frame_time),
        "joint_names": np.array(motion.joint_names), "parents": np.asarray(motion.parents),
        "offsets": np.asarray(motion.offsets), "root_pos": motion.root_pos, "rot": motion.rot,
        "positions": clip.positions, "contacts": contacts,
        "contact_names": np.array(names, dtype=str),
        "base_root_pos": layers.base.root_pos, "base_rot": layers.base.rot,
        "control": layers.control, "residual": layers.residual,
    }
    arrays.update({name: getattr(layers, name) for name in _PARAMS})
    arrays["pose_features"] = np.asarray(pose_features(motion))
    return [arrays for _ in variants]


def _op_resample(clip: Clip, variants: list[dict[str, Any]], keep_contacts: bool = True,
                 **options: Any) -> list[Any]:
    del keep_contacts
    return [resample(clip.motion, **options) for _ in variants]


def _op_timewarp(clip: Clip, variants: list[dict[str, Any]], keep_contacts: bool = True,
                 **options: Any) -> list[Any]:
    del keep_contacts
    return [timewarp(clip.motion, **options) for _ in variants]


register_operation(Operation(
    "denoise", _op_denoise, ".bvh", _LAYER_OPTIONS | {"keep_contacts"},
    help="smooth each clip (mlayer.denoise)", takes_clip=True))
register_operation(Operation(
    "stylize", _op_stylize, ".bvh", _LAYER_OPTIONS | {"keep_contacts", "joints", "root_alpha"},
    uses_alphas=True, help="scale each clip's style, one output per alpha (mlayer.stylize)",
    takes_clip=True))
register_operation(Operation(
    "features", _op_features, ".npz", _LAYER_OPTIONS | {"keep_contacts"},
    help="frames, positions, contacts and layers of each clip as .npz for machine learning",
    takes_clip=True))
register_operation(Operation(
    "resample", _op_resample, ".bvh",
    frozenset({"keep_contacts", "fps", "n_frames", "lam", "sigma", "allow_extreme", "style"}),
    help="resample each clip to a new frame rate or frame count (mlayer.resample)",
    takes_clip=True))
register_operation(Operation(
    "timewarp", _op_timewarp, ".bvh",
    frozenset({"keep_contacts", "strength", "n_frames", "lam", "sigma", "smooth_seconds",
               "root_weight", "allow_extreme", "style"}),
    help="retime each clip along its automatic time map (mlayer.timewarp)", takes_clip=True))


# ---- variants -------------------------------------------------------------------------------

def parse_alphas(spec: str | float | Iterable[Any] | None) -> list[float]:
    """Alphas from a number, a sequence, or a string.

    Parameters
    ----------
    spec : str, float, sequence or None
        A number, a sequence, ``"0.5,1,2"`` or ``"START:STOP:STEP"`` (STOP included when it
        falls on the grid: ``"0.5:2.5:0.5"`` is 0.5, 1, ..., 2.5).

    Returns
    -------
    list of float
        The distinct alphas in order; empty for None.

    Raises
    ------
    mlayer.InvalidArgumentError
        For values that are not finite numbers, a bad range, more than 10000 alphas, or none.
    """
    if spec is None:
        return []
    if isinstance(spec, str):
        s = spec.strip()
        if ":" in s:
            parts = s.split(":")
            if len(parts) != 3:
                raise InvalidArgumentError(f"alphas range must be START:STOP:STEP, got {spec!r}")
            try:
                a, b, step = (float(p) for p in parts)
            except ValueError:
                raise InvalidArgumentError(f"alphas range {spec!r}: not numbers") from None
            if not all(math.isfinite(x) for x in (a, b, step)) or step <= 0 or b < a:
                raise InvalidArgumentError(
                    f"alphas range {spec!r}: needs finite START <= STOP and STEP > 0")
            n = int(math.floor((b - a) / step + 1e-9)) + 1
            if n > 10000:
                raise InvalidArgumentError(f"alphas range {spec!r} gives {n} alphas (> 10000)")
            return [round(a + k * step, 12) for k in range(n)]
        spec = [p for p in s.split(",") if p.strip()]
    if isinstance(spec, (int, float, np.integer, np.floating)):
        spec = [spec]
    out = []
    for v in spec:
        try:
            f = float(v)
        except (TypeError, ValueError):
            raise InvalidArgumentError(f"alpha must be a number, got {v!r}") from None
        if not math.isfinite(f):
            raise InvalidArgumentError(f"alpha must be finite, got {v!r}")
        if f not in out:
            out.append(f)
    if not out:
        raise InvalidArgumentError("alphas: empty")
    return out


def variants(op: Operation, alphas: str | float | Iterable[Any] | None) -> list[dict[str, Any]]:
    """The variants of one run of an operation.

    Parameters
    ----------
    op : Operation
        The operation.
    alphas : str, float, sequence or None
        As for :func:`parse_alphas`; for an operation that uses alphas (default 2).

    Returns
    -------
    list of dict
        One ``{"alpha": a}`` per alpha for an operation that uses alphas, else ``[{}]``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For alphas given to another operation.
    """
    if op.uses_alphas:
        return [{"alpha": a} for a in parse_alphas(2.0 if alphas is None else alphas)]
    if alphas is not None:
        raise InvalidArgumentError(f"batch {op.name}: alphas apply to stylize only")
    return [{}]


def variant_tag(variant: dict[str, Any]) -> str:
    """What a variant adds to an output's name: "_alpha1.5" for {"alpha": 1.5}."""
    return "".join(f"_{k}{v:g}" if isinstance(v, float) else f"_{k}{v}"
                   for k, v in variant.items())
