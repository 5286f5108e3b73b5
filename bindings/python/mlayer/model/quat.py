"""Batched quaternions over numpy arrays: scalar-first ``(w, x, y, z)``, Hamilton product.

Quaternion arrays have shape ``(..., 4)``, rotation vectors and Euler angles ``(..., 3)``.
Rotation vectors are axis times the *full* angle (as ``scipy``'s ``as_rotvec``). Every
function returns a new array; inputs that already are C-contiguous float64 are passed to the
C core without a copy.

Euler orders are intrinsic, as BVH channel lines name them: ``"ZXY"`` means
``R = Rz(a0) Rx(a1) Ry(a2)`` (scipy: ``Rotation.from_euler("ZXY", ...)``, uppercase). The
order must be given in uppercase: in scipy a lowercase order means *extrinsic*, so a lowercase
order is refused here rather than silently read as intrinsic.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._native import ffi, lib
from .._optional import require
from ..errors import InvalidArgumentError, check

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["mul", "conj", "normalize", "exp", "log", "slerp", "from_euler", "to_euler",
           "continuous", "euler_order", "to_scalar_last", "from_scalar_last", "to_scipy",
           "from_scipy"]


def to_scalar_last(q: ArrayLike) -> NDArray[np.float64]:
    """Scalar-first quaternions as scalar-last ``(x, y, z, w)``.

    Scalar-last is the order of ``scipy.spatial.transform.Rotation.from_quat`` (and glTF).
    ``Rotation.from_quat(m.rot)`` without it is wrong: the scalar is read as z.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar-first ``(w, x, y, z)`` quaternions.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        The same quaternions, scalar-last (a new C-contiguous array).
    """
    q = _quats(q, "q")
    return np.ascontiguousarray(np.concatenate([q[..., 1:], q[..., :1]], axis=-1))


def from_scalar_last(q: ArrayLike) -> NDArray[np.float64]:
    """Scalar-last ``(x, y, z, w)`` quaternions as mlayer's scalar-first ``(w, x, y, z)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar-last quaternions (scipy's ``Rotation.as_quat``).

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        The same quaternions, scalar-first (a new C-contiguous array).
    """
    q = _quats(q, "q")
    return np.ascontiguousarray(np.concatenate([q[..., 3:], q[..., :3]], axis=-1))


def to_scipy(q: ArrayLike) -> Rotation:
    """A ``scipy.spatial.transform.Rotation`` of scalar-first quaternions. Needs scipy.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar-first quaternions; any leading shape is flattened, as scipy holds a 1-D stack.

    Returns
    -------
    scipy.spatial.transform.Rotation
        A stack of ``q.size // 4`` rotations.

    Raises
    ------
    mlayer.MissingDependencyError
        When scipy is not installed.
    """
    require("scipy", feature="mlayer.quat.to_scipy")
    from scipy.spatial.transform import Rotation as _Rotation
    return _Rotation.from_quat(to_scalar_last(q).reshape(-1, 4))


def from_scipy(rotation: Rotation) -> NDArray[np.float64]:
    """Scalar-first quaternions of a ``scipy.spatial.transform.Rotation``.

    Parameters
    ----------
    rotation : scipy.spatial.transform.Rotation
        A stack of rotations or a single one.

    Returns
    -------
    numpy.ndarray, shape (N, 4) or (4,)
        ``(w, x, y, z)`` quaternions: ``(4,)`` for a single rotation.
    """
    return from_scalar_last(rotation.as_quat())


def _quats(q: ArrayLike, name: str) -> NDArray[np.float64]:
    return _arrays.as_f64(q, name, last=(4,))


def _vecs(v: ArrayLike, name: str) -> NDArray[np.float64]:
    return _arrays.as_f64(v, name, last=(3,))


def _broadcast(name: str, *parts: tuple[NDArray[np.float64], int]
               ) -> tuple[tuple[int, ...], list[NDArray[np.float64]]]:
    """Broadcast (array, trailing_dims) pairs over their leading (batch) shapes and make each
    C-contiguous. Arrays already of the common shape are not copied."""
    try:
        batch = np.broadcast_shapes(*(a.shape[:a.ndim - k] for a, k in parts))
    except ValueError:
        shapes = ", ".join(str(a.shape) for a, _ in parts)
        raise InvalidArgumentError(f"{name}: shapes {shapes} do not broadcast") from None
    out = []
    for a, k in parts:
        shape = batch + a.shape[a.ndim - k:]
        if a.shape != shape:
            a = np.ascontiguousarray(np.broadcast_to(a, shape))
        out.append(a)
    return batch, out


def euler_order(order: str) -> int:
    """The C enum value (``lib.MLR_EULER_*``) of an Euler order name.

    Parameters
    ----------
    order : str
        An intrinsic order in uppercase, such as ``"ZXY"``.

    Returns
    -------
    int
        The ``mlr_euler_order`` value.

    Raises
    ------
    mlayer.InvalidArgumentError
        When ``order`` is not a string, is lowercase (scipy's extrinsic spelling) or names no
        order.
    """
    if not isinstance(order, str):
        raise InvalidArgumentError(f"order must be a string such as 'ZXY', got {order!r}")
    if order != order.upper():
        raise InvalidArgumentError(
            f"order {order!r}: give intrinsic orders in uppercase ('{order.upper()}'); mlayer "
            "has no extrinsic (lowercase, scipy-style) orders")
    out = ffi.new("mlr_euler_order *")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_euler_order_parse(order.encode("ascii", errors="replace"), out, diag),
          "mlayer.quat.euler_order", diag)
    return int(out[0])


def mul(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product ``a * b``, broadcast over the leading dimensions.

    As rotations, ``mul(a, b)`` applies ``b`` first, then ``a``. NaNs propagate.

    Parameters
    ----------
    a, b : array_like, shape (..., 4)
        Scalar-first quaternions; their leading shapes broadcast.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        The products.

    Raises
    ------
    mlayer.InvalidArgumentError
        When the shapes do not broadcast.

    Examples
    --------
    >>> import numpy as np
    >>> from mlayer import quat
    >>> quat.mul([1.0, 0, 0, 0], [0.0, 1, 0, 0])
    array([0., 1., 0., 0.])
    """
    a, b = _quats(a, "a"), _quats(b, "b")
    batch, (a, b) = _broadcast("mlayer.quat.mul", (a, 1), (b, 1))
    out = np.empty(batch + (4,))
    if out.size:
        lib.mlr_quat_mul_array(_arrays.ptr(a, "mlr_quat *"), _arrays.ptr(b, "mlr_quat *"),
                               out.size // 4, _arrays.ptr_out(out, "mlr_quat *"))
    return out


def conj(q: ArrayLike) -> NDArray[np.float64]:
    """Conjugate ``(w, -x, -y, -z)``: the inverse rotation of a unit quaternion.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar-first quaternions.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        The conjugates.
    """
    q = _quats(q, "q")
    out = np.empty(q.shape)
    if out.size:
        lib.mlr_quat_conj_array(_arrays.ptr(q, "mlr_quat *"), out.size // 4,
                                _arrays.ptr_out(out, "mlr_quat *"))
    return out


def normalize(q: ArrayLike) -> NDArray[np.float64]:
    """``q / |q|``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        Unit quaternions.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a zero or non-finite quaternion.
    """
    q = _quats(q, "q")
    out = np.empty(q.shape)
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_normalize_array(_arrays.ptr(q, "mlr_quat *"), out.size // 4,
                                            _arrays.ptr_out(out, "mlr_quat *"), diag)
        check(code, "mlayer.quat.normalize", diag)
    return out


def exp(v: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternions of rotation vectors: the rotation by ``|v|`` about ``v / |v|``.

    Accurate near 0.

    Parameters
    ----------
    v : array_like, shape (..., 3)
        Rotation vectors (axis times the full angle, radians).

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        Unit quaternions.

    Raises
    ------
    mlayer.InvalidArgumentError
        For non-finite vectors.
    """
    v = _vecs(v, "v")
    out = np.empty(v.shape[:-1] + (4,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_exp_array(_arrays.ptr(v, "mlr_vec3 *"), out.size // 4,
                                      _arrays.ptr_out(out, "mlr_quat *"), diag)
        check(code, "mlayer.quat.exp", diag)
    return out


def log(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation vectors of quaternions, angle in [0, pi].

    ``q`` and ``-q`` give the same vector; accurate near 0 and near pi. ``q`` need not be
    exactly unit.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar-first quaternions.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        Rotation vectors (axis times the full angle, radians).

    Raises
    ------
    mlayer.InvalidArgumentError
        For a zero or non-finite quaternion.
    """
    q = _quats(q, "q")
    out = np.empty(q.shape[:-1] + (3,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_log_array(_arrays.ptr(q, "mlr_quat *"), out.size // 3,
                                      _arrays.ptr_out(out, "mlr_vec3 *"), diag)
        check(code, "mlayer.quat.log", diag)
    return out


def slerp(a: ArrayLike, b: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Spherical interpolation from ``a`` (t = 0) to ``b`` (t = 1) along the shorter arc.

    All three arguments broadcast over the leading dimensions, so
    ``slerp(a, b, np.linspace(0, 1, 5)[:, None])`` with ``a``, ``b`` of shape (J, 4) gives
    (5, J, 4). ``t`` outside [0, 1] extrapolates.

    Parameters
    ----------
    a, b : array_like, shape (..., 4)
        Scalar-first quaternions.
    t : float or array_like, shape (...)
        Interpolation parameters.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        Unit quaternions.

    Raises
    ------
    mlayer.InvalidArgumentError
        When the shapes do not broadcast or an input is not finite.
    """
    a, b = _quats(a, "a"), _quats(b, "b")
    scalar_t = np.ndim(t) == 0
    t = _arrays.as_f64(t, "t")
    if scalar_t:  # as_f64 (np.ascontiguousarray) makes scalars 1-d
        t = t.reshape(())
    batch, (a, b, t) = _broadcast("mlayer.quat.slerp", (a, 1), (b, 1), (t, 0))
    out = np.empty(batch + (4,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_slerp_array(_arrays.ptr(a, "mlr_quat *"),
                                        _arrays.ptr(b, "mlr_quat *"), _arrays.ptr(t),
                                        out.size // 4, _arrays.ptr_out(out, "mlr_quat *"), diag)
        check(code, "mlayer.quat.slerp", diag)
    return out


def from_euler(angles: ArrayLike, order: str, degrees: bool = True) -> NDArray[np.float64]:
    """Unit quaternions from intrinsic Euler angles.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        ``angles[..., k]`` is the angle about the k-th axis of ``order``.
    order : str
        An uppercase intrinsic order, e.g. ``"ZXY"``: ``R = Rz(a0) Rx(a1) Ry(a2)``.
    degrees : bool, optional
        Angles in degrees (the default) or radians.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        Unit quaternions.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a bad order (see :func:`euler_order`) or non-finite angles.
    """
    o = euler_order(order)
    a = _arrays.as_f64(angles, "angles", last=(3,))
    if degrees:
        a = np.deg2rad(a)
    out = np.empty(a.shape[:-1] + (4,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_from_euler_array(_arrays.ptr(a), out.size // 4, o,
                                             _arrays.ptr_out(out, "mlr_quat *"), diag)
        check(code, "mlayer.quat.from_euler", diag)
    return out


def to_euler(q: ArrayLike, order: str, degrees: bool = True) -> NDArray[np.float64]:
    """Intrinsic Euler angles of quaternions in ``order``.

    The middle angle is in [-90, 90] degrees, the others in (-180, 180]. At gimbal lock the
    third angle is 0. ``q`` need not be normalized.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Scalar-first quaternions.
    order : str
        An uppercase intrinsic order, e.g. ``"ZXY"``.
    degrees : bool, optional
        Return degrees (the default) or radians.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        The angles, ``[..., k]`` about the k-th axis of ``order``.

    Raises
    ------
    mlayer.InvalidArgumentError
        For a bad order or a zero or non-finite quaternion.
    """
    o = euler_order(order)
    q = _quats(q, "q")
    out = np.empty(q.shape[:-1] + (3,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_to_euler_array(_arrays.ptr(q, "mlr_quat *"), out.size // 3, o,
                                           _arrays.ptr_out(out), diag)
        check(code, "mlayer.quat.to_euler", diag)
    if degrees:
        np.rad2deg(out, out=out)
    return out


def continuous(q: ArrayLike, *, predictive: bool = False) -> NDArray[np.float64]:
    """Sign continuity along axis 0.

    Each track (every index of the middle dimensions) is flipped to ``-q`` where needed so
    that consecutive frames have a non-negative dot product. The first frame keeps its sign;
    rotations are unchanged.

    Parameters
    ----------
    q : array_like, shape (N, ..., 4)
        Scalar-first quaternions, frames along axis 0.
    predictive : bool, optional
        Use the second-order predictive rule instead
        (``mlr_quat_make_continuous_predictive``: the sign that continues the previous steps,
        so a spin faster than 180 degrees per frame keeps its direction; the nearest sign for
        steps below 60 degrees). It is the rule the resampler and :class:`mlayer.Stream`
        apply.

    Returns
    -------
    numpy.ndarray, shape (N, ..., 4)
        A copy of ``q`` with continuous signs.

    Raises
    ------
    mlayer.InvalidArgumentError
        When ``q`` has fewer than 2 dimensions.
    """
    q = _quats(q, "q")
    if q.ndim < 2:
        raise InvalidArgumentError(
            f"q: expected shape (N, ..., 4) with frames along axis 0, got shape {q.shape}")
    out = np.array(q, dtype=np.float64, order="C", copy=True)
    n_frames = out.shape[0]
    if out.size and n_frames > 1:
        fn = lib.mlr_quat_make_continuous_predictive if predictive \
            else lib.mlr_quat_make_continuous
        fn(_arrays.ptr_out(out, "mlr_quat *"), n_frames, out.size // (4 * n_frames))
    return out
