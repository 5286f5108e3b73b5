"""Motions: a skeleton plus frames of root translation and local joint rotations.

A :class:`Motion` holds numpy arrays, and those arrays are the truth: ``root_pos`` (N, 3),
``rot`` (N, J, 4, scalar-first unit quaternions, local to the parent) and ``trans`` (N, P, 3,
the translations of the P non-root joints that have position channels). The C library's motion
handle (``mlr_motion``) is built only for a moment, to write a file; forward kinematics runs on
the arrays directly (``mlr_fk_arrays``). Why arrays and not a handle:

- every feature (denoising, resampling, learning) consumes and produces numpy arrays; a handle
  would force a copy out and a copy back around each of them, and in-place edits of
  ``m.rot`` would silently not reach it;
- slicing, copying and building a motion with new frames are plain numpy operations, with no
  lifetime to manage across the C boundary;
- the handle costs nothing to build when it is needed (a memcpy of the frames, far below the
  cost of formatting the text).

The skeleton (:class:`Skeleton`: names, parents, OFFSETs, channel layout with each joint's
Euler order, End Sites) is immutable and shared between a motion and the motions derived from
it. It is checked by the C core when it is created, so a skeleton that exists can be written.

Position channels *replace* the OFFSET of their joint, as MotionBuilder and Blender read them
(the Bandai Namco clips put 6 channels on every joint); a root without position channels has
its OFFSET as ``root_pos`` in every frame.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._handles import ReadOnlyAttributes
from .._native import ffi, lib
from .._optional import require
from ..errors import InvalidArgumentError, check
from . import quat
from ._rig import axis, body_height_of
from .quat import from_euler, from_scalar_last, to_euler, to_scipy
from .units import UNITS, human_leg_length, length_unit, units_arg
from .up_axis import axis_name, detect_up

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Motion", "Skeleton", "ScipyFrames", "DEFAULT_ROOT_CHANNELS",
           "DEFAULT_JOINT_CHANNELS", "MIN_FRAME_TIME", "MAX_FRAME_TIME", "depth_first_order"]

DEFAULT_ROOT_CHANNELS = "Xposition Yposition Zposition Zrotation Yrotation Xrotation"
DEFAULT_JOINT_CHANNELS = "Zrotation Yrotation Xrotation"

_ORDER_NAMES = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")  # mlr_euler_order values 0..5


def _readonly(a: NDArray[Any]) -> NDArray[Any]:
    a.setflags(write=False)
    return a


def _enc(s: str) -> bytes:
    return s.encode("utf-8", errors="surrogateescape")


def _packed(fn: Any, h: Any, J: int) -> tuple[str, ...]:
    """The J strings of a C ``*_packed`` accessor (each NUL-terminated, one call for all)."""
    n = fn(h, ffi.NULL, 0)
    buf = ffi.new("char[]", max(n, 1))
    fn(h, buf, n)
    return tuple(ffi.unpack(buf, n).decode("utf-8", errors="surrogateescape").split("\0")[:J])


class _Handle:
    """An ``mlr_motion *`` owned for the duration of a ``with`` block."""

    def __init__(self, ptr: Any) -> None:
        self.ptr = ptr

    def __enter__(self) -> Any:
        return self.ptr

    def __exit__(self, *exc: object) -> None:
        lib.mlr_motion_destroy(self.ptr)
        self.ptr = ffi.NULL


class ScipyFrames(NamedTuple):
    """What :meth:`Motion.to_scipy` returns.

    Attributes
    ----------
    root_pos : numpy.ndarray, shape (N, 3)
        Root translations (a copy).
    rotations : list of scipy.spatial.transform.Rotation
        J stacks of N local rotations, one per joint.
    trans : numpy.ndarray, shape (N, P, 3)
        Translations of the joints with position channels (a copy).
    """
    root_pos: np.ndarray
    rotations: list[Any]
    trans: np.ndarray


def depth_first_order(parents: ArrayLike, joint_names: Sequence[str] | None = None,
                      where: str = "Skeleton") -> NDArray[np.int64]:
    """The depth-first (BVH) order of a joint tree given in any order.

    Parameters
    ----------
    parents : array_like of int, shape (J,)
        The parent of every joint, -1 for the root; any order (a parent may come after its
        children, as in SMPL's order or a glTF node list).
    joint_names : sequence of str, optional
        Names used in the error messages.
    where : str
        The caller, named in the error messages.

    Returns
    -------
    numpy.ndarray of int64, shape (J,)
        ``order``: joint k of the depth-first order is input joint ``order[k]``. The root
        comes first, then each joint's subtree right after it; children keep their input
        order. The identity when ``parents`` already is in depth-first order.

    Raises
    ------
    InvalidArgumentError
        No root or two roots, a parent out of range, a joint that is its own parent or a
        cycle (joints not below the root); the message names the joint.

    Notes
    -----
    The C core computes it (``mlr_rig_depth_first_order`` in ``mlr_rig.h``), in O(J).
    """
    par = np.asarray(parents).reshape(-1)
    J = par.shape[0]
    if J == 0:
        raise InvalidArgumentError(f"{where}: needs at least one joint")
    if np.any(par < np.iinfo(np.int32).min) or np.any(par > np.iinfo(np.int32).max):
        j = int(np.flatnonzero((par < -1) | (par >= J))[0])
        raise InvalidArgumentError(f"{where}: joint {j} has parent {int(par[j])}, outside "
                                   f"-1..{J - 1}")
    par32 = np.ascontiguousarray(par, dtype=np.int32)
    order = np.empty(J, dtype=np.int32)
    keep: list[Any] = []  # the name buffers live until the call returns
    cnames = ffi.NULL
    if joint_names is not None:
        keep = [ffi.new("char[]", str(n).encode("utf-8", errors="surrogateescape"))
                for n in joint_names]
        cnames = ffi.new("const char *[]", keep)
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_rig_depth_first_order(J, ffi.cast("const int32_t *", ffi.from_buffer(par32)),
                                        cnames, ffi.cast("int32_t *", ffi.from_buffer(order)),
                                        ffi.NULL, diag), where, diag)
    return order.astype(np.int64)


class Skeleton(ReadOnlyAttributes):
    """Joint names, parents, OFFSETs, channel layout and End Sites; immutable.

    Assigning an attribute raises AttributeError, the arrays are read-only. Joints are in BVH
    depth-first order: joint 0 is the root (parent -1) and every parent comes before its
    children, each joint's subtree right after it. Joints given in another order (any tree:
    SMPL's order, a glTF node list, parents after their children) are reordered to the
    depth-first order when the skeleton is made (:func:`depth_first_order`; children keep
    their relative order); ``source_order[k]`` is then the input index of joint k, so frames
    in the input order become the skeleton's with ``rot[:, skeleton.source_order]``
    (:meth:`Motion.from_arrays` does that itself). End Sites are kept only so that a written
    file has the same hierarchy; they are not joints (forward kinematics leaves them out). The
    C core checks the skeleton when it is created, so a skeleton that exists can be written.

    Parameters
    ----------
    joint_names : iterable of str
        J names (J >= 1).
    parents : array_like of int, shape (J,)
        The parent of every joint, -1 for the root; any tree order.
    offsets : array_like, shape (J, 3)
        The OFFSETs.
    channels : sequence of str, optional
        One string per joint as on a CHANNELS line without the count (e.g.
        ``"Zrotation Xrotation Yrotation"``; a sequence of channel names is joined); default:
        :data:`DEFAULT_ROOT_CHANNELS` for the root, :data:`DEFAULT_JOINT_CHANNELS` for the
        others.
    end_site_parents : array_like of int, shape (E,), optional
        The joint of each End Site (non-decreasing).
    end_site_offsets : array_like, shape (E, 3), optional
        Their OFFSETs (default zeros).

    Attributes
    ----------
    parents : numpy.ndarray of int32, shape (J,)
        As given.
    offsets : numpy.ndarray, shape (J, 3)
        As given.
    channels : tuple of str
        The canonical channel list of each joint.
    euler_orders : tuple of str
        Each joint's Euler order, e.g. ``"ZXY"``, from its rotation channels.
    end_site_parents : numpy.ndarray of int32, shape (E,)
        As given.
    end_site_offsets : numpy.ndarray, shape (E, 3)
        As given.
    trans_joints : numpy.ndarray of int32, shape (P,)
        The non-root joints with position channels.
    n_channels : int
        Channels per frame.
    source_order : numpy.ndarray of int64, shape (J,)
        The input index of each joint (the identity for joints given in depth-first order).

    Raises
    ------
    mlayer.InvalidArgumentError
        For names, parents, offsets, channels or End Sites the C core refuses.
    """
    parents: NDArray[np.int32]
    offsets: NDArray[np.float64]
    channels: tuple[str, ...]
    euler_orders: tuple[str, ...]
    end_site_parents: NDArray[np.int32]
    end_site_offsets: NDArray[np.float64]
    trans_joints: NDArray[np.int32]
    n_channels: int
    source_order: NDArray[np.intp]

    __slots__ = ("_names", "parents", "offsets", "channels", "euler_orders",
                 "end_site_parents", "end_site_offsets", "trans_joints", "n_channels",
                 "source_order")
    _readonly = __slots__

    def __init__(self, joint_names: Iterable[str], parents: ArrayLike, offsets: ArrayLike,
                 channels: Sequence[str | Sequence[str]] | None = None,
                 end_site_parents: ArrayLike = (),
                 end_site_offsets: ArrayLike | None = None) -> None:
        names = [str(n) for n in joint_names]
        J = len(names)
        if J == 0:
            raise InvalidArgumentError("Skeleton: needs at least one joint")
        par = np.asarray(parents)
        if par.shape != (J,) or not np.issubdtype(par.dtype, np.integer):
            raise InvalidArgumentError(
                f"Skeleton: parents must be {J} integers, got shape {par.shape} ({par.dtype})")
        par = np.ascontiguousarray(par, dtype=np.int32)
        off = _arrays.as_f64(offsets, "offsets", ndim=2, last=(3,))
        if off.shape[0] != J:
            raise InvalidArgumentError(f"Skeleton: offsets must be ({J}, 3), got {off.shape}")
        if channels is None:  # the root's by its parent -1, whatever the order
            channels = [DEFAULT_ROOT_CHANNELS if p == -1 else DEFAULT_JOINT_CHANNELS
                        for p in par.tolist()]
        elif isinstance(channels, str):
            raise InvalidArgumentError("Skeleton: channels must be a list of one string per joint")
        chans: list[str] = [c if isinstance(c, str) else " ".join(c) for c in channels]
        if len(chans) != J:
            raise InvalidArgumentError(
                f"Skeleton: channels must list {J} joints, got {len(chans)}")
        ep = np.asarray(end_site_parents if end_site_parents is not None else ())
        if ep.size == 0:
            ep = np.zeros(0, dtype=np.int32)
        if ep.ndim != 1 or not np.issubdtype(ep.dtype, np.integer):
            raise InvalidArgumentError("Skeleton: end_site_parents must be a 1-D integer array")
        ep = np.ascontiguousarray(ep, dtype=np.int32)
        E = ep.shape[0]
        if end_site_offsets is None:
            eo = np.zeros((E, 3))
        else:
            eo = _arrays.as_f64(end_site_offsets, "end_site_offsets", ndim=2, last=(3,)) \
                if E else np.zeros((0, 3))
        if eo.shape != (E, 3):
            raise InvalidArgumentError(f"Skeleton: end_site_offsets must be ({E}, 3), got "
                                       f"{eo.shape}")
        order = depth_first_order(par, names)
        if not np.array_equal(order, np.arange(J)):
            names, par, off, chans, ep, eo = _reordered(order, names, par, off, chans, ep, eo)
        # Let the C core judge names, parents, channel lists and End Sites; read back its
        # canonical channel lists, Euler orders and the joints with position channels.
        with _create_handle(names, par, off, chans, ep, eo, 0, 1.0) as h:
            self._from_handle(h)
        self.source_order = _readonly(order)

    @classmethod
    def _from_c(cls, h: Any) -> Skeleton:
        self = cls.__new__(cls)
        self._from_handle(h)
        self.source_order = _readonly(np.arange(self.n_joints))
        return self

    def _from_handle(self, h: Any) -> None:
        J = lib.mlr_motion_n_joints(h)
        self._names = _packed(lib.mlr_motion_joint_names_packed, h, J)
        self.parents = _readonly(np.frombuffer(
            ffi.buffer(lib.mlr_motion_parents(h), 4 * J), dtype=np.int32).copy())
        self.offsets = _readonly(np.frombuffer(
            ffi.buffer(lib.mlr_motion_offsets(h), 24 * J), dtype=np.float64).reshape(J, 3).copy())
        self.channels = _packed(lib.mlr_motion_joint_channels_packed, h, J)
        orders = ffi.new("int32_t[]", max(J, 1))
        lib.mlr_motion_joint_euler_orders(h, orders)
        self.euler_orders = tuple(_ORDER_NAMES[o] for o in ffi.unpack(orders, J))
        E = lib.mlr_motion_n_end_sites(h)
        self.end_site_parents = _readonly(
            np.frombuffer(ffi.buffer(lib.mlr_motion_end_site_parents(h), 4 * E),
                          dtype=np.int32).copy() if E else np.zeros(0, dtype=np.int32))
        self.end_site_offsets = _readonly(
            np.frombuffer(ffi.buffer(lib.mlr_motion_end_site_offsets(h), 24 * E),
                          dtype=np.float64).reshape(E, 3).copy() if E else np.zeros((0, 3)))
        P = lib.mlr_motion_n_trans(h)
        self.trans_joints = _readonly(
            np.frombuffer(ffi.buffer(lib.mlr_motion_trans_joints(h), 4 * P),
                          dtype=np.int32).copy() if P else np.zeros(0, dtype=np.int32))
        self.n_channels = int(lib.mlr_motion_n_channels(h))

    @property
    def joint_names(self) -> list[str]:
        """The J joint names (a new list)."""
        return list(self._names)

    @property
    def n_joints(self) -> int:
        """The number of joints J."""
        return len(self._names)

    @property
    def n_end_sites(self) -> int:
        """The number of End Sites E."""
        return int(self.end_site_parents.shape[0])

    def index(self, name: str) -> int:
        """Index of a joint.

        Parameters
        ----------
        name : str
            The joint's name.

        Returns
        -------
        int
            Its index.

        Raises
        ------
        mlayer.InvalidArgumentError
            (a ValueError) When there is no such joint.
        """
        try:
            return self._names.index(name)
        except ValueError:
            raise InvalidArgumentError(f"no joint named {name!r}") from None

    def children(self, j: int) -> list[int]:
        """The children of a joint.

        Parameters
        ----------
        j : int
            A joint index.

        Returns
        -------
        list of int
            The joints whose parent is ``j``, in order.
        """
        return [k for k in range(self.n_joints) if self.parents[k] == j]

    def depth(self) -> NDArray[np.int64]:
        """Depth of every joint in the tree.

        Returns
        -------
        numpy.ndarray of int64, shape (J,)
            0 for the root.
        """
        d = np.zeros(self.n_joints, dtype=np.int64)
        for j in range(1, self.n_joints):
            d[j] = d[self.parents[j]] + 1
        return d

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Skeleton):
            return NotImplemented
        return (self._names == other._names and self.channels == other.channels
                and np.array_equal(self.parents, other.parents)
                and np.array_equal(self.offsets, other.offsets)
                and np.array_equal(self.end_site_parents, other.end_site_parents)
                and np.array_equal(self.end_site_offsets, other.end_site_offsets))

    # equal skeletons compare equal: unhashable
    __hash__: ClassVar[None] = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (f"Skeleton({self.n_joints} joints, {self.n_end_sites} End Sites, "
                f"{self.n_channels} channels, root {self._names[0]!r})")


def _reordered(order: NDArray[np.int64], names: list[str], par: NDArray[Any],
               off: NDArray[np.float64], channels: list[str], ep: NDArray[Any],
               eo: NDArray[np.float64]) -> tuple[Any, ...]:
    """The skeleton arrays in the joint order ``order`` (from :func:`depth_first_order`):
    parents renumbered, End Sites renumbered and sorted by their new parent (stable)."""
    inv = np.empty_like(order)
    inv[order] = np.arange(order.shape[0])
    par = np.ascontiguousarray(np.where(par[order] < 0, -1, inv[par[order]]), dtype=np.int32)
    names = [names[j] for j in order]
    channels = [channels[j] for j in order]
    off = np.ascontiguousarray(off[order])
    if ep.shape[0]:
        if ep.min() < 0 or ep.max() >= order.shape[0]:
            raise InvalidArgumentError(f"Skeleton: end_site_parents must be joint indices in "
                                       f"[0, {order.shape[0]}), got {ep.tolist()}")
        ep = inv[ep]
        by = np.argsort(ep, kind="stable")
        ep, eo = np.ascontiguousarray(ep[by], dtype=np.int32), np.ascontiguousarray(eo[by])
    return names, par, off, channels, ep, eo


def _frames_in_order(skel: Skeleton, order: NDArray[np.int64], rot: ArrayLike,
                     trans: ArrayLike | None) -> tuple[NDArray[np.float64], Any]:
    """Frames given in the input joint order of a reordered skeleton, in its own order:
    ``rot`` (N, J, 4) by ``order``; ``trans`` (N, P, 3), one column per joint with position
    channels in increasing *input* index, reordered to the skeleton's ``trans_joints``."""
    J = skel.n_joints
    rot = np.take(_frame_array(rot, "Motion: rot", (J, 4)), order, axis=1)
    if trans is not None:
        P = skel.trans_joints.shape[0]
        trans = _frame_array(trans, "Motion: trans", (P, 3))
        src = np.sort(order[skel.trans_joints])  # the input indices, in the input's order
        trans = trans[:, np.searchsorted(src, order[skel.trans_joints])]
    return np.ascontiguousarray(rot), trans


class _CFrames:
    """A float64 block inside a C motion handle, seen by numpy through the array interface.

    The numpy array keeps this object as its base, and this object keeps ``owner`` (the handle,
    with ``mlr_motion_destroy`` as its finalizer), so the memory lives as long as any array on
    it does.
    """

    __slots__ = ("__array_interface__", "_owner")

    def __init__(self, owner: Any, ptr: Any, shape: tuple[int, ...]) -> None:
        self._owner = owner
        self.__array_interface__ = {"shape": tuple(shape), "typestr": np.dtype(np.float64).str,
                                    "version": 3, "data": (int(ffi.cast("uintptr_t", ptr)), False)}

    def array(self) -> NDArray[np.float64]:
        return np.asarray(self)


MIN_FRAME_TIME = 1e-6
"""The shortest frame time a Motion takes, in seconds (a million frames per second). Shorter
ones are mistakes or hostile files (a BVH with Frame Time 1e-300 made every rate-dependent
step overflow) and are refused with InvalidArgumentError (ParseError from the readers)."""

MAX_FRAME_TIME = 1e6
"""The longest frame time a Motion takes, in seconds (a frame every 11.6 days). Longer ones
are mistakes: ``frame_time = 1e308`` made the clip's duration infinite (write_gltf failed)."""


def _frame_time_arg(v: Any, name: str) -> float:
    if isinstance(v, (bool, np.bool_)):
        raise InvalidArgumentError(f"{name} must be a number of seconds, got {v!r}")
    ft = _arrays.finite(v, name)
    if not ft >= MIN_FRAME_TIME:
        raise InvalidArgumentError(f"{name} must be at least {MIN_FRAME_TIME:g} s (finite, "
                                   f"at most 1e6 frames per second), got {v!r}")
    if ft > MAX_FRAME_TIME:
        raise InvalidArgumentError(f"{name} must be at most {MAX_FRAME_TIME:g} s "
                                   f"(mlayer.model.motion.MAX_FRAME_TIME), got {v!r}")
    return ft


def _frame_array(a: ArrayLike, name: str, tail: tuple[int, ...]) -> NDArray[np.float64]:
    """A frame array as C-contiguous float64 of shape (N,) + tail, with finite values."""
    a = _arrays.as_f64(a, name, ndim=1 + len(tail))
    if a.shape[1:] != tail:
        raise InvalidArgumentError(f"{name} must have shape (N, {', '.join(map(str, tail))}), "
                                   f"got {a.shape}")
    _arrays.require_finite(a, name)
    return a


def _unit_quaternions(rot: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """rot (N, J, 4), or InvalidArgumentError naming the first quaternion that is not unit."""
    if rot.shape[0]:
        norm = np.sqrt(np.einsum("...i,...i->...", rot, rot))
        bad = np.abs(norm - 1.0) > 1e-6
        if bad.any():
            f, j = np.argwhere(bad)[0]
            raise InvalidArgumentError(
                f"{name}[{f}, {j}] has norm {norm[f, j]:.9g}, expected unit quaternions "
                "(mlayer.quat.normalize)")
    return rot


def _create_handle(names: Sequence[str], parents: NDArray[np.int32],
                   offsets: NDArray[np.float64], channels: Sequence[str],
                   end_parents: NDArray[np.int32], end_offsets: NDArray[np.float64],
                   n_frames: int, frame_time: float) -> _Handle:
    J, E = len(names), end_parents.shape[0]
    keep = [ffi.new("char[]", _enc(n)) for n in names]
    keep_ch = [ffi.new("char[]", _enc(c)) for c in channels]
    c_names = ffi.new("const char *[]", keep)
    c_ch = ffi.new("const char *[]", keep_ch)
    out = ffi.new("mlr_motion **")
    diag = ffi.new("mlr_diag *")
    code = lib.mlr_motion_create(
        J, c_names, ffi.cast("const int32_t *", ffi.from_buffer(parents)),
        _arrays.ptr(offsets), c_ch, E,
        ffi.cast("const int32_t *", ffi.from_buffer(end_parents)) if E else ffi.NULL,
        _arrays.ptr(end_offsets) if E else ffi.NULL, n_frames, frame_time, ffi.NULL, out, diag)
    check(code, "mlayer.Skeleton", diag)
    return _Handle(out[0])


class Motion:
    """A skeleton and N frames. See the module docstring for the data model.

    The numpy arrays are the data; edit them in place or build a new motion with
    :meth:`with_frames`. Assigned arrays are checked (dtype, dimensions, the skeleton's
    joints, finite values, unit quaternions for ``rot``) and converted to C-contiguous
    float64; ``frame_time``, ``skeleton``, ``up_axis`` and ``units`` are checked too, and the
    other attributes are read-only (InvalidArgumentError or AttributeError when assigned).
    ``m[a:b]`` (or ``m[a:b:k]``) is a new motion holding copies of those frames (a step k
    multiplies the frame time by k); ``len(m)`` is the number of frames.

    Parameters
    ----------
    skeleton : Skeleton
        The skeleton (shared, immutable).
    frame_time : float
        Seconds per frame, :data:`MIN_FRAME_TIME` .. :data:`MAX_FRAME_TIME`.
    root_pos : array_like, shape (N, 3)
        Root translations.
    rot : array_like, shape (N, J, 4)
        Local rotations, scalar-first unit quaternions.
    trans : array_like, shape (N, P, 3), optional
        Translations of the joints ``skeleton.trans_joints`` (the non-root joints with
        position channels; they replace those joints' OFFSETs); default: their OFFSETs. P is
        usually 0.

    Raises
    ------
    mlayer.InvalidArgumentError
        For arrays of other shapes, non-finite values, quaternions that are not unit, or a
        frame time out of range.

    Examples
    --------
    >>> import mlayer
    >>> m = mlayer.data.load_sample()
    >>> len(m[:120]), m[:120:2].n_frames
    (120, 60)
    """

    __slots__ = ("_skeleton", "_frame_time", "_root_pos", "_rot", "_trans", "_up", "_units",
                 "_found")
    _skeleton: Skeleton
    _frame_time: float
    _root_pos: NDArray[np.float64]
    _rot: NDArray[np.float64]
    _trans: NDArray[np.float64]
    _up: str | None
    _units: str | None

    def __init__(self, skeleton: Skeleton, frame_time: float, root_pos: ArrayLike,
                 rot: ArrayLike, trans: ArrayLike | None = None, *,
                 _trusted: bool = False) -> None:
        if not isinstance(skeleton, Skeleton):
            raise InvalidArgumentError("Motion: skeleton must be a mlayer.Skeleton")
        self._skeleton = skeleton
        self._up = None
        self._units = None
        self._found: dict[str, Any] = {}  # what was detected from the frames: "up", "units"
        if _trusted:
            # the readers and the library's own copies: arrays already checked
            self._frame_time, self._root_pos, self._rot, self._trans = \
                frame_time, cast(Any, root_pos), cast(Any, rot), cast(Any, trans)
            return
        ft = _frame_time_arg(frame_time, "Motion: frame_time")
        J, P = skeleton.n_joints, skeleton.trans_joints.shape[0]
        rot = _frame_array(rot, "Motion: rot", (J, 4))
        N = rot.shape[0]
        root_pos = _frame_array(root_pos, "Motion: root_pos", (3,))
        if root_pos.shape[0] != N:
            raise InvalidArgumentError(f"Motion: root_pos must be ({N}, 3), got {root_pos.shape}")
        if trans is None:
            if P:
                trans = np.broadcast_to(skeleton.offsets[skeleton.trans_joints], (N, P, 3)).copy()
            else:
                trans = np.zeros((N, 0, 3))
        trans = _frame_array(trans, "Motion: trans", (P, 3))
        if trans.shape != (N, P, 3):
            raise InvalidArgumentError(f"Motion: trans must be ({N}, {P}, 3), got {trans.shape}")
        _unit_quaternions(rot, "Motion: rot")
        self._frame_time, self._root_pos, self._rot, self._trans = ft, root_pos, rot, trans

    # ---- the attributes, checked when they are assigned ------------------------------------
    # An assignment is checked on its own (dtype, dimensions, the skeleton's joints, finite
    # values) and converted to C-contiguous float64; the frame counts of the three arrays are
    # compared by _frames() before every C call, since they may be replaced one at a time.

    @property
    def skeleton(self) -> Skeleton:
        """The :class:`Skeleton` (assignable, to another Skeleton)."""
        return self._skeleton

    @skeleton.setter
    def skeleton(self, sk: Skeleton) -> None:
        if not isinstance(sk, Skeleton):
            raise InvalidArgumentError("Motion.skeleton must be a mlayer.Skeleton, got "
                                       f"{type(sk).__name__}")
        self._skeleton = sk

    @property
    def frame_time(self) -> float:
        """Seconds per frame (:attr:`fps` is its inverse); assignable, in
        :data:`MIN_FRAME_TIME` .. :data:`MAX_FRAME_TIME`."""
        return self._frame_time

    @frame_time.setter
    def frame_time(self, v: float) -> None:
        self._frame_time = _frame_time_arg(v, "Motion.frame_time")

    @property
    def root_pos(self) -> NDArray[np.float64]:
        """(N, 3) root translations."""
        return self._root_pos

    @root_pos.setter
    def root_pos(self, a: ArrayLike) -> None:
        self._root_pos = _frame_array(a, "Motion.root_pos", (3,))
        self._found.clear()

    @property
    def rot(self) -> NDArray[np.float64]:
        """(N, J, 4) local rotations, scalar-first unit quaternions (checked when assigned)."""
        return self._rot

    @rot.setter
    def rot(self, a: ArrayLike) -> None:
        rot = _frame_array(a, "Motion.rot", (self._skeleton.n_joints, 4))
        self._rot = _unit_quaternions(rot, "Motion.rot")
        self._found.clear()

    @property
    def trans(self) -> NDArray[np.float64]:
        """(N, P, 3) translations of the joints ``skeleton.trans_joints``."""
        return self._trans

    @trans.setter
    def trans(self, a: ArrayLike) -> None:
        self._trans = _frame_array(a, "Motion.trans",
                                   (self._skeleton.trans_joints.shape[0], 3))
        self._found.clear()

    @property
    def up_axis(self) -> str:
        """The world axis that points up, ``"x"``, ``"y"`` or ``"z"``.

        Given by ``read_bvh(path, up=...)`` or by assigning it; else detected from the motion
        (:func:`mlayer.detect_up`: from the feet by name, or the floor), and ``"y"`` (the BVH
        convention) when the detection is not sure. Every threshold along up (contacts, floor,
        body height) follows it. The detection runs once, on first use (one
        forward-kinematics pass), and is kept; assign None to detect again (after editing the
        frames in place, say).
        """
        if self._up is not None:
            return self._up
        if "up" not in self._found:
            g = detect_up(self)
            self._found["up"] = g.axis if g.sure else "y"
        return self._found["up"]

    @up_axis.setter
    def up_axis(self, up: str | None) -> None:
        self._up = axis_name(up, "Motion.up_axis")
        self._found.clear()

    @property
    def units(self) -> str | None:
        """The clip's length unit, ``"m"``, ``"cm"``, ``"mm"``, ``"in"``, ``"ft"`` or None.

        The unit when given (``read_bvh(path, units=...)``, ``--units``, or assigned), else
        the unit the body's size suggests (:func:`mlayer.model.units.length_unit`: for a human rig
        the one unit that gives a person's height and leg length, inches and feet included; for
        other rigs ``"m"``, ``"cm"`` or ``"mm"`` when the height is an animal's in just that
        unit), else None: never a guess where two units fit.
        Thresholds do not depend on it (they are relative to the body height); conversions to
        metres do. Found once, on first use, and kept (assign None to look again).
        """
        if self._units is not None:
            return self._units
        if "units" not in self._found:
            self._found["units"] = (length_unit(body_height_of(self.positions(),
                                                               axis(self.up_axis, "units")),
                                                leg=human_leg_length(self))
                                    if self.n_frames else None)
        return self._found["units"]

    @units.setter
    def units(self, units: str | None) -> None:
        self._units = units_arg(units, "Motion.units")
        self._found.pop("units", None)

    @property
    def metres_per_unit(self) -> float | None:
        """The size of the clip's length unit in metres (from :attr:`units`), or None."""
        u = self.units
        return UNITS[u] if u else None

    def _same_up(self, other: Motion) -> Motion:
        """Carry what was said about other (up axis, units) over to this motion of its frames."""
        self._up, self._units = other._up, other._units
        return self

    # ---- construction ----------------------------------------------------------------------

    @classmethod
    def from_arrays(cls, joint_names: Iterable[str], parents: ArrayLike, offsets: ArrayLike,
                    root_pos: ArrayLike, rot: ArrayLike, *, fps: float | None = None,
                    frame_time: float | None = None,
                    channels: Sequence[str | Sequence[str]] | None = None,
                    trans: ArrayLike | None = None, end_site_parents: ArrayLike = (),
                    end_site_offsets: ArrayLike | None = None) -> Motion:
        """Build a motion from arrays.

        Joints not in depth-first order (SMPL's, a parent after its children) are reordered to
        it, with their rotations, translations and End Sites, so the motion's joint order is the
        depth-first one (``skeleton.source_order[k]`` is the input index of joint k).

        Parameters
        ----------
        joint_names : iterable of str
            J names.
        parents : array_like of int, shape (J,)
            -1 for the root; any tree order.
        offsets : array_like, shape (J, 3)
            The OFFSETs.
        root_pos : array_like, shape (N, 3)
            Root translations.
        rot : array_like, shape (N, J, 4)
            Unit quaternions (w, x, y, z).
        fps, frame_time : float, optional
            One or the other (default 30 fps).
        channels : sequence of str, optional
            One string per joint as on a CHANNELS line without the count (e.g.
            ``"Zrotation Xrotation Yrotation"``); default: the root
            ``"Xposition Yposition Zposition Zrotation Yrotation Xrotation"``, the others
            ``"Zrotation Yrotation Xrotation"``.
        trans : array_like, shape (N, P, 3), optional
            Translations of the non-root joints whose channels include positions (default:
            their OFFSETs).
        end_site_parents : array_like of int, shape (E,), optional
            End Site parent joints (non-decreasing), written back to files only.
        end_site_offsets : array_like, shape (E, 3), optional
            Their OFFSETs.

        Returns
        -------
        Motion
            The motion, on a new :class:`Skeleton`.

        Raises
        ------
        mlayer.InvalidArgumentError
            For both fps and frame_time, a bad fps, or anything :class:`Skeleton` and
            :class:`Motion` refuse.
        """
        if fps is not None and frame_time is not None:
            raise InvalidArgumentError("from_arrays: give fps or frame_time, not both")
        if frame_time is None:
            fps = 30.0 if fps is None else float(fps)
            if not (np.isfinite(fps) and fps > 0):
                raise InvalidArgumentError(f"from_arrays: fps must be finite and > 0, got {fps}")
            frame_time = 1.0 / fps
        skel = Skeleton(joint_names, parents, offsets, channels, end_site_parents,
                        end_site_offsets)
        order = skel.source_order
        if not np.array_equal(order, np.arange(order.shape[0])):
            rot, trans = _frames_in_order(skel, order, rot, trans)
        return cls(skel, frame_time, root_pos, rot, trans)

    def with_frames(self, root_pos: ArrayLike | None = None, rot: ArrayLike | None = None,
                    trans: ArrayLike | None = None, *,
                    frame_time: float | None = None) -> Motion:
        """A new motion on the same skeleton with new frames.

        Arrays not given are copied from this motion (they must then keep its frame count);
        the arrays given are checked (shapes, finite values, unit quaternions) and used without
        a copy when they already are C-contiguous float64.

        Parameters
        ----------
        root_pos : array_like, shape (N, 3), optional
            New root translations.
        rot : array_like, shape (N, J, 4), optional
            New local rotations.
        trans : array_like, shape (N, P, 3), optional
            New joint translations.
        frame_time : float, optional
            A new frame time.

        Returns
        -------
        Motion
            The new motion (with this one's up axis and units, when they were given).
        """
        return Motion(self.skeleton, self.frame_time if frame_time is None else frame_time,
                      self.root_pos.copy() if root_pos is None else root_pos,
                      self.rot.copy() if rot is None else rot,
                      self.trans.copy() if trans is None else trans)._same_up(self)

    def copy(self) -> Motion:
        """A deep copy of the frames (the immutable skeleton is shared).

        Returns
        -------
        Motion
            The copy.
        """
        return Motion(self.skeleton, self.frame_time, self.root_pos.copy(), self.rot.copy(),
                      self.trans.copy(), _trusted=True)._same_up(self)

    # ---- sizes and skeleton shortcuts ------------------------------------------------------

    @property
    def joint_names(self) -> list[str]:
        """The skeleton's joint names."""
        return self.skeleton.joint_names

    @property
    def parents(self) -> NDArray[np.int32]:
        """The skeleton's parents, (J,)."""
        return self.skeleton.parents

    @property
    def offsets(self) -> NDArray[np.float64]:
        """The skeleton's OFFSETs, (J, 3)."""
        return self.skeleton.offsets

    @property
    def channels(self) -> tuple[str, ...]:
        """The skeleton's channel list of each joint."""
        return self.skeleton.channels

    @property
    def euler_orders(self) -> tuple[str, ...]:
        """The skeleton's Euler order of each joint."""
        return self.skeleton.euler_orders

    @property
    def trans_joints(self) -> NDArray[np.int32]:
        """The joints with position channels, (P,)."""
        return self.skeleton.trans_joints

    @property
    def end_site_parents(self) -> NDArray[np.int32]:
        """The skeleton's End Site parents, (E,)."""
        return self.skeleton.end_site_parents

    @property
    def end_site_offsets(self) -> NDArray[np.float64]:
        """The skeleton's End Site OFFSETs, (E, 3)."""
        return self.skeleton.end_site_offsets

    @property
    def n_joints(self) -> int:
        """The number of joints J."""
        return self.skeleton.n_joints

    @property
    def n_frames(self) -> int:
        """The number of frames N."""
        return int(self.rot.shape[0])

    @property
    def fps(self) -> float:
        """Frames per second, ``1 / frame_time``."""
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Length in seconds, N frame times (each frame stands for one frame time)."""
        return self.n_frames * self.frame_time

    def __len__(self) -> int:
        return self.n_frames

    def __getitem__(self, key: int | np.integer[Any] | slice) -> Motion:
        N = self.n_frames
        if isinstance(key, (int, np.integer)):
            i = int(key)
            if i < -N or i >= N:
                raise IndexError(f"frame {i} out of range for {N} frames")
            key = slice(i % N, i % N + 1)
        if not isinstance(key, slice):
            raise TypeError("Motion indices are frame slices m[a:b:k] or single frames m[i]")
        start, stop, step = key.indices(N)
        if step <= 0:
            raise InvalidArgumentError("Motion slices need a positive step")
        root, rot, trans = self._frames()  # the arrays agree (they may have been replaced)
        return Motion(self.skeleton, _frame_time_arg(self.frame_time * step, "Motion slice"),
                      root[start:stop:step].copy(order="C"), rot[start:stop:step].copy(order="C"),
                      trans[start:stop:step].copy(order="C"), _trusted=True)._same_up(self)

    # ---- kinematics ------------------------------------------------------------------------

    def local_translations(self) -> NDArray[np.float64]:
        """Translation of every joint relative to its parent.

        Returns
        -------
        numpy.ndarray, shape (N, J, 3)
            ``root_pos`` for the root, the position channels where a joint has them, the
            OFFSET otherwise.
        """
        t = np.broadcast_to(self.skeleton.offsets, (self.n_frames, self.n_joints, 3)).copy()
        t[:, 0] = self.root_pos
        if self.trans.shape[1]:
            t[:, self.skeleton.trans_joints] = self.trans
        return t

    def _frames(self, finite: bool = False) -> list[NDArray[np.float64]]:
        """(root_pos, rot, trans) checked for a C call: C-contiguous float64 arrays of the
        shapes (N, 3), (N, J, 4), (N, P, 3) of the skeleton, without a copy when they already
        are; with ``finite``, also free of NaN and infinities. The attributes are public and
        may have been replaced (or reshaped in place) since the motion was made, so every
        wrapper that hands a motion's frames to C takes them from here: an array C would read
        past its end raises InvalidArgumentError instead."""
        sk = self._skeleton
        if not isinstance(sk, Skeleton):
            raise InvalidArgumentError("Motion.skeleton must be a mlayer.Skeleton")
        _frame_time_arg(self._frame_time, "Motion.frame_time")
        J, P = sk.n_joints, sk.trans_joints.shape[0]
        rot = _arrays.as_f64(self._rot, "Motion.rot", ndim=3)
        N = rot.shape[0]
        out = []
        for a, name, shape in ((self._root_pos, "root_pos", (N, 3)), (rot, "rot", (N, J, 4)),
                               (self._trans, "trans", (N, P, 3))):
            a = _arrays.as_f64(a, f"Motion.{name}")
            if a.shape != shape:
                raise InvalidArgumentError(f"Motion.{name}: expected shape {shape} (the "
                                           f"skeleton's joints, {N} frames as rot), got {a.shape}")
            if finite:
                _arrays.require_finite(a, f"Motion.{name}")
            out.append(a)
        return out

    def _fk(self, want_rot: bool) -> tuple[NDArray[np.float64], Any]:
        N, J = self.n_frames, self.n_joints
        sk = self.skeleton
        root_pos, rot, trans = self._frames()
        pos = np.empty((N, J, 3))
        wrot = np.empty((N, J, 4)) if want_rot else None
        if N == 0:
            return pos, wrot
        P = sk.trans_joints.shape[0]
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_fk_arrays(
            N, J, ffi.cast("const int32_t *", ffi.from_buffer(sk.parents)),
            _arrays.ptr(sk.offsets), _arrays.ptr(root_pos), _arrays.ptr(rot), P,
            ffi.cast("const int32_t *", ffi.from_buffer(sk.trans_joints)) if P else ffi.NULL,
            _arrays.ptr(trans) if P else ffi.NULL, _arrays.ptr_out(pos),
            _arrays.ptr_out(wrot) if wrot is not None else ffi.NULL, ffi.NULL, diag)
        check(code, "mlayer.Motion.positions", diag)
        return pos, wrot

    def positions(self) -> NDArray[np.float64]:
        """World positions of the joints, by forward kinematics in the C core.

        Returns
        -------
        numpy.ndarray, shape (N, J, 3)
            End Sites excluded.
        """
        return self._fk(False)[0]

    def world_rotations(self) -> NDArray[np.float64]:
        """World rotations of the joints.

        Returns
        -------
        numpy.ndarray, shape (N, J, 4)
            Scalar-first quaternions.
        """
        return self._fk(True)[1]

    def forward_kinematics(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World positions and world rotations in one pass.

        Returns
        -------
        positions : numpy.ndarray, shape (N, J, 3)
            World joint positions.
        rotations : numpy.ndarray, shape (N, J, 4)
            World joint rotations.
        """
        return self._fk(True)

    def end_site_positions(self) -> NDArray[np.float64]:
        """World positions of the End Sites.

        Returns
        -------
        numpy.ndarray, shape (N, E, 3)
            The positions.
        """
        return self._end_sites(*self._fk(True))

    def _end_sites(self, pos: np.ndarray, wrot: np.ndarray) -> np.ndarray:
        """(N, E, 3) End Site positions from this motion's forward kinematics (pos, wrot)."""
        sk = self.skeleton
        if sk.n_end_sites == 0:
            return np.zeros((self.n_frames, 0, 3))
        q = wrot[:, sk.end_site_parents]
        v = np.concatenate([np.zeros(q.shape[:-1] + (1,)),
                            np.broadcast_to(sk.end_site_offsets, q.shape[:-1] + (3,))], axis=-1)
        r = quat.mul(quat.mul(q, v), quat.conj(q))[..., 1:]
        return pos[:, sk.end_site_parents] + r

    # ---- bridges to scipy and pandas -------------------------------------------------------

    def to_scipy(self) -> ScipyFrames:
        """The frames with the rotations as scipy rotations, one stack per joint.

        ``rotations[j]`` is a ``scipy.spatial.transform.Rotation`` of the N local rotations of
        joint j (:func:`mlayer.model.quat.to_scipy` of ``rot[:, j]``: scalar-first turned
        scalar-last), so ``rotations[j].as_euler("ZXY", degrees=True)`` or
        ``rotations[j][f].apply(v)`` work with any scipy. :meth:`from_scipy` is the inverse:
        ``Motion.from_scipy(m.skeleton, m.frame_time, *m.to_scipy())``. Needs scipy (the
        ``scipy`` extra).

        Returns
        -------
        ScipyFrames
            ``(root_pos, rotations, trans)``; root_pos (N, 3) and trans (N, P, 3) are copies.

        Raises
        ------
        mlayer.MissingDependencyError
            Without scipy.
        """
        require("scipy", feature="mlayer.Motion.to_scipy")
        root_pos, rot, trans = self._frames()
        return ScipyFrames(root_pos.copy(), [to_scipy(rot[:, j]) for j in range(rot.shape[1])],
                           trans.copy())

    @classmethod
    def from_scipy(cls, skeleton: Skeleton, frame_time: float, root_pos: ArrayLike,
                   rotations: Any, trans: ArrayLike | None = None) -> Motion:
        """A motion of ``skeleton`` from scipy rotations (the inverse of :meth:`to_scipy`).

        Parameters
        ----------
        skeleton : Skeleton
            The skeleton.
        frame_time : float
            Seconds per frame.
        root_pos : array_like, shape (N, 3)
            Root translations.
        rotations : scipy.spatial.transform.Rotation or list of them
            A list of J ``Rotation`` stacks of N frames each (one per joint, as
            :meth:`to_scipy` gives), a ``Rotation`` stack of N * J rotations in frame-major
            order (as ``mlayer.quat.to_scipy(m.rot)`` gives), or a ``Rotation`` of shape
            (N, J) (scipy 1.17 and later).
        trans : array_like, shape (N, P, 3), optional
            As for :class:`Motion` (default: the OFFSETs).

        Returns
        -------
        Motion
            The motion (rotations renormalized).

        Raises
        ------
        mlayer.InvalidArgumentError
            For a count of rotations that does not match the frames and joints.
        """
        if not isinstance(skeleton, Skeleton):
            raise InvalidArgumentError("Motion.from_scipy: skeleton must be a mlayer.Skeleton")
        J = skeleton.n_joints
        root = _frame_array(root_pos, "Motion.from_scipy: root_pos", (3,))
        N = root.shape[0]
        if isinstance(rotations, (list, tuple)):
            if len(rotations) != J:
                raise InvalidArgumentError(f"Motion.from_scipy: {len(rotations)} per-joint "
                                           f"rotation stacks for {J} joints")
            q = np.stack([np.asarray(r.as_quat()).reshape(-1, 4) for r in rotations], axis=1) \
                if J else np.zeros((N, 0, 4))
        elif hasattr(rotations, "as_quat"):
            q = np.asarray(rotations.as_quat())
        else:
            raise InvalidArgumentError("Motion.from_scipy: rotations must be a "
                                       "scipy.spatial.transform.Rotation or a list of them, got "
                                       f"{type(rotations).__name__}")
        if q.size != N * J * 4:
            raise InvalidArgumentError(f"Motion.from_scipy: {q.size // 4} rotations for {N} "
                                       f"frames of {J} joints (root_pos has {N} frames)")
        q = from_scalar_last(q.reshape(N, J, 4))
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        return cls(skeleton, frame_time, root, q, trans)

    def to_dataframe(self) -> pd.DataFrame:
        """The frames as a ``pandas.DataFrame`` like the BVH file's MOTION section.

        One row per frame (index ``frame``, 0 .. N-1), one column per channel in the file's
        order, named by a two-level index (joint, channel), e.g. ``df["Hips", "Xposition"]``,
        ``df["LeftUpLeg", "Zrotation"]``. Positions are in the file's units; rotations are
        Euler angles in degrees in each joint's channel order (:func:`mlayer.model.quat.to_euler`:
        the middle angle in [-90, 90], the others in (-180, 180], as the BVH writer writes
        them). ``df.attrs`` holds ``frame_time`` and ``fps``; for flat column names,
        ``df.columns = ["/".join(c) for c in df.columns]``. Needs pandas (the ``dataframe``
        extra).

        Returns
        -------
        pandas.DataFrame
            The channels.

        Raises
        ------
        mlayer.MissingDependencyError
            Without pandas.
        """
        pd = require("pandas", feature="mlayer.Motion.to_dataframe")
        root_pos, rot, trans = self._frames()
        sk = self.skeleton
        where = {int(j): p for p, j in enumerate(sk.trans_joints)}
        columns, values = [], []
        for j, name in enumerate(sk._names):
            chans = sk.channels[j].split()
            order = sk.euler_orders[j]
            angles = None
            for c in chans:
                axis = "XYZ".index(c[0].upper())
                if c[1:].lower() == "position":
                    v = root_pos[:, axis] if j == 0 else trans[:, where[j], axis]
                else:
                    if angles is None:
                        angles = to_euler(rot[:, j], order)
                    v = angles[:, order.index(c[0].upper())]
                columns.append((name, c))
                values.append(v)
        data = np.stack(values, axis=1) if values else np.zeros((self.n_frames, 0))
        df = pd.DataFrame(data, index=pd.RangeIndex(self.n_frames, name="frame"),
                          columns=pd.MultiIndex.from_tuples(columns, names=["joint", "channel"]))
        df.attrs.update(frame_time=self.frame_time, fps=self.fps)
        return df

    @classmethod
    def from_dataframe(cls, df: pd.DataFrame, skeleton: Skeleton,
                       frame_time: float | None = None) -> Motion:
        """A motion of ``skeleton`` from a table of its BVH channels (the inverse of
        :meth:`to_dataframe`).

        The table has one row per frame and one column per channel of ``skeleton``, named
        ``(joint, channel)`` (a two-level column index, as :meth:`to_dataframe` gives) or
        ``"joint/channel"`` (flat names); the columns may come in any order, but every channel
        must be there once and no other column. Positions are in the skeleton's units,
        rotations Euler angles in degrees in each joint's channel order, as in a BVH file.

        Parameters
        ----------
        df : pandas.DataFrame
            The channels, one row per frame.
        skeleton : Skeleton
            The skeleton the channels belong to (e.g. ``m.skeleton``).
        frame_time : float, optional
            Seconds per frame; default ``df.attrs["frame_time"]`` (which
            :meth:`to_dataframe` sets).

        Returns
        -------
        Motion
            The motion.

        Raises
        ------
        mlayer.InvalidArgumentError
            For a channel of the skeleton missing from the table, a column that is none of its
            channels or appears twice (each named), values that are not finite numbers, or no
            frame time.
        mlayer.MissingDependencyError
            Without pandas.

        Examples
        --------
        >>> df = m.to_dataframe()                                      # doctest: +SKIP
        >>> df["Hips", "Yposition"] += 2.0                             # doctest: +SKIP
        >>> lifted = mlayer.Motion.from_dataframe(df, m.skeleton)      # doctest: +SKIP
        """
        pd = require("pandas", feature="mlayer.Motion.from_dataframe")
        what = "Motion.from_dataframe"
        if not isinstance(df, pd.DataFrame):
            raise InvalidArgumentError(f"{what}: df must be a pandas.DataFrame, got "
                                       f"{type(df).__name__}")
        if not isinstance(skeleton, Skeleton):
            raise InvalidArgumentError(f"{what}: skeleton must be a mlayer.Skeleton")
        if frame_time is None:
            frame_time = df.attrs.get("frame_time")
            if frame_time is None:
                raise InvalidArgumentError(f"{what}: no frame_time given and none in "
                                           "df.attrs['frame_time']")

        def key(col: Any) -> tuple[str, str]:
            if isinstance(col, tuple) and len(col) == 2:
                return str(col[0]), str(col[1])
            joint, sep, chan = str(col).rpartition("/")
            if not sep:
                raise InvalidArgumentError(f"{what}: column {col!r} is not (joint, channel) "
                                           "nor 'joint/channel'")
            return joint, chan

        cols = [key(c) for c in df.columns]
        sk = skeleton
        want = [(name, c) for j, name in enumerate(sk._names) for c in sk.channels[j].split()]
        seen: dict[tuple[str, str], int] = {}
        for i, c in enumerate(cols):
            if c in seen:
                raise InvalidArgumentError(f"{what}: column {'/'.join(c)} appears twice")
            seen[c] = i
        wanted = set(want)
        extra = [c for c in cols if c not in wanted]
        if extra:
            raise InvalidArgumentError(
                f"{what}: column {'/'.join(extra[0])} is not a channel of the skeleton"
                + (f" ({len(extra) - 1} more)" if len(extra) > 1 else ""))
        missing = [c for c in want if c not in seen]
        if missing:
            raise InvalidArgumentError(
                f"{what}: channel {'/'.join(missing[0])} is missing from the table"
                + (f" ({len(missing) - 1} more)" if len(missing) > 1 else ""))
        try:
            values = df.to_numpy(dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise InvalidArgumentError(f"{what}: the values are not numbers ({e})") from None
        bad = ~np.isfinite(values)
        if bad.any():
            row, col = (int(v[0]) for v in np.nonzero(bad))
            raise InvalidArgumentError(f"{what}: column {'/'.join(cols[col])} is not finite at "
                                       f"row {row}")
        N = values.shape[0]
        J, P = sk.n_joints, sk.trans_joints.shape[0]
        where = {int(j): p for p, j in enumerate(sk.trans_joints)}
        root_pos = np.zeros((N, 3))
        trans = np.broadcast_to(sk.offsets[sk.trans_joints], (N, P, 3)).copy()
        rot = np.zeros((N, J, 4))
        rot[..., 0] = 1.0
        for j, name in enumerate(sk._names):
            order = sk.euler_orders[j]
            angles = np.zeros((N, 3))
            has_rot = False
            for chan in sk.channels[j].split():
                v = values[:, seen[(name, chan)]]
                axis = "XYZ".index(chan[0].upper())
                if chan[1:].lower() == "position":
                    if j == 0:
                        root_pos[:, axis] = v
                    else:
                        trans[:, where[j], axis] = v
                else:
                    angles[:, order.index(chan[0].upper())] = v
                    has_rot = True
            if has_rot:
                rot[:, j] = from_euler(angles, order)
        return cls(sk, float(frame_time), root_pos, rot, trans)

    # ---- output ----------------------------------------------------------------------------

    def _handle(self) -> _Handle:
        """A C motion handle holding a copy of this motion (for the writers)."""
        sk = self.skeleton
        N = self.n_frames
        root_pos, rot, trans = self._frames(finite=True)
        h = _create_handle(list(sk._names), sk.parents, sk.offsets, sk.channels,
                           sk.end_site_parents, sk.end_site_offsets, N, self.frame_time)
        if N:
            ffi.memmove(lib.mlr_motion_root_pos_mut(h.ptr), ffi.from_buffer(root_pos),
                        root_pos.nbytes)
            ffi.memmove(lib.mlr_motion_rot_mut(h.ptr), ffi.from_buffer(rot), rot.nbytes)
            if trans.size:
                ffi.memmove(lib.mlr_motion_trans_mut(h.ptr), ffi.from_buffer(trans), trans.nbytes)
        return h

    @classmethod
    def _adopt_c(cls, h: Any) -> Motion:
        """A new Motion whose frame arrays are the C handle's own memory, with no copy.

        Takes ownership of ``h``: it is destroyed when the last of the arrays (or of the views
        taken from them) goes away. Used by the readers, where the handle exists only to be
        turned into a Motion; a copy of the frames would cost more than the conversion.
        """
        owner = ffi.gc(h, lib.mlr_motion_destroy)
        sk = Skeleton._from_c(h)
        N, J, P = (lib.mlr_motion_n_frames(h), sk.n_joints, sk.trans_joints.shape[0])
        if N == 0:
            return cls(sk, float(lib.mlr_motion_frame_time(h)), np.empty((0, 3)),
                       np.empty((0, J, 4)), np.empty((0, P, 3)), _trusted=True)
        root_pos = _CFrames(owner, lib.mlr_motion_root_pos(h), (N, 3)).array()
        rot = _CFrames(owner, lib.mlr_motion_rot(h), (N, J, 4)).array()
        trans = (_CFrames(owner, lib.mlr_motion_trans(h), (N, P, 3)).array() if P
                 else np.empty((N, 0, 3)))
        return cls(sk, float(lib.mlr_motion_frame_time(h)), root_pos, rot, trans,
                   _trusted=True)

    def __repr__(self) -> str:
        sk = self.skeleton
        extra = f", {sk.trans_joints.shape[0]} joints with position channels" \
            if sk.trans_joints.shape[0] else ""
        return (f"<mlayer.Motion {self.n_frames} frames at {self.fps:.6g} fps "
                f"({self.duration:.3f} s), {sk.n_joints} joints (+{sk.n_end_sites} End Sites), "
                f"{sk.n_channels} channels{extra}, root {sk._names[0]!r}>")
