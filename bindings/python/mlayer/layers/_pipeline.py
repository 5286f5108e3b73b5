"""The C core's job object, ``mlr_pipeline`` (include/mlayer/mlr_pipeline.h), for
:func:`mlayer.decompose` and :mod:`mlayer.pipeline.pipeline`.

The composition of the layers and the guards (trim, up axis, body joint, the decomposition's
options, the repaired input, the guards, the synthesis with the body translation where it rides,
``mlr_guards_apply_trans``) lives there, once: this module only sets parameters, hands a Motion
over and reads the results back. The pipelines made here are used for one clip each
(``MLR_PIPELINE_KEEP_MEMORY`` 0). A pipeline has one writer at a time: a lock serializes the
syntheses of one Job (a Synthesis may be run from several threads, as the viewer's server does).
"""
from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .._native import ffi, lib
from .alpha_curve import AlphaCurve
from ..errors import check

if TYPE_CHECKING:
    from ..model.motion import Motion


class Job:
    """One ``mlr_pipeline`` (freed with the object), prepared on one motion."""

    def __init__(self, params: Mapping[int, float], where: str) -> None:
        diag = ffi.new("mlr_diag *")
        out = ffi.new("mlr_pipeline **")
        check(lib.mlr_pipeline_create(ffi.NULL, out, diag), where, diag)
        self.h = ffi.gc(out[0], lib.mlr_pipeline_destroy)
        self.where = where
        self.set({lib.MLR_PIPELINE_KEEP_MEMORY: 0.0, **params})
        self.motion: Motion | None = None
        self._layers: Any = None
        self._lock = threading.Lock()

    def set(self, params: Mapping[int, float]) -> None:
        diag = ffi.new("mlr_diag *")
        for key, value in params.items():
            check(lib.mlr_pipeline_set(self.h, key, float(value), diag), self.where, diag)

    def get(self, key: int) -> float:
        v = ffi.new("double *")
        check(lib.mlr_pipeline_get(self.h, key, v), self.where)
        return float(v[0])

    def prepare(self, motion: Motion, layers: Any = None) -> str:
        """Prepare on motion (with its layers' C handle when given, kept referenced); returns
        the guards' note (empty, or a guard that cannot run)."""
        diag = ffi.new("mlr_diag *")
        h = motion._handle()
        check(lib.mlr_pipeline_prepare(self.h, h.ptr, ffi.NULL if layers is None else layers,
                                       diag), self.where, diag)
        self.motion, self._layers = motion, layers
        return ffi.string(diag.message).decode("utf-8", "replace")

    def layers(self) -> Any:
        return lib.mlr_pipeline_layers(self.h)

    def guards(self) -> Any:
        return lib.mlr_pipeline_guards(self.h)

    def synthesize(self, alpha: float | AlphaCurve,
                   joints: Mapping[str, float | AlphaCurve] | None,
                   root_alpha: float | None, n_joints: int
                   ) -> tuple[tuple[NDArray[np.float64], ...], Any, NDArray[np.uintp]]:
        """((root_pos, rot, trans) of the guarded synthesis, new arrays; the guards' report;
        the frames each joint was limited in)."""
        with self._lock:
            frames = self._synthesize(alpha, joints, root_alpha)
            return (frames, *self._report(n_joints))

    def _synthesize(self, alpha: float | AlphaCurve,
                    joints: Mapping[str, float | AlphaCurve] | None,
                    root_alpha: float | None) -> tuple[NDArray[np.float64], ...]:
        """The alphas set (numbers, or AlphaCurves: mlr_pipeline_set_alpha_keys), then the
        synthesis."""
        h = self.h
        diag = ffi.new("mlr_diag *")
        lib.mlr_pipeline_clear_joint_alphas(h)
        if isinstance(alpha, AlphaCurve):
            check(lib.mlr_pipeline_set_alpha_keys(h, ffi.NULL, *_keys(alpha), diag), self.where,
                  diag)
        else:
            check(lib.mlr_pipeline_set(h, lib.MLR_PIPELINE_ALPHA, alpha, diag), self.where, diag)
        if root_alpha is not None:
            check(lib.mlr_pipeline_set(h, lib.MLR_PIPELINE_ROOT_ALPHA, root_alpha, diag),
                  self.where, diag)
        for pattern, a in (joints or {}).items():
            name = pattern.encode("utf-8", errors="surrogateescape")
            if isinstance(a, AlphaCurve):
                check(lib.mlr_pipeline_set_alpha_keys(h, name, *_keys(a), diag), self.where, diag)
            else:
                check(lib.mlr_pipeline_set_joint_alpha(h, name, a, diag), self.where, diag)
        out = ffi.new("mlr_motion **")
        check(lib.mlr_pipeline_synthesize(h, out, diag), self.where, diag)
        m = out[0]
        try:
            N, J, P = (lib.mlr_motion_n_frames(m), lib.mlr_motion_n_joints(m),
                       lib.mlr_motion_n_trans(m))
            root = _copy(lib.mlr_motion_root_pos(m), (N, 3))
            rot = _copy(lib.mlr_motion_rot(m), (N, J, 4))
            trans = _copy(lib.mlr_motion_trans(m), (N, P, 3)) if P else np.empty((N, 0, 3))
        finally:
            lib.mlr_motion_destroy(m)
        return root, rot, trans

    def _report(self, n_joints: int) -> tuple[Any, NDArray[np.uintp]]:
        rep = ffi.new("mlr_guards_report *")
        limited = np.zeros(n_joints, dtype=np.uintp)
        check(lib.mlr_pipeline_report(self.h, rep, ffi.cast("size_t *", ffi.from_buffer(limited)),
                                      n_joints), self.where)
        return rep, limited


def _keys(c: AlphaCurve) -> tuple[Any, Any, int]:
    """(times, values, n) of a curve for mlr_pipeline_set_alpha_keys (copied there)."""
    return (ffi.cast("const double *", ffi.from_buffer(c.times)),
            ffi.cast("const double *", ffi.from_buffer(c.values)), c.times.size)


def _copy(ptr: Any, shape: tuple[int, ...]) -> NDArray[np.float64]:
    n = int(np.prod(shape))
    return np.frombuffer(ffi.buffer(ptr, 8 * n), dtype=np.float64).reshape(shape).copy()
