"""The synthesis pipeline: decompose once, synthesize, then make the result plausible.

The composition of the layers (:mod:`mlayer.layers.layers`) with the plausibility guards of the C
core (``mlr_guards.h``: joint limits, foot contacts, the floor) lives in the C core's job
object, ``mlr_pipeline`` (``mlr_pipeline.h``): the decomposition's options, the repaired input
the guards learn from, the guards' options, the synthesis with the body translation where it
rides and ``mlr_guards_apply_trans``. :func:`stylize` and :func:`denoise`, the command line,
batch runs and the viewer all go through :class:`Synthesis`, a thin caller of it, so they give
the same motion, and the same motion as a game runtime that calls ``mlr_pipeline_run``.
What stays here, on top of the C result: the arguments' Python forms (``"auto"``, globs in a
dict, JointLimits objects, contact points by name, set on the pipeline's guards), the
:class:`GuardReport` with joint names, the viewer's synthesis with the residual kept
(``run(residual=True)``: the layers synthesized here, then :meth:`Synthesis.guard`), and the
:class:`Clip`'s figures.

What runs, in order, on ``M' = Mb (+) alpha delta_c``:

1. joint limits, when some ``|alpha| > 1`` (``limits="auto"``): knees and elbows never bend the
   other way beyond the input's own and never fold past 150 degrees (or the input's largest
   angle); other joints stay within published human ranges of motion (human rigs) or within
   the input's range widened by alpha (a dog); a soft saturation, so the motion stays smooth;
2. the foot contacts of the input (detected once, on the input) pinned by two-bone IK, the feet
   following the input's trajectories (smoothed over 0.02 s), or keeping their own where those
   slide less, with the corrections blended in time;
3. the floor of the input's contacts: no foot point goes below it where the input's did not
   (IK on the legs; where the limited legs cannot keep a foot up, the whole body rises).

Each :class:`Synthesis` holds one input's decomposition and guards, so a
second alpha (a slider move, an augmentation sweep) costs a synthesis and the guards only.

A run from file to file (the command line, batch workers, the viewer) holds its input in a
:class:`Clip`: read (with the reading options: strict, up, trim, units), then what every later
step needs from the input is computed once there: its forward kinematics, up axis and body
height, its layers and guards (one :class:`Synthesis` per set of options), its jitter and the
foot sliding of its contacts; outputs are written with :meth:`Clip.write`. One ``mlayer
stylize`` run does two forward-kinematics passes over the input (this module's and the C
guards' own, which take frames, not positions) and one over the output for its figures
(``bench/python/bench_pipeline_passes.py`` counts them).
"""
from __future__ import annotations

import functools
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, NoReturn, SupportsIndex, cast, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays, _attrs
from .._handles import ReadOnlyAttributes, refuse_copy
from .._native import ffi, lib
from ..errors import InvalidArgumentError, MlayerWarning, check
from ..guards.contacts import _point, detect_contacts, find_feet
from ..guards.limits import JointLimits
from ..guards.metrics import body_height, foot_sliding, jitter
from ..io.bvh import read_bvh, write_bvh
from ..layers._pipeline import Job
from ..layers.alpha_curve import as_alpha, has_curve
from ..layers.layers import Layers, decompose
from ..model import quat
from ..model._rig import motion_axis
from ..model.motion import Motion
from ..model.up_axis import detect_up

if TYPE_CHECKING:
    from ..layers.alpha_curve import AlphaArg, AlphaCurve

__all__ = ["Clip", "Synthesis", "GuardReport", "stylize", "denoise"]

#: the ``limits`` argument: "auto", True, None/False or a JointLimits
LimitsArg = str | bool | JointLimits | None
#: the ``floor`` argument: "auto", a height, or None/False
FloorArg = str | float | bool | None


@dataclass(frozen=True)
class GuardReport:
    """What the guards did to one synthesized motion.

    Attributes
    ----------
    limited : dict of str to int
        Joint name -> frames in which the joint limits changed it (limited joints only);
        empty when the limits did not run.
    limits_applied : bool
        Whether the joint limits ran (by default only when some |alpha| > 1).
    contact_frames : int
        Frames where some foot was pinned to its contact.
    floor_frames : int
        Frames where some foot was raised to the floor.
    floor_height : float
        The floor used along the up axis (NaN when the floor guard was off).
    root_shift_max : float
        Largest root correction of the contact cleanup, in the clip's units.
    floor_raised : int
        Frames where the whole body was raised because a foot the limited legs could not
        keep up, or any other joint or End Site, was still below the floor (beyond the
        input's own depth there) after the other guards.
    """
    limited: dict[str, int] = field(default_factory=dict)
    limits_applied: bool = False
    contact_frames: int = 0
    floor_frames: int = 0
    floor_height: float = float("nan")
    root_shift_max: float = 0.0
    floor_raised: int = 0


def _limits_mode(limits: LimitsArg) -> tuple[int, JointLimits | None]:
    """(C mode, JointLimits or None) for the ``limits`` argument."""
    if limits is None or limits is False:
        return lib.MLR_GUARDS_LIMITS_OFF, None
    if isinstance(limits, str) and limits == "auto":
        return lib.MLR_GUARDS_LIMITS_AUTO, None
    if limits is True:
        return lib.MLR_GUARDS_LIMITS_ALWAYS, None
    if isinstance(limits, JointLimits):
        return lib.MLR_GUARDS_LIMITS_ALWAYS, limits
    raise InvalidArgumentError(f"limits: expected 'auto', True, None/False or a JointLimits "
                               f"(mlayer.joint_limits), got {limits!r}")


def _floor(floor: FloorArg) -> tuple[bool, float | None]:
    """(on, height or None) for the ``floor`` argument."""
    if floor is None or floor is False:
        return False, None
    if isinstance(floor, str) and floor == "auto":
        return True, None
    if isinstance(floor, bool) or not isinstance(floor, (int, float, np.floating, np.integer)):
        raise InvalidArgumentError(f"floor: expected 'auto', None or a height, got {floor!r}")
    h = float(floor)
    if not math.isfinite(h):
        raise InvalidArgumentError(f"floor: the height must be finite, got {floor!r}")
    return True, h


class Synthesis(ReadOnlyAttributes):
    """The layers and the guards of one input motion, for any number of syntheses.

    ``motion`` and ``layers`` are read-only attributes. ``copy.copy`` shares the guards' C
    handle (it is not changed after it is made and is freed with the last user);
    ``copy.deepcopy`` and pickling raise TypeError (the guards and joint limits are C models
    that cannot be duplicated: make a new Synthesis).

    Parameters
    ----------
    motion : Motion
        The input.
    limits : "auto", bool, None or JointLimits, optional
        ``"auto"`` (default: learned from the input, applied when some |alpha| > 1), True
        (always), None or False (never), or a JointLimits (:func:`mlayer.joint_limits`:
        explicit ranges, several clips), always applied.
    floor : "auto", float or None, optional
        ``"auto"`` (default: from the input's contacts), a height along the up axis, or None
        (off).
    keep_contacts : bool, optional
        Pin the feet during the input's contacts (default True).
    contact_joints : str or sequence of str, optional
        The contact points instead of the feet found by name: joint names or ``"Joint/End"``
        for a joint's End Site.
    up : {"x", "y", "z"}, optional
        The up axis; None (default): the input's :attr:`Motion.up_axis`.
    layers : Layers, optional
        The input's layers when they are at hand (else decomposed here).
    **layer_options
        gamma, lam_c, sigma_c, lam_b, sigma_b, base_cutoff, robust (default True: outlier
        frames down-weighted, see :attr:`Layers.outliers`): see :func:`mlayer.decompose`.

    Raises
    ------
    mlayer.InvalidArgumentError
        (naming the argument) For bad options or input.
    """
    layers: Layers

    _readonly = ("motion", "layers", "_mode", "_limits", "_floor_on", "_floor_height",
                 "_keep_contacts", "_contact_joints", "_up")

    def __copy__(self) -> Synthesis:
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)  # the same layers, limits and guards handle
        return new

    def __deepcopy__(self, memo: dict[int, Any]) -> NoReturn:
        raise refuse_copy(self, "deep-copy", "make a new Synthesis of the motion")

    def __reduce_ex__(self, protocol: SupportsIndex) -> NoReturn:
        raise refuse_copy(self, "pickle", "pickle the motion and make a new Synthesis")

    def __init__(self, motion: Motion, *, limits: LimitsArg = "auto", floor: FloorArg = "auto",
                 keep_contacts: bool = True,
                 contact_joints: str | Sequence[str | int] | None = None,
                 up: str | int | None = None, layers: Layers | None = None,
                 **layer_options: Any) -> None:
        if not isinstance(motion, Motion):
            raise InvalidArgumentError(f"motion: expected a mlayer.Motion, got "
                                       f"{type(motion).__name__}")
        if not isinstance(keep_contacts, (bool, np.bool_)):
            raise InvalidArgumentError(f"keep_contacts: expected True or False, got "
                                       f"{keep_contacts!r}")
        self.motion = motion
        self._mode, self._limits = _limits_mode(limits)
        self._floor_on, self._floor_height = _floor(floor)
        self._keep_contacts = bool(keep_contacts)
        self._contact_joints = contact_joints
        self._up = motion_axis(motion, up, "up")
        if layers is not None and (not isinstance(layers, Layers) or layers.motion is not motion):
            raise InvalidArgumentError("layers: expected the Layers of this motion "
                                       "(mlayer.decompose(motion))")
        self.layers = layers if layers is not None else decompose(motion, **layer_options)

    def _guard_input(self) -> Motion:
        """The input the guards learn from (contacts, floor, limits): the input, with the frames
        the robust decomposition found to be outliers (``Layers.outliers``) replaced by the
        denoised ones (:meth:`Layers.repaired`, ``mlr_layers_repair``), so that a glitch does
        not break a contact or move the floor."""
        return self.layers.repaired()

    @functools.cached_property
    def _job(self) -> Job:
        """The C pipeline (``mlr_pipeline``) prepared on the input with these layers: the input
        with its outlier frames repaired (``mlr_layers_repair``, what :meth:`Layers.repaired`
        gives) is what the guards learn from, so that a glitch does not break a contact or move
        the floor."""
        job = Job({lib.MLR_PIPELINE_UP: self._up, lib.MLR_PIPELINE_LIMITS: self._mode,
                   lib.MLR_PIPELINE_KEEP_CONTACTS: float(self._keep_contacts),
                   lib.MLR_PIPELINE_FLOOR: 0 if not self._floor_on
                   else 1 if self._floor_height is None else 2,
                   lib.MLR_PIPELINE_FLOOR_HEIGHT: self._floor_height or 0.0}, "guards")
        note = job.prepare(self.motion, self.layers._h)
        if note and self._contact_joints is None:  # (given contact points replace the feet)
            warnings.warn(note, MlayerWarning, stacklevel=4)
        g = job.guards()
        diag = ffi.new("mlr_diag *")
        if self._contact_joints is not None and self._keep_contacts:
            m = self._guard_input()
            names, c = detect_contacts(m, self._contact_joints, up="xyz"[self._up])
            pts = [_point(m.skeleton, n) for n in names]
            j = np.array([p[0] for p in pts], dtype=np.int32)
            e = np.array([p[1] for p in pts], dtype=np.int32)
            cu = np.ascontiguousarray(c, dtype=np.uint8)
            check(lib.mlr_guards_set_contacts(
                g, len(pts), ffi.cast("const int32_t *", ffi.from_buffer(j)),
                ffi.cast("const int32_t *", ffi.from_buffer(e)),
                ffi.cast("const uint8_t *", ffi.from_buffer(cu)), diag), "contact_joints", diag)
        if self._limits is not None:
            if self._limits.joint_names != self.motion.joint_names:
                raise InvalidArgumentError("limits: made for another skeleton than the motion's")
            check(lib.mlr_guards_set_limits(g, self._limits._h, diag), "limits", diag)
        return job

    @property
    def _guards(self) -> Any:
        return self._job.guards()

    def contacts(self) -> tuple[list[str], NDArray[np.bool_]]:
        """The contacts the guards pin.

        Returns
        -------
        names : list of str
            The contact point names (``"Joint"`` or ``"Joint/End"``).
        contacts : numpy.ndarray of bool, shape (N, C)
            The input's contacts.
        """
        g, sk = self._guards, self.motion.skeleton
        C = int(lib.mlr_guards_n_points(g))
        j = np.zeros(C, dtype=np.int32)
        e = np.zeros(C, dtype=np.int32)
        c = np.zeros((self.motion.n_frames, C), dtype=np.uint8)
        if C:
            check(lib.mlr_guards_get_contacts(
                g, ffi.cast("int32_t *", ffi.from_buffer(j)),
                ffi.cast("int32_t *", ffi.from_buffer(e)),
                ffi.cast("uint8_t *", ffi.from_buffer(c))), "guards contacts")
        names = [sk.joint_names[a] + ("/End" if b >= 0 else "") for a, b in zip(j, e)]
        return names, c.astype(bool)

    def _same_frames(self, m: Motion | None, name: str) -> None:
        """The C guards read a synthesis (and its reference) on the input's frames and
        skeleton: anything else is refused before the call."""
        if m is None and name == "reference":
            return
        if not isinstance(m, Motion):
            raise InvalidArgumentError(f"{name}: expected a mlayer.Motion, got "
                                       f"{type(m).__name__}")
        if m.skeleton != self.motion.skeleton or m.n_frames != self.motion.n_frames:
            raise InvalidArgumentError(f"{name}: expected a Motion on the input's skeleton and "
                                       f"its {self.motion.n_frames} frames, got "
                                       f"{m.n_frames} frames")

    def guard(self, synthesized: Motion, alphas: ArrayLike, reference: Motion | None = None
              ) -> tuple[Motion, GuardReport]:
        """The guards applied to a synthesized motion.

        During contacts the feet follow ``reference`` (default: the input, smoothed over
        0.02 s against capture noise), or keep their own trajectory where it slides less.

        Parameters
        ----------
        synthesized : Motion
            A motion on the input's skeleton and frames.
        alphas : array_like, shape (1 + J,)
            The alphas it was made with, as :meth:`Layers.alphas` gives them.
        reference : Motion, optional
            On the input's skeleton and frames.

        Returns
        -------
        motion : Motion
            The guarded motion.
        report : GuardReport
            What the guards did.

        Raises
        ------
        mlayer.InvalidArgumentError
            For motions on other skeletons or frames.
        """
        a = np.ascontiguousarray(alphas, dtype=np.float64).reshape(-1)
        for m, name in ((synthesized, "synthesized"), (reference, "reference")):
            self._same_frames(m, name)
        root, rot, trans = (x.copy() for x in synthesized._frames())
        if reference is None:
            rr = rq = rt = None
        else:
            rr, rq, rt = reference._frames()
        def ref_ptr(x: NDArray[np.float64] | None) -> Any:
            return ffi.NULL if x is None or not x.size else _arrays.ptr(x)
        J = self.motion.n_joints
        limited = np.zeros(J, dtype=np.uintp)
        rep = ffi.new("mlr_guards_report *")
        diag = ffi.new("mlr_diag *")
        job = ffi.new("mlr_guards_job *")
        job.alpha, job.n_alpha = _arrays.ptr(a), a.size
        if reference is not None:
            job.reference = (reference.n_frames, ref_ptr(rr), ref_ptr(rq), ref_ptr(rt))
        job.root_pos, job.rot = _arrays.ptr_out(root), _arrays.ptr_out(rot)
        job.trans = _arrays.ptr_out(trans) if trans.size else ffi.NULL
        job.body_on_trans = 1
        job.limited, job.n_limited = ffi.cast("size_t *", ffi.from_buffer(limited)), J
        job.report = rep
        check(lib.mlr_guards_run(self._guards, job, diag), "guards", diag)
        return synthesized.with_frames(root_pos=root, rot=rot, trans=trans), \
            self._report(rep, limited)

    def run(self, alpha: AlphaArg = 1.0, joints: Mapping[str, AlphaArg] | None = None, *,
            root_alpha: float | None = None, residual: bool = False
            ) -> tuple[Motion, GuardReport]:
        """Synthesize, then guard.

        ``Mb (+) alpha delta_c`` as :meth:`Layers.synthesize`, the residual added back when
        ``residual``, then :meth:`guard`.

        Parameters
        ----------
        alpha : float or AlphaCurve, optional
            The alpha of every joint and the body translation; an :class:`mlayer.AlphaCurve`
            (or its keys) for alpha over time. The guards then run as for each group's alpha of
            largest magnitude over the clip (``mlr_pipeline.h``, "Alpha over time").
        joints : dict of str to float or AlphaCurve, optional
            Joint name or glob -> alpha or curve.
        root_alpha : float, optional
            The body translation's alpha (default: ``alpha``).
        residual : bool, optional
            Add the residual back (the input's noise kept, as the viewer's "denoise off").

        Returns
        -------
        motion : Motion
            The guarded synthesis.
        report : GuardReport
            What the guards did.
        """
        L: Layers = self.layers
        if has_curve(alpha, joints):
            # (the arguments' Python forms checked here; the guards take each group's peak)
            rows = L.alphas_over_time(alpha, joints, root_alpha)
            a = guard_alphas(rows)
            alpha_c: float | AlphaCurve = as_alpha(alpha, "alpha")
            joints_c: dict[str, float | AlphaCurve] | None = {
                p: as_alpha(v, f"alpha of {p!r}") for p, v in (joints or {}).items()}
        else:
            # (the arguments' Python forms checked here)
            a = L.alphas(cast(float, alpha), cast("Mapping[str, float] | None", joints),
                         root_alpha)
            alpha_c = float(cast(float, alpha))
            joints_c = cast("dict[str, float | AlphaCurve] | None", joints)
        if residual:
            out = L.synthesize(alpha_c, joints_c, root_alpha=root_alpha)
            r = np.asarray(L.residual)
            out = out.with_frames(root_pos=out.root_pos + r[:, 0],
                                  rot=quat.normalize(quat.mul(out.rot, quat.exp(r[:, 1:]))))
            return self.guard(out, a)
        (root, rot, trans), rep, limited = self._job.synthesize(
            alpha_c, joints_c, None if root_alpha is None else float(root_alpha),
            self.motion.n_joints)
        return self.motion.with_frames(root_pos=root, rot=rot, trans=trans), \
            self._report(rep, limited)

    def _report(self, rep: Any, limited: NDArray[np.uintp]) -> GuardReport:
        return GuardReport(
            limited={n: int(k) for n, k in zip(self.motion.joint_names, limited) if k},
            limits_applied=bool(rep.limits_applied), contact_frames=int(rep.contact_frames),
            floor_frames=int(rep.floor_frames), floor_height=float(rep.floor_height),
            root_shift_max=float(rep.root_shift_max), floor_raised=int(rep.floor_raised))


def guard_alphas(rows: NDArray[np.float64]) -> NDArray[np.float64]:
    """The alphas the guards take for alphas over time, as ``mlr_pipeline`` gives them.

    Each group's alpha of largest magnitude (its first frame's), just below 1 where that is 1
    but the group is not 1 at every frame (so that the guards do not take it for a denoise;
    the limits read it as 1).

    Parameters
    ----------
    rows : numpy.ndarray, shape (N, 1 + J)
        The alphas of every frame (:meth:`Layers.alphas_over_time`).

    Returns
    -------
    numpy.ndarray, shape (1 + J,)
        The alphas for :meth:`Synthesis.guard`.
    """
    if not rows.shape[0]:
        return np.ones(rows.shape[1])
    a = rows[np.argmax(np.abs(rows), axis=0), np.arange(rows.shape[1])].copy()
    a[(a == 1.0) & ~np.all(rows == 1.0, axis=0)] = np.nextafter(1.0, 0.0)
    return a


@overload
def denoise(motion: Motion, *, limits: LimitsArg = "auto", floor: FloorArg = "auto",
            keep_contacts: bool = True, contact_joints: str | Sequence[str | int] | None = None,
            up: str | int | None = None, return_report: Literal[False] = False,
            **layer_options: Any) -> Motion: ...
@overload
def denoise(motion: Motion, *, limits: LimitsArg = "auto", floor: FloorArg = "auto",
            keep_contacts: bool = True, contact_joints: str | Sequence[str | int] | None = None,
            up: str | int | None = None, return_report: Literal[True],
            **layer_options: Any) -> tuple[Motion, GuardReport]: ...
def denoise(motion: Motion, *, limits: LimitsArg = "auto", floor: FloorArg = "auto",
            keep_contacts: bool = True, contact_joints: str | Sequence[str | int] | None = None,
            up: str | int | None = None, return_report: bool = False,
            **layer_options: Any) -> Motion | tuple[Motion, GuardReport]:
    """The denoised motion.

    The layers of ``motion`` synthesized at alpha = 1, with the feet kept on their contacts
    and above the floor.

    Parameters
    ----------
    motion : Motion
        The input.
    limits, floor, keep_contacts, contact_joints, up
        The guards' switches: see :class:`Synthesis`.
    return_report : bool, optional
        Also return the :class:`GuardReport`.
    **layer_options
        See :func:`mlayer.decompose`.

    Returns
    -------
    Motion or (Motion, GuardReport)
        The denoised motion, with the report when ``return_report``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For bad options or input.

    Examples
    --------
    >>> import mlayer
    >>> m = mlayer.data.load_sample()[:240]
    >>> clean = mlayer.denoise(m)
    >>> clean.n_frames
    240
    """
    out, report = Clip(motion).denoise(limits=limits, floor=floor, keep_contacts=keep_contacts,
                                       contact_joints=contact_joints, up=up, **layer_options)
    return (out, report) if return_report else out


@overload
def stylize(motion: Motion, alpha: AlphaArg, joints: Mapping[str, AlphaArg] | None = None, *,
            root_alpha: float | None = None, limits: LimitsArg = "auto",
            floor: FloorArg = "auto", keep_contacts: bool = True,
            contact_joints: str | Sequence[str | int] | None = None,
            up: str | int | None = None, return_report: Literal[False] = False,
            **layer_options: Any) -> Motion: ...
@overload
def stylize(motion: Motion, alpha: AlphaArg, joints: Mapping[str, AlphaArg] | None = None, *,
            root_alpha: float | None = None, limits: LimitsArg = "auto",
            floor: FloorArg = "auto", keep_contacts: bool = True,
            contact_joints: str | Sequence[str | int] | None = None,
            up: str | int | None = None, return_report: Literal[True],
            **layer_options: Any) -> tuple[Motion, GuardReport]: ...
def stylize(motion: Motion, alpha: AlphaArg, joints: Mapping[str, AlphaArg] | None = None, *,
            root_alpha: float | None = None, limits: LimitsArg = "auto",
            floor: FloorArg = "auto", keep_contacts: bool = True,
            contact_joints: str | Sequence[str | int] | None = None,
            up: str | int | None = None, return_report: bool = False,
            **layer_options: Any) -> Motion | tuple[Motion, GuardReport]:
    """Scale the style (the controllable layer) of a motion.

    The guards (joint limits when some |alpha| > 1, foot contacts, floor; see
    :class:`Synthesis`) keep the result within what a body can do.

    Parameters
    ----------
    motion : Motion
        The input.
    alpha : float or AlphaCurve
        2 exaggerates, 0.5 flattens. An :class:`mlayer.AlphaCurve`, ``(time_s, alpha)`` keys
        or their text (``"0:1,2.5:3,4:1"``) give an alpha that changes over time, smoothly
        between the keys (:mod:`mlayer.layers.alpha_curve`; paper 1, section 6.2); the guards then
        run as for each joint's largest |alpha| over the clip.
    joints : dict of str to float or AlphaCurve, optional
        Joint names or globs (``"Left*"``) -> their own alpha or curve.
    root_alpha : float, optional
        The body translation's alpha (default: ``alpha``).
    limits, floor, keep_contacts, contact_joints, up
        The guards' switches: see :class:`Synthesis`.
    return_report : bool, optional
        Also return the :class:`GuardReport`.
    **layer_options
        See :func:`mlayer.decompose`.

    Returns
    -------
    Motion or (Motion, GuardReport)
        The stylized motion, with the report when ``return_report``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For bad options or input.
    """
    out, report = Clip(motion).stylize(alpha, joints, root_alpha=root_alpha, limits=limits,
                                       floor=floor, keep_contacts=keep_contacts,
                                       contact_joints=contact_joints, up=up, **layer_options)
    return (out, report) if return_report else out


class Clip(ReadOnlyAttributes):
    """One input of a run and what is computed from it once.

    ``Clip.read(path, strict=, up=, trim=, units=)`` or ``Clip(motion)``. The forward
    kinematics of the input (:attr:`positions`), its up axis (:attr:`up`, detected from those
    positions unless the motion says it), its body height, jitter and foot sliding are
    computed on first use and kept; :meth:`synthesis` keeps one :class:`Synthesis` (layers and
    guards) per set of options, so denoising and any number of alphas share one
    decomposition. The input is not modified; do not modify it in place while the clip is in
    use (the kept figures would not follow).

    ``motion`` and the figures kept are read-only; ``name`` can be assigned a str.

    Parameters
    ----------
    motion : Motion
        The input.
    name : str, optional
        What the clip is called in messages (default ``"<motion>"``).
    """
    name: str

    _readonly = ("motion", "forward_kinematics", "up", "body_height", "contacts")
    _checked = {"name": _attrs.text}

    def __init__(self, motion: Motion, *, name: str | None = None) -> None:
        if not isinstance(motion, Motion):
            raise InvalidArgumentError(f"motion: expected a mlayer.Motion, got "
                                       f"{type(motion).__name__}")
        self.motion = motion
        self.name = name if name is not None else "<motion>"
        self._syntheses: dict[tuple[tuple[str, str], ...], Synthesis] = {}
        self._layers: dict[tuple[tuple[str, str], ...], Layers] = {}

    @classmethod
    def read(cls, path: str | os.PathLike[str], **read_options: Any) -> Clip:
        """The clip of a BVH file.

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        **read_options
            Passed to :func:`mlayer.read_bvh`.

        Returns
        -------
        Clip
            The clip, named by the path.
        """
        return cls(read_bvh(path, **read_options), name=str(path))

    @functools.cached_property
    def forward_kinematics(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World positions (N, J, 3) and world rotations (N, J, 4) of the input's joints, from
        one forward-kinematics pass (read-only arrays)."""
        pos, wrot = self.motion.forward_kinematics()
        pos.flags.writeable = wrot.flags.writeable = False
        return pos, wrot

    @property
    def positions(self) -> NDArray[np.float64]:
        """(N, J, 3) world positions of the input's joints (read-only)."""
        return self.forward_kinematics[0]

    @functools.cached_property
    def up(self) -> str:
        """The input's up axis, the motion's when it was given (``read_bvh(up=)``, ``--up``),
        else detected from :attr:`positions` ("y" when the detection is not sure)."""
        m = self.motion
        if m._up is not None:
            return m._up
        g = detect_up(m, self.positions)
        return g.axis if g.sure else "y"

    @functools.cached_property
    def body_height(self) -> float:
        """:func:`mlayer.guards.metrics.body_height` of the input along :attr:`up` (NaN for an
        empty clip)."""
        return body_height(self.positions, up=self.up) if self.motion.n_frames else math.nan

    @functools.cached_property
    def contacts(self) -> tuple[list[str], NDArray[np.bool_]]:
        """``(names, contacts)``, :func:`mlayer.detect_contacts` of the input.

        Its feet, along :attr:`up`, from :attr:`forward_kinematics`; no points for a skeleton
        without feet (:func:`mlayer.guards.contacts.find_feet`).
        """
        m = self.motion
        try:
            find_feet(m, self.positions, up=self.up)
        except InvalidArgumentError:  # no feet by name: nothing to pin (as stylize does)
            return [], np.zeros((m.n_frames, 0), dtype=bool)
        pos, wrot = self.forward_kinematics
        names, c = detect_contacts(m, up=self.up, pos=pos, wrot=wrot)
        c.flags.writeable = False
        return names, c

    def layers(self, **layer_options: Any) -> Layers:
        """The input's :func:`mlayer.decompose` with these options, made once per set.

        Parameters
        ----------
        **layer_options
            See :func:`mlayer.decompose`.

        Returns
        -------
        Layers
            The layers (the same object for the same options).
        """
        key = tuple(sorted((k, repr(v)) for k, v in layer_options.items()))
        L = self._layers.get(key)
        if L is None:
            if layer_options.get("robust", True) and "body_height" not in layer_options:
                h = self.body_height
                if math.isfinite(h) and h > 0.0:
                    layer_options["body_height"] = h
            L = self._layers[key] = decompose(self.motion, **layer_options)
        return L

    def synthesis(self, *, limits: LimitsArg = "auto", floor: FloorArg = "auto",
                  keep_contacts: bool = True,
                  contact_joints: str | Sequence[str | int] | None = None,
                  up: str | int | None = None, **layer_options: Any) -> Synthesis:
        """The input's :class:`Synthesis` for these guard and layer options, made once per set.

        Syntheses with the same layer options share one decomposition (:meth:`layers`).

        Parameters
        ----------
        limits, floor, keep_contacts, contact_joints, up
            The guards' switches: see :class:`Synthesis`.
        **layer_options
            See :func:`mlayer.decompose`.

        Returns
        -------
        Synthesis
            The synthesis (the same object for the same options).
        """
        guard: dict[str, Any] = dict(limits=limits, floor=floor, keep_contacts=keep_contacts,
                     contact_joints=contact_joints, up=up)
        key = tuple(sorted((k, repr(v)) for k, v in guard.items())) + \
            tuple(sorted((k, repr(v)) for k, v in layer_options.items()))
        s = self._syntheses.get(key)
        if s is None:
            if up is not None and layer_options.get("robust", True) \
                    and "body_height" not in layer_options and self.motion.n_frames:
                h = body_height(self.positions, up=up)  # along the axis asked for
                if math.isfinite(h) and h > 0.0:
                    layer_options["body_height"] = h
            guard["up"] = self.up if up is None else up
            s = self._syntheses[key] = Synthesis(self.motion, layers=self.layers(**layer_options),
                                                 **guard)
        return s

    def denoise(self, **options: Any) -> tuple[Motion, GuardReport]:
        """:func:`denoise` of the input.

        Parameters
        ----------
        **options
            The options of :meth:`synthesis`.

        Returns
        -------
        motion : Motion
            The denoised motion.
        report : GuardReport
            What the guards did.
        """
        return self.synthesis(**options).run(1.0)

    def stylize(self, alpha: AlphaArg, joints: Mapping[str, AlphaArg] | None = None, *,
                root_alpha: float | None = None, **options: Any) -> tuple[Motion, GuardReport]:
        """:func:`stylize` of the input.

        Parameters
        ----------
        alpha : float or AlphaCurve
            The style scale, or its curve over time.
        joints : dict of str to float or AlphaCurve, optional
            Joint name or glob -> alpha or curve.
        root_alpha : float, optional
            The body translation's alpha.
        **options
            The options of :meth:`synthesis`.

        Returns
        -------
        motion : Motion
            The stylized motion.
        report : GuardReport
            What the guards did.
        """
        return self.synthesis(**options).run(alpha, joints, root_alpha=root_alpha)

    def jitter(self, motion: Motion | None = None) -> float:
        """Jitter in body heights per s^3 (:func:`mlayer.guards.metrics.jitter`).

        Parameters
        ----------
        motion : Motion, optional
            An output of this clip; default the input.

        Returns
        -------
        float
            The jitter; NaN under 4 frames or without a body height.
        """
        m = self.motion if motion is None else motion
        h = self.body_height
        if m.n_frames < 4 or not (h > 0.0):
            return math.nan
        return jitter(self.positions if motion is None else m, fps=m.fps) / h

    def foot_sliding(self, motion: Motion | None = None) -> float:
        """Foot sliding (:func:`mlayer.guards.metrics.foot_sliding`) during the input's contacts.

        Parameters
        ----------
        motion : Motion, optional
            An output on the input's frames (one on other frames is measured during its own
            contacts); default the input.

        Returns
        -------
        float
            Body heights per second; NaN without contacts or a body height.
        """
        names, c = self.contacts
        h = self.body_height
        if not names or not (h > 0.0):
            return math.nan
        if motion is None:
            pos, wrot = self.forward_kinematics
            return foot_sliding(self.motion, c, names, up=self.up, pos=pos, wrot=wrot) / h
        if motion.n_frames != c.shape[0]:
            names, c = detect_contacts(motion, up=self.up)
            if not names:
                return math.nan
        return foot_sliding(motion, c, names, up=self.up) / h

    def write(self, motion: Motion, path: str | os.PathLike[str]) -> None:
        """Write an output of this clip as BVH, atomically (:func:`mlayer.write_bvh`).

        Parameters
        ----------
        motion : Motion
            The output.
        path : str or os.PathLike
            The file.
        """
        write_bvh(motion, path)
