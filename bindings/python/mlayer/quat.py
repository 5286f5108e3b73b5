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

import numpy as np

from . import _arrays
from ._native import ffi, lib
from .errors import InvalidArgumentError, check

__all__ = ["mul", "conj", "normalize", "exp", "log", "slerp", "from_euler", "to_euler",
           "continuous", "euler_order", "to_scalar_last", "from_scalar_last", "to_scipy",
           "from_scipy"]


def to_scalar_last(q) -> np.ndarray:
    """mlayer's scalar-first ``(..., 4)`` quaternions as scalar-last ``(x, y, z, w)``, the order
    of ``scipy.spatial.transform.Rotation.from_quat`` (and glTF). ``Rotation.from_quat(m.rot)``
    without it is wrong: the scalar is read as z."""
    q = _quats(q, "q")
    return np.ascontiguousarray(np.concatenate([q[..., 1:], q[..., :1]], axis=-1))


def from_scalar_last(q) -> np.ndarray:
    """Scalar-last ``(x, y, z, w)`` quaternions (scipy's ``Rotation.as_quat``) as mlayer's
    scalar-first ``(w, x, y, z)``."""
    q = _quats(q, "q")
    return np.ascontiguousarray(np.concatenate([q[..., 3:], q[..., :3]], axis=-1))


def to_scipy(q):
    """A ``scipy.spatial.transform.Rotation`` of scalar-first quaternions (any leading shape is
    flattened, as scipy holds a 1-D stack). Needs scipy."""
    from ._optional import require
    require("scipy", feature="mlayer.quat.to_scipy")
    from scipy.spatial.transform import Rotation
    return Rotation.from_quat(to_scalar_last(q).reshape(-1, 4))


def from_scipy(rotation) -> np.ndarray:
    """Scalar-first ``(N, 4)`` quaternions of a ``scipy.spatial.transform.Rotation`` stack
    (``(4,)`` for a single rotation)."""
    return from_scalar_last(rotation.as_quat())


def _quats(q, name: str) -> np.ndarray:
    return _arrays.as_f64(q, name, last=(4,))


def _vecs(v, name: str) -> np.ndarray:
    return _arrays.as_f64(v, name, last=(3,))


def _broadcast(name: str, *parts):
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
    """The C enum value (``lib.MLR_EULER_*``) of an order name such as ``"ZXY"``."""
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


def mul(a, b) -> np.ndarray:
    """Hamilton product ``a * b`` of (..., 4) arrays, broadcast over the leading dimensions.

    As rotations, ``mul(a, b)`` applies ``b`` first, then ``a``. NaNs propagate.
    """
    a, b = _quats(a, "a"), _quats(b, "b")
    batch, (a, b) = _broadcast("mlayer.quat.mul", (a, 1), (b, 1))
    out = np.empty(batch + (4,))
    if out.size:
        lib.mlr_quat_mul_array(_arrays.ptr(a, "mlr_quat *"), _arrays.ptr(b, "mlr_quat *"),
                               out.size // 4, _arrays.ptr_out(out, "mlr_quat *"))
    return out


def conj(q) -> np.ndarray:
    """Conjugate ``(w, -x, -y, -z)``: the inverse rotation of a unit quaternion."""
    q = _quats(q, "q")
    out = np.empty(q.shape)
    if out.size:
        lib.mlr_quat_conj_array(_arrays.ptr(q, "mlr_quat *"), out.size // 4,
                                _arrays.ptr_out(out, "mlr_quat *"))
    return out


def normalize(q) -> np.ndarray:
    """``q / |q|``. Raises InvalidArgumentError for a zero or non-finite quaternion."""
    q = _quats(q, "q")
    out = np.empty(q.shape)
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_normalize_array(_arrays.ptr(q, "mlr_quat *"), out.size // 4,
                                            _arrays.ptr_out(out, "mlr_quat *"), diag)
        check(code, "mlayer.quat.normalize", diag)
    return out


def exp(v) -> np.ndarray:
    """Unit quaternions (..., 4) of rotation vectors (..., 3): the rotation by ``|v|`` about
    ``v / |v|``; accurate near 0."""
    v = _vecs(v, "v")
    out = np.empty(v.shape[:-1] + (4,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_exp_array(_arrays.ptr(v, "mlr_vec3 *"), out.size // 4,
                                      _arrays.ptr_out(out, "mlr_quat *"), diag)
        check(code, "mlayer.quat.exp", diag)
    return out


def log(q) -> np.ndarray:
    """Rotation vectors (..., 3) of quaternions (..., 4), angle in [0, pi] (``q`` and ``-q``
    give the same vector); accurate near 0 and near pi. ``q`` need not be exactly unit."""
    q = _quats(q, "q")
    out = np.empty(q.shape[:-1] + (3,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_log_array(_arrays.ptr(q, "mlr_quat *"), out.size // 3,
                                      _arrays.ptr_out(out, "mlr_vec3 *"), diag)
        check(code, "mlayer.quat.log", diag)
    return out


def slerp(a, b, t) -> np.ndarray:
    """Spherical interpolation from ``a`` (t = 0) to ``b`` (t = 1) along the shorter arc.

    ``a`` and ``b`` are (..., 4), ``t`` is a scalar or (...); all three broadcast over the
    leading dimensions, so ``slerp(a, b, np.linspace(0, 1, 5)[:, None])`` with ``a``, ``b`` of
    shape (J, 4) gives (5, J, 4). Output is unit norm; t outside [0, 1] extrapolates.
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


def from_euler(angles, order: str, degrees: bool = True) -> np.ndarray:
    """Unit quaternions (..., 4) from intrinsic Euler angles (..., 3), ``angles[..., k]`` about
    the k-th axis of ``order`` (e.g. ``"ZXY"``: ``R = Rz(a0) Rx(a1) Ry(a2)``)."""
    o = euler_order(order)
    angles = _arrays.as_f64(angles, "angles", last=(3,))
    if degrees:
        angles = np.deg2rad(angles)
    out = np.empty(angles.shape[:-1] + (4,))
    if out.size:
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_quat_from_euler_array(_arrays.ptr(angles), out.size // 4, o,
                                             _arrays.ptr_out(out, "mlr_quat *"), diag)
        check(code, "mlayer.quat.from_euler", diag)
    return out


def to_euler(q, order: str, degrees: bool = True) -> np.ndarray:
    """Intrinsic Euler angles (..., 3) of quaternions (..., 4) in ``order``: the middle angle in
    [-90, 90] degrees, the others in (-180, 180]. At gimbal lock the third angle is 0. ``q``
    need not be normalized."""
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


def continuous(q, *, predictive: bool = False) -> np.ndarray:
    """Sign continuity along axis 0: a copy of ``q`` (N, ..., 4) where each track (every index
    of the middle dimensions) is flipped to ``-q`` where needed so that consecutive frames have
    a non-negative dot product. The first frame keeps its sign; rotations are unchanged.

    ``predictive=True`` uses the second-order predictive rule instead
    (``mlr_quat_make_continuous_predictive``: the sign that continues the previous steps, so a
    spin faster than 180 degrees per frame keeps its direction; the nearest sign for steps below
    60 degrees). It is the rule the resampler and :class:`mlayer.Stream` apply."""
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
