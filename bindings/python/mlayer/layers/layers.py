"""Motion layers (paper 1, section 4): decomposition, denoising and style modulation.

A motion M (root translation and joint rotations) is split into

    base layer Mb         a strongly smoothed version of M (LGS on the root translation and
                          on each joint's hemisphere-aligned quaternion, renormalized);
    controllable layer    the displacement M (-) Mb, smoothed by a second LGS: the "style";
    residual              what is left: mostly capture noise.

so that (Mb (+) control) (+) residual == M to rounding. ``(+)`` adds translations and applies
rotations as q * exp(v), v a rotation vector (axis times full angle).

Synthesis scales the controllable layer per joint: M' = Mb (+) alpha * control. alpha = 1 is
the denoised motion, alpha > 1 exaggerates the style, 0 <= alpha < 1 flattens it.

How the smoothing is chosen (all in the C core, see mlr_layers.h):
- base layer, per joint: the strongest smoothing whose largest displacement angle stays within
  gamma (paper eq. 14; default pi/2). The paper uses one setting for the body; one per joint
  keeps a single glitchy joint from weakening the rest. The root translation takes the
  setting of the root joint.
- controllable layer, per joint and for the root translation: generalized cross-validation
  (GCV) of the LGS, so the same call works at 24 and at 120 fps. The paper's fixed
  lam_c = sigma_c = 1 was tuned on 24 fps data and barely smooths 120 fps captures; pass
  lam_c / sigma_c to use fixed values instead.

The translation group (index 0 of control, residual and the parameters) is the body
translation: the root's, or, on rigs whose root stays put while a joint below it carries the
walk in its position channels (Bandai: a static ``joint_Root`` above ``Hips``), that joint's
(:func:`body_translation_joint`, ``Layers.body_joint``). Denoising smooths it and style
modulation scales it wherever it lives. Other position channels (Bandai files put 6 channels on
every joint, repeating the OFFSETs) keep their values.
"""
from __future__ import annotations

import fnmatch
import functools
import math
import os
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, NoReturn, SupportsIndex, cast

import numpy as np
from numpy.typing import NDArray

from .. import _arrays
from .._args import integer
from .._files import atomic_output
from .._handles import ReadOnlyAttributes
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..model import quat
from ..model._rig import axis, c_rig
from ..model.motion import Motion
from ._pipeline import Job
from .alpha_curve import as_alpha, has_curve
from .smoothing import lgs

if TYPE_CHECKING:
    from .alpha_curve import AlphaArg

_PARAMS = {
    "base_s": lib.MLR_LAYERS_PARAM_BASE_S,
    "lam": lib.MLR_LAYERS_PARAM_BASE_LAM,
    "sigma": lib.MLR_LAYERS_PARAM_BASE_SIGMA,
    "base_max_angle": lib.MLR_LAYERS_PARAM_BASE_MAX_ANGLE,
    "control_s": lib.MLR_LAYERS_PARAM_CONTROL_S,
    "lam_c": lib.MLR_LAYERS_PARAM_CONTROL_LAM,
    "sigma_c": lib.MLR_LAYERS_PARAM_CONTROL_SIGMA,
    "control_gcv": lib.MLR_LAYERS_PARAM_CONTROL_GCV,
    "control_dof": lib.MLR_LAYERS_PARAM_CONTROL_DOF,
}


def body_translation_joint(motion: Motion | Sequence[Motion]) -> int:
    """The joint that carries the body translation (``mlr_rig_body_translation_joint``).

    The root when its translation varies beyond rounding, else the topmost joint with
    position channels whose translation does (Bandai: ``Hips`` under a static
    ``joint_Root``), else the root. "Beyond rounding": a coordinate spans more than 1e-5 of
    the rest pose's size.

    Parameters
    ----------
    motion : Motion or list or tuple of Motion
        A clip, or clips of one skeleton: then the first non-root answer among them, else the
        root.

    Returns
    -------
    int
        The joint index.

    Raises
    ------
    mlayer.InvalidArgumentError
        For something else than Motions.
    """
    clips: list[Any] = list(motion) if isinstance(motion, (list, tuple)) else [motion]
    for m in clips:
        if not isinstance(m, Motion):
            raise InvalidArgumentError(f"body_translation_joint: expected a Motion, got "
                                       f"{type(m).__name__}")
    for m in clips:
        j = _body_joint_one(m)
        if j != 0:
            return j
    return 0


def _body_joint_one(m: Motion) -> int:
    sk = m.skeleton
    P = int(sk.trans_joints.shape[0])
    if P == 0 or m.n_frames == 0:
        return 0
    root, _, trans = m._frames()
    rig, _keep = c_rig(sk)
    out = ffi.new("int32_t *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_rig_body_translation_joint(rig, m.n_frames, _arrays.ptr(root),
                                             _arrays.ptr(trans), out, diag),
          "body_translation_joint", diag)
    return int(out[0])


def body_translation(motion: Motion, joint: int) -> NDArray[np.float64]:
    """The translation of a joint in a motion.

    Parameters
    ----------
    motion : Motion
        The motion.
    joint : int
        0 (the root), or a joint with position channels.

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        ``root_pos`` for the root, else the joint's position channels.

    Raises
    ------
    mlayer.InvalidArgumentError
        When the joint has no position channels.
    """
    if joint == 0:
        return motion.root_pos
    hits = np.flatnonzero(motion.skeleton.trans_joints == joint)
    if hits.size != 1:
        raise InvalidArgumentError(f"joint {joint} has no position channels")
    return motion.trans[:, int(hits[0])]


def _with_body_translation(motion: Motion, joint: int, t: NDArray[np.float64],
                           rot: NDArray[np.float64]) -> Motion:
    """motion.with_frames with rotations rot and the body translation t written to `joint`
    (the root's translation when joint is 0, else that joint's position channels; the root and
    the other channels keep motion's values)."""
    if joint == 0:
        return motion.with_frames(root_pos=t, rot=rot)
    trans = np.array(motion.trans, dtype=np.float64, order="C", copy=True)
    trans[:, int(np.flatnonzero(motion.skeleton.trans_joints == joint)[0])] = t
    return motion.with_frames(rot=rot, trans=trans)


class Layers(ReadOnlyAttributes):
    """The layers of one motion. Made by :func:`decompose`; read-only.

    Assigning an attribute raises AttributeError. Copies: the C handle is never changed after
    :func:`decompose` and is freed when the last Layers using it goes, so ``copy.copy`` and
    ``copy.deepcopy`` share it (a deep copy also copies ``motion``). Pickling raises
    TypeError: write the layers with :meth:`save_npz`. Groups: index 0 is the body
    translation, 1 + j is joint j.

    Parameters
    ----------
    motion : Motion
        The decomposed motion.
    handle : cffi ``mlr_layers *``
        The C layers: owned (with its finalizer), or borrowed from ``owner``.
    params : dict of str to numpy.ndarray
        The parameter arrays below, by name (made read-only).
    body_joint : int, optional
        The joint of group 0.
    owner : object, optional
        What keeps a borrowed handle alive (the C pipeline that made the layers).

    Attributes
    ----------
    motion : Motion
        The input motion.
    body_joint : int
        The joint whose translation is group 0: 0 (the root) on most rigs; the joint below a
        static root that carries the walk otherwise (Bandai: Hips); see
        :func:`body_translation_joint`.
    lam, sigma : numpy.ndarray, shape (1 + J,)
        Base-layer LGS parameters per group.
    base_s : numpy.ndarray, shape (1 + J,)
        ``lam^2 sigma^2`` of the base layer per group (the smoothing strength).
    base_max_angle : numpy.ndarray, shape (1 + J,)
        Largest displacement per group: radians for joints, length units for the body
        translation.
    lam_c, sigma_c : numpy.ndarray, shape (1 + J,)
        Controllable-layer LGS parameters per group.
    control_s : numpy.ndarray, shape (1 + J,)
        ``lam_c^2 sigma_c^2`` per group.
    control_gcv : numpy.ndarray, shape (1 + J,)
        GCV score at the chosen setting (NaN when lam_c/sigma_c were given).
    control_dof : numpy.ndarray, shape (1 + J,)
        Effective degrees of freedom of the control smoother per channel.
    """
    body_joint: int

    lam: NDArray[np.float64]
    sigma: NDArray[np.float64]
    base_s: NDArray[np.float64]
    base_max_angle: NDArray[np.float64]
    lam_c: NDArray[np.float64]
    sigma_c: NDArray[np.float64]
    control_s: NDArray[np.float64]
    control_gcv: NDArray[np.float64]
    control_dof: NDArray[np.float64]

    _readonly = ("motion", "body_joint", "_h", "_owner", "base", "control", "residual",
                 "outliers") + tuple(_PARAMS)

    def __init__(self, motion: Motion, handle: Any, params: dict[str, NDArray[Any]],
                 body_joint: int = 0, owner: Any = None) -> None:
        self.motion = motion
        self.body_joint = int(body_joint)
        self._h = handle
        self._owner = owner
        for name, values in params.items():
            values.flags.writeable = False
            setattr(self, name, values)

    def _share(self, motion: Motion) -> Layers:
        params = {name: getattr(self, name) for name in _PARAMS}
        return Layers(motion, self._h, params, self.body_joint, self._owner)

    def __copy__(self) -> Layers:
        return self._share(self.motion)

    def __deepcopy__(self, memo: dict[int, Any]) -> Layers:
        return self._share(self.motion.copy())

    def __reduce_ex__(self, protocol: SupportsIndex) -> NoReturn:
        raise TypeError("cannot pickle mlayer.Layers (they own a C handle); write them with "
                        "Layers.save_npz")

    # The layers are read from the C handle on first use: synthesize() and denoise() need
    # none of them, and a 2,526 x 31 clip's three copies take about 1.5 ms.
    @functools.cached_property
    def base(self) -> Motion:
        """The base layer Mb as a Motion on the same skeleton."""
        n, j = self.motion.n_frames, self.motion.n_joints
        root, rot = np.empty((n, 3)), np.empty((n, j, 4))
        check(lib.mlr_layers_get_base(self._h, _arrays.ptr_out(root), root.size,
                                      _arrays.ptr_out(rot), rot.size), "layers base")
        return _with_body_translation(self.motion, self.body_joint, root, rot)

    @functools.cached_property
    def control(self) -> NDArray[np.float64]:
        """The controllable layer, (N, 1 + J, 3).

        Body translation offsets, then one rotation vector (radians, axis times angle) per
        joint.
        """
        return self._groups(lib.mlr_layers_get_control, "layers control")

    @functools.cached_property
    def residual(self) -> NDArray[np.float64]:
        """The residual layer, (N, 1 + J, 3), laid out like :attr:`control`."""
        return self._groups(lib.mlr_layers_get_residual, "layers residual")

    def _groups(self, getter: Any, where: str) -> NDArray[np.float64]:
        a = np.empty((self.motion.n_frames, 1 + self.motion.n_joints, 3))
        check(getter(self._h, _arrays.ptr_out(a), a.size), where)
        a.flags.writeable = False
        return a

    @functools.cached_property
    def outliers(self) -> NDArray[np.bool_]:
        """bool (N, 1 + J), the frames down-weighted as outliers per group.

        True where a frame of a group (0 the body translation, 1 + j joint j) was found an
        outlier and down-weighted by the robust decomposition, or belongs to a joint's flip of
        constant turn that was undone (its repaired rotation counted in the layers; see
        "Outliers" in mlr_layers.h); all False when robust is off or nothing was found.
        """
        a = np.zeros((self.motion.n_frames, 1 + self.motion.n_joints), dtype=np.uint8)
        check(lib.mlr_layers_get_outliers(self._h, ffi.from_buffer("unsigned char[]", a,
                                                                   require_writable=True),
                                          a.size), "layers outliers")
        out = a.astype(bool)
        out.flags.writeable = False
        return out

    @property
    def outlier_frames(self) -> NDArray[np.intp]:
        """The frames that are an outlier of some group, sorted."""
        return np.flatnonzero(self.outliers.any(axis=1))

    def repaired(self) -> Motion:
        """The input with its outlier frames replaced by the denoised ones.

        The frames of :attr:`outlier_frames` take the synthesis at alpha 1
        (``mlr_layers_repair``): what the guards learn from, so that a glitch does not break a
        contact or move the floor.

        Returns
        -------
        Motion
            The repaired motion; the input itself when there is no outlier.
        """
        m = self.motion
        if self.outlier_frames.size == 0:
            return m
        body = self.body_joint
        if body == 0:
            t = np.array(m.root_pos, dtype=np.float64, order="C", copy=True)
        else:
            col = int(np.flatnonzero(m.skeleton.trans_joints == body)[0])
            t = np.ascontiguousarray(m.trans[:, col], dtype=np.float64).copy()
        rot = np.array(m.rot, dtype=np.float64, order="C", copy=True)
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_layers_repair(self._h, 0, self.n_frames, _arrays.ptr_out(t), t.size,
                                    _arrays.ptr_out(rot), rot.size, ffi.NULL, diag),
              "layers repair", diag)
        return _with_body_translation(m, body, t, rot)

    @property
    def n_frames(self) -> int:
        """The number of frames N."""
        return self.motion.n_frames

    def alphas(self, alpha: float = 1.0, joints: Mapping[str, float] | None = None,
               root_alpha: float | None = None) -> NDArray[np.float64]:
        """The alpha vector :meth:`synthesize` uses.

        Parameters
        ----------
        alpha : float, optional
            The alpha everywhere.
        joints : dict of str to float, optional
            Joint name or glob -> alpha, applied in order; later patterns win.
        root_alpha : float, optional
            The body translation's alpha (default: ``alpha``).

        Returns
        -------
        numpy.ndarray, shape (1 + J,)
            The alphas per group.

        Raises
        ------
        mlayer.InvalidArgumentError
            For a pattern that matches no joint or a non-finite alpha.
        """
        if has_curve(alpha, joints):
            raise InvalidArgumentError("alpha: a curve changes over time: use "
                                       "alphas_over_time() for the alphas of every frame")
        names = self.motion.joint_names
        out = np.full(1 + len(names), _arrays.finite(alpha, "alpha"))
        if root_alpha is not None:
            out[0] = _arrays.finite(root_alpha, "root_alpha")
        for pattern, a in (joints or {}).items():
            hits = [k for k, n in enumerate(names) if fnmatch.fnmatchcase(n, pattern)]
            if not hits:
                raise InvalidArgumentError(
                    f"joint pattern {pattern!r} matches no joint; joints: {', '.join(names)}")
            out[1 + np.asarray(hits)] = _arrays.finite(a, f"alpha of {pattern!r}")
        return out

    def alphas_over_time(self, alpha: AlphaArg = 1.0,
                         joints: Mapping[str, AlphaArg] | None = None,
                         root_alpha: float | None = None) -> NDArray[np.float64]:
        """The alphas of every frame, as :meth:`synthesize` uses them with curves.

        Composed as :meth:`alphas` (``alpha`` everywhere, ``root_alpha`` for the body
        translation, then the patterns in order, later ones winning), each a number or an
        :class:`mlayer.AlphaCurve` (or its keys) evaluated by the C core at
        ``i * frame_time`` seconds for frame ``i``, as ``mlr_pipeline`` does.

        Parameters
        ----------
        alpha : float or AlphaCurve, optional
            The alpha of every group.
        joints : dict of str to float or AlphaCurve, optional
            Joint name or glob -> alpha or curve.
        root_alpha : float, optional
            The body translation's alpha (default: ``alpha``).

        Returns
        -------
        numpy.ndarray, shape (N, 1 + J)
            Frame by frame, the body translation first.

        Raises
        ------
        mlayer.InvalidArgumentError
            For a pattern that matches no joint, bad keys or a non-finite alpha.
        """
        names = self.motion.joint_names
        n = self.n_frames
        t = np.arange(n, dtype=np.float64) * self.motion.frame_time  # (as mlr_pipeline)

        def column(a: Any, name: str) -> NDArray[np.float64]:
            a = as_alpha(a, name)
            return np.full(n, a) if isinstance(a, float) else a(t)

        out = np.empty((n, 1 + len(names)))
        out[:] = column(alpha, "alpha")[:, None]
        if root_alpha is not None:
            out[:, 0] = _arrays.finite(root_alpha, "root_alpha")
        for pattern, a in (joints or {}).items():
            hits = [k for k, nm in enumerate(names) if fnmatch.fnmatchcase(nm, pattern)]
            if not hits:
                raise InvalidArgumentError(
                    f"joint pattern {pattern!r} matches no joint; joints: {', '.join(names)}")
            out[:, 1 + np.asarray(hits)] = column(a, f"alpha of {pattern!r}")[:, None]
        return out

    def synthesize(self, alpha: AlphaArg = 1.0, joints: Mapping[str, AlphaArg] | None = None,
                   *, root_alpha: float | None = None) -> Motion:
        """``M' = Mb (+) W control`` (paper eq. 16, 17), as a Motion on the same skeleton.

        Parameters
        ----------
        alpha : float or AlphaCurve, optional
            Scale of the controllable layer for every joint and the body translation (1:
            denoised, > 1 exaggerated, 0: the base layer); an :class:`mlayer.AlphaCurve` (or
            its ``(time, alpha)`` keys) for an alpha that changes over time
            (``mlr_layers_synthesize_frames``).
        joints : dict of str to float or AlphaCurve, optional
            Maps a joint name or a glob such as ``"Left*"`` to its own alpha or curve.
        root_alpha : float, optional
            Alpha of the body translation (default: alpha): the root's, or that of
            ``body_joint`` when a joint below a static root carries it.

        Returns
        -------
        Motion
            The synthesized motion.
        """
        if has_curve(alpha, joints):
            rows = np.ascontiguousarray(self.alphas_over_time(alpha, joints, root_alpha))
            return self._frames(lambda r, q, d: lib.mlr_layers_synthesize_frames(
                self._h, 0, self.n_frames, _arrays.ptr(rows), rows.size, _arrays.ptr_out(r),
                r.size, _arrays.ptr_out(q), q.size, d), "synthesize")
        w = self.alphas(cast(float, alpha), cast("Mapping[str, float] | None", joints),
                        root_alpha)
        return self._frames(lambda r, q, d: lib.mlr_layers_synthesize(
            self._h, 0, self.n_frames, _arrays.ptr(w), w.size, _arrays.ptr_out(r), r.size,
            _arrays.ptr_out(q), q.size, d), "synthesize")

    def reconstruct(self) -> Motion:
        """``(Mb (+) control) (+) residual``: the input motion again, to rounding.

        Returns
        -------
        Motion
            The reconstruction (a rotation may come back as -q).
        """
        return self._frames(lambda r, q, d: lib.mlr_layers_reconstruct(
            self._h, 0, self.n_frames, _arrays.ptr_out(r), r.size, _arrays.ptr_out(q), q.size,
            d), "reconstruct")

    def _frames(self, call: Callable[[Any, Any, Any], int], where: str) -> Motion:
        n, j = self.n_frames, self.motion.n_joints
        root, rot = np.empty((n, 3)), np.empty((n, j, 4))
        diag = ffi.new("mlr_diag *")
        check(call(root, rot, diag), where, diag)
        return _with_body_translation(self.motion, self.body_joint, root, rot)

    def save_npz(self, path: str | os.PathLike[str]) -> None:
        """Write every layer and parameter to a .npz file, atomically.

        The arrays: base_root_pos, base_rot, base_trans (the base layer's position channels of
        non-root joints), control, residual, the parameter arrays, body_joint, joint_names and
        fps.

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        """
        arrays = {"base_root_pos": self.base.root_pos, "base_rot": self.base.rot,
                  "base_trans": self.base.trans, "body_joint": np.int64(self.body_joint),
                  "control": self.control, "residual": self.residual,
                  "joint_names": np.array(self.motion.joint_names), "fps": self.motion.fps}
        arrays.update({name: getattr(self, name) for name in _PARAMS})
        with atomic_output(path, ".npz") as tmp:
            np.savez(tmp, **arrays)

    def __repr__(self) -> str:
        body = "" if self.body_joint == 0 else \
            f"; body translation on {self.motion.joint_names[self.body_joint]!r}"
        return (f"<mlayer.Layers of {self.n_frames} frames, {self.motion.n_joints} joints; "
                f"lam_c median {np.median(self.lam_c):.3g}{body}>")


def base_s_max(fps: float, cutoff_hz: float) -> float:
    """The base-layer smoothing that halves the amplitude at a frequency.

    The s = lam^2 sigma^2 whose LGS (second-difference prior, identity observations) halves
    the amplitude at ``cutoff_hz`` for a clip at ``fps``: the gain
    ``1 / (1 + s (2 sin(pi f / fps))^4)`` is 1/2 there. The C core computes the same upper end
    of the base search from MLR_LAYERS_OPT_FPS and MLR_LAYERS_OPT_BASE_CUTOFF (decompose
    passes those); this formula is kept as the reference.

    Parameters
    ----------
    fps : float
        The clip's frame rate.
    cutoff_hz : float
        The half-power frequency.

    Returns
    -------
    float
        s.
    """
    return (2.0 * math.sin(math.pi * cutoff_hz / fps)) ** -4


def decompose(motion: Motion, *, gamma: float = math.pi / 2, lam_c: float | None = None,
              sigma_c: float | None = None, lam_b: float | None = None,
              sigma_b: float | None = None, base_cutoff: float | None = 0.25,
              robust: bool = True, body_height: float | None = None) -> Layers:
    """Split a motion into base, controllable and residual layers (see the module docs).

    The translation group is the body translation (:func:`body_translation_joint`): the
    root's, or that of the joint below a static root that carries it, which then also lends
    its base smoothing to the translation (MLR_LAYERS_OPT_BODY_JOINT).

    Parameters
    ----------
    motion : Motion
        The clip (at least 3 frames).
    gamma : float, optional
        Largest displacement angle the base layer may leave, radians, in [pi/2, pi) (paper
        eq. 14).
    lam_c, sigma_c : float, optional
        Fixed controllable-layer parameters instead of GCV (the paper used 1, 1 at 24 fps);
        giving one sets the other to 1.
    lam_b, sigma_b : float, optional
        Fixed base-layer parameters instead of the gamma heuristic.
    base_cutoff : float or None, optional
        Lowest half-power frequency, in Hz, the gamma heuristic may smooth the base layer
        down to (default 0.25 Hz: trends slower than about 4 s). Human joints rarely move 90
        degrees from their mean, so without a floor the heuristic picks the strongest setting
        for every joint and the base layer becomes a straight line or parabola through the
        whole clip; exaggerating then pushes the root far off its path. The paper's windowed
        solves (120 frames at 24 fps) had a similar floor built in. None lifts the floor (the
        C library's default range).
    robust : bool, optional
        Find outlier frames (decoder glitches, marker swaps, one-frame flips) per joint and
        for the body translation, and down-weight them in every LGS, so that a glitch stays in
        the residual layer and its effect on the other layers stays local (default True; see
        "Outliers" in mlr_layers.h). The frames found are ``Layers.outliers``. The
        translation's gate is 0.2 of :func:`mlayer.guards.metrics.body_height`. Clips without
        outliers decompose as with robust=False.
    body_height : float, optional
        The body size that gate scales with, in the clip's units (default:
        :func:`mlayer.guards.metrics.body_height` of the motion, one forward-kinematics pass;
        :class:`mlayer.pipeline.pipeline.Clip` passes the one it has).

    Returns
    -------
    Layers
        The layers.

    Raises
    ------
    mlayer.InvalidArgumentError
        For fewer than 3 frames, bad parameters or non-finite data.

    Examples
    --------
    >>> import mlayer
    >>> m = mlayer.data.load_sample()[:240]
    >>> layers = mlayer.decompose(m)
    >>> layers.control.shape == (240, 1 + m.n_joints, 3)
    True
    """
    n, j = motion.n_frames, motion.n_joints
    if n < 3:
        raise InvalidArgumentError(f"decompose needs at least 3 frames (the second-difference "
                                   f"prior), got {n}")
    if not isinstance(robust, (bool, np.bool_)):
        raise InvalidArgumentError(f"robust: expected True or False, got {robust!r}")
    # The options are composed in C (mlr_pipeline_prepare, step 4): the base floor at the
    # clip's frame rate, the body height along the up axis, the body translation joint.
    params = {lib.MLR_PIPELINE_GUARDS: 0.0, lib.MLR_PIPELINE_ROBUST: float(bool(robust)),
              lib.MLR_PIPELINE_BASE_CUTOFF: 0.0 if base_cutoff is None
              else _positive(base_cutoff, "base_cutoff")}
    for key, value, name in ((lib.MLR_PIPELINE_GAMMA, gamma, "gamma"),
                             (lib.MLR_PIPELINE_LAM_C, lam_c, "lam_c"),
                             (lib.MLR_PIPELINE_SIGMA_C, sigma_c, "sigma_c"),
                             (lib.MLR_PIPELINE_LAM_B, lam_b, "lam_b"),
                             (lib.MLR_PIPELINE_SIGMA_B, sigma_b, "sigma_b")):
        if value is not None:
            params[key] = value if key == lib.MLR_PIPELINE_GAMMA else _positive(value, name)
            params[key] = _arrays.number(params[key], name)
    if robust:
        if body_height is None:  # measured along the motion's up axis (given or detected)
            params[lib.MLR_PIPELINE_UP] = axis(motion.up_axis, "decompose")
        else:
            h = _arrays.finite(body_height, "body_height")
            params[lib.MLR_PIPELINE_BODY_HEIGHT] = h if h > 0.0 else -1.0
    job = Job(params, "decompose")
    job.prepare(motion)
    handle = job.layers()
    params_out = {}
    for name, which in _PARAMS.items():
        a = np.empty(1 + j)
        check(lib.mlr_layers_get_param(handle, which, _arrays.ptr_out(a), a.size), name)
        params_out[name] = a
    return Layers(motion, handle, params_out, int(job.get(lib.MLR_PIPELINE_INFO_BODY_JOINT)),
                  job)


def _positive(v: Any, name: str) -> float:
    """A value the pipeline takes as given only when > 0 (0 there means "not given")."""
    x = _arrays.number(v, name)
    if not x > 0.0:
        raise InvalidArgumentError(f"option {name} must be > 0, got {v!r}")
    return x


# ---- the baselines of paper 1's comparisons (Figures 6 and 7) ---------------------------------
#
# Python over the C core's LGS and quaternion maps, with no numerics of their own beyond the
# B-spline filter of multires_stylize: they exist to draw and measure the paper's comparisons
# (docs/make_figures.py, docs/layers.md), not for a runtime, whose base layer and synthesis
# are the quaternion ones above (in C, mlr_layers.h). slerp_resample (mlayer.pipeline.retiming) is
# the same kind of baseline beside resample.


def expmap_base(motion: Motion, layers: Layers | None = None) -> Motion:
    """The base layer smoothed in exponential-map coordinates: the baseline of paper 1, Fig. 6.

    Each joint's rotations are turned into rotation vectors (:func:`mlayer.model.quat.log`, angle
    in [0, pi]), each of the 3 channels is smoothed by the LGS with the joint's own base-layer
    strength (``layers.base_s[1 + j]``, so only the representation differs from the quaternion
    base layer), and the result is mapped back by :func:`mlayer.model.quat.exp`. Translations are
    the base layer's. The rotation vector jumps where a joint's angle crosses pi (v turns into
    about -v), and the smoothing averages across that jump: rotations near pi come out far from
    the input, where the quaternion base layer (hemisphere-aligned, :func:`decompose`) does
    not. docs/layers.md states the measured difference.

    Python over the C core's LGS and quaternion maps: a baseline for figures and comparisons,
    not for a runtime (the runtime's base layer is the quaternion one, in C).

    Parameters
    ----------
    motion : Motion
        The clip.
    layers : Layers, optional
        Its decomposition (default ``decompose(motion)``), for the strengths and translations.

    Returns
    -------
    Motion
        The exp-map base layer on the motion's skeleton.

    Raises
    ------
    mlayer.InvalidArgumentError
        For layers of another motion (another frame or joint count).
    """
    if layers is None:
        layers = decompose(motion)
    if not isinstance(layers, Layers):
        raise InvalidArgumentError(f"expmap_base: layers must be a Layers, got "
                                   f"{type(layers).__name__}")
    if layers.motion.n_frames != motion.n_frames or layers.motion.n_joints != motion.n_joints:
        raise InvalidArgumentError("expmap_base: the layers are of another motion "
                                   f"({layers.motion.n_frames} frames, {layers.motion.n_joints} "
                                   f"joints; the motion {motion.n_frames}, {motion.n_joints})")
    base = layers.base
    v = quat.log(motion.rot)  # (N, J, 3), angle in [0, pi]
    out = np.empty_like(v)
    for j in range(motion.n_joints):
        s = float(layers.base_s[1 + j])
        out[:, j] = lgs(np.ascontiguousarray(v[:, j]), lam=math.sqrt(s), sigma=1.0) if s > 0 \
            else v[:, j]
    return base.with_frames(rot=quat.exp(out))


#: the cubic B-spline kernel of Bruderlin and Williams' multiresolution filtering (1/16)
#: [1 4 6 4 1], spread by 2^k at level k (their expansion without the resampling)
_B5 = np.array([1.0, 4.0, 6.0, 4.0, 1.0]) / 16.0


def _reflect(idx: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """Indices outside 0 .. n-1 mirrored about the ends (no repeated end sample), any far."""
    if n == 1:
        return np.zeros_like(idx)
    p = 2 * (n - 1)
    idx = np.mod(idx, p)
    return np.where(idx > n - 1, p - idx, idx)


def frequency_bands(y: Any, levels: int) -> list[NDArray[np.float64]]:
    """Bruderlin and Williams' frequency bands of signals (multiresolution filtering, 1995).

    ``G_0 = y``; ``G_{k+1}`` is ``G_k`` filtered by the B-spline kernel [1 4 6 4 1] / 16
    spread by 2^k (the expanded kernel of their pyramid, undecimated, so any length works),
    the ends mirrored; band k is ``G_k - G_{k+1}``, the finest first, and the last entry is the
    low pass ``G_levels``. The bands sum to ``y``.

    Parameters
    ----------
    y : array_like, shape (n,) or (n, m)
        Signals, one column per channel, frames along the first axis.
    levels : int
        Number of band-pass bands (>= 1); band k covers about fps / 2^(k+2) .. fps / 2^(k+1).

    Returns
    -------
    list of numpy.ndarray
        ``levels + 1`` arrays of y's shape: the bands, finest first, then the low pass.
    """
    levels = integer(levels, "levels", 1, 30)
    g = np.array(y, dtype=np.float64)
    if g.ndim not in (1, 2) or g.shape[0] < 1 or not np.all(np.isfinite(g)):
        raise InvalidArgumentError(f"frequency_bands: y must be finite, (n,) or (n, m), got "
                                   f"shape {g.shape}")
    n = g.shape[0]
    base = np.arange(n)
    bands = []
    for k in range(levels):
        h = 1 << k
        smooth = sum(w * g[_reflect(base + (i - 2) * h, n)] for i, w in enumerate(_B5))
        bands.append(g - smooth)
        g = smooth
    bands.append(g)
    return bands


def multires_stylize(motion: Motion, gains: Sequence[float]) -> Motion:
    """Style modulation by frequency bands (MultiRes): the baseline of paper 1, Figure 7.

    Bruderlin and Williams' multiresolution motion filtering: each signal is split into
    frequency bands (:func:`frequency_bands`), each band is scaled by its gain and the bands
    are added up again. Here the signals are, for each joint, its low pass (the
    hemisphere-aligned quaternions' low pass, renormalized: the coarsest band, like the base
    layer) and the rotation vectors of the motion about it (the finer bands); and the root
    translation (and the position channels) per coordinate. The low pass's gain (the last)
    scales the translations' low pass; the rotations keep theirs (a gain on a mean rotation
    has no meaning). Gains of 1 give the input back.

    Python and numpy over the C core's quaternion maps: a baseline for figures and
    comparisons, not for a runtime (the method, :func:`mlayer.stylize`, is in C).

    Parameters
    ----------
    motion : Motion
        The clip.
    gains : sequence of float
        One gain per band, finest first, then the low pass's (usually 1): ``len(gains) - 1``
        band-pass levels. ``[1, a, a, a, a, a, 1]`` at 120 fps scales the content from about
        0.9 to 30 Hz by a and keeps the finest band (noise) and the low pass.

    Returns
    -------
    Motion
        The modulated motion on the motion's skeleton.
    """
    g = [_arrays.finite(x, "gains") for x in gains] \
        if isinstance(gains, (list, tuple, np.ndarray)) else None
    if g is None or len(g) < 2:
        raise InvalidArgumentError(f"multires_stylize: gains must list at least 2 numbers (a "
                                   f"band and the low pass), got {gains!r}")
    levels = len(g) - 1

    def modulate(y: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros(y.shape)
        for w, b in zip(g, frequency_bands(y, levels)):
            out += w * b
        return out

    q = quat.continuous(motion.rot)  # (N, J, 4), consecutive frames in one hemisphere
    N, J = q.shape[:2]
    low = frequency_bands(q.reshape(N, 4 * J), levels)[-1].reshape(N, J, 4)
    low = quat.normalize(low)
    v = quat.log(quat.mul(quat.conj(low), q))  # (N, J, 3) about the low pass
    bands = frequency_bands(v.reshape(N, 3 * J), levels)
    vm = sum(w * b for w, b in zip(g[:-1], bands[:-1])) + bands[-1]
    rot = quat.mul(low, quat.exp(vm.reshape(N, J, 3)))
    trans = motion.trans
    if trans.size:
        trans = modulate(trans.reshape(N, -1)).reshape(trans.shape)
    return motion.with_frames(root_pos=modulate(motion.root_pos), rot=rot, trans=trans)
