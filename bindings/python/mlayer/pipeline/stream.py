"""Live filtering: the fixed-lag LGS smoother of the C core (``mlr_stream.h``) for frames that
arrive one at a time.

A :class:`Stream` takes one frame per :meth:`Stream.push` and returns the smoothed frame from
``lag`` frames ago: the posterior mean of the order-2 LGS (paper 1, ``mlayer.lgs`` with the
same ``lam``, ``sigma``) given every frame pushed so far. :meth:`Stream.flush` ends the clip and
returns the ``lag`` frames still pending, exactly as the offline solve of the whole clip gives
them. The gap between a pushed output and the offline solve of the whole clip shrinks as
``decay_rate ** lag`` (``decay_rate`` in [0, 1) grows with ``lam * sigma``); the lag that keeps
it below a fraction ``tol`` of the clip's size is about ``log(tol) / log(decay_rate)``.

Quaternions get their sign online by the second-order predictive rule (exactly
``mlayer.quat.continuous(rot, predictive=True)`` on the frames so far), their four components
are smoothed as channels and the output is renormalized. With ``lam_base``/``sigma_base`` the
stream also runs a base layer and outputs ``base (+) alpha (main (-) base)`` (paper 1 section
4), ``alpha`` settable between any two pushes (:meth:`Stream.set_alpha`).

Frames. A frame is given as ``(root_pos (3,), rot (J, 4))``, or ``(root_pos, rot, trans (P,
3))`` for skeletons whose non-root joints have position channels (``trans`` may be left out: it
is then the skeleton's OFFSETs, as in :class:`~mlayer.Motion`), or as a one-frame
:class:`~mlayer.Motion`, or as one flat float64 array of ``frame_size`` values
``[root 3][trans 3P][rot 4J]``. The output has the form of the input: a :class:`Frame`
``(root_pos, rot, trans)`` for a tuple, a one-frame Motion for a Motion, a flat array for a flat
array (the fastest path).

Cost (CMU 131_01: 31 joints, lag 10, lam = sigma = 1; on a 2-core machine shared with other
jobs): the C push is 0.87 us per frame (median, ``build-b/bench/mlayer-bench --filter stream``);
through Python (``python bench/python/bench_stream.py``, 21 passes over the 994 frames, the
fastest pass; medians were 2 to 3 times higher under the machine's load) a flat-array push costs
about 2 us per frame, a ``(root_pos, rot)`` push about 5 us, a Motion-frame push about 10 us,
and :func:`stream_motion` about 3 us per frame (the loop of C pushes alone: 1.3 us). Buffers
are allocated once by the constructor; a push allocates only the copy it returns.

A stream is not thread-safe; separate streams are independent.
"""
from __future__ import annotations


from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._args import integer
from .._handles import NativeHandle, ReadOnlyAttributes
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from ..guards.limits import JointLimits
from ..model.motion import Motion, Skeleton


__all__ = ["Stream", "Frame", "stream_motion", "decay_rate"]


class Frame(NamedTuple):
    """One frame (or, from :meth:`Stream.flush`, k frames along a leading axis).

    Attributes
    ----------
    root_pos : numpy.ndarray, shape (3,) or (k, 3)
        Root translation.
    rot : numpy.ndarray, shape (J, 4) or (k, J, 4)
        Local rotations.
    trans : numpy.ndarray, shape (P, 3) or (k, P, 3)
        Translations of the joints with position channels.
    """
    root_pos: np.ndarray  # (3,) or (k, 3)
    rot: np.ndarray       # (J, 4) or (k, J, 4)
    trans: np.ndarray     # (P, 3) or (k, P, 3)


#: what :meth:`Stream.push` takes: a (root_pos, rot[, trans]) tuple, a Motion, a flat array
FrameInput = tuple[ArrayLike, ...] | Motion | NDArray[Any]
#: what :meth:`Stream.push` and :meth:`Stream.flush` give back: the form of the input
FrameOutput = Frame | Motion | NDArray[np.float64]


def decay_rate(lam: float, sigma: float) -> float:
    """Rate at which a stream's gap to the offline solve shrinks per frame of lag.

    ``mlr_stream_decay_rate``: 0 for lam = 0, close to 1 for strong smoothing.

    Parameters
    ----------
    lam, sigma : float
        The LGS parameters: finite lam >= 0, sigma > 0.

    Returns
    -------
    float
        rho in [0, 1).

    Raises
    ------
    mlayer.InvalidArgumentError
        For lam or sigma out of range.
    """
    r = float(lib.mlr_stream_decay_rate(float(lam), float(sigma)))
    if r < 0:
        raise InvalidArgumentError(
            f"decay_rate: need finite lam >= 0 and sigma > 0, got lam={lam!r} sigma={sigma!r}")
    return r


MAX_LAG = 10**6
"""The largest lag a Stream takes: 2.3 hours at 120 fps, far beyond any lag whose gap to the
offline solve is measurable (``decay_rate ** lag``), and about 1 GB of buffers for a 31-joint
skeleton. A larger lag is taken as a mistake (frames given for seconds, say)."""


MAX_BYTES = 256 << 20
"""The default ``max_bytes`` of :class:`Stream`: the most its buffers may take."""


def _as_lag(lag: int) -> int:
    lag = integer(lag, "Stream: lag", 0)
    if lag > MAX_LAG:
        raise InvalidArgumentError(f"Stream: lag must be at most {MAX_LAG} frames "
                                   f"(mlayer.pipeline.stream.MAX_LAG), got {lag!r}")
    return int(lag)


class Stream(ReadOnlyAttributes, NativeHandle):
    """A fixed-lag LGS smoother for one skeleton (see the module docstring).

    ``skeleton``, ``lam``, ``sigma``, ``lam_base``, ``sigma_base`` and ``limits`` are read-only
    (the C stream was made with them and borrows the limits). A stream cannot be copied or
    pickled (TypeError: its pushed frames live in the C handle; make a new Stream and push the
    frames again); after ``close()`` its methods raise InvalidArgumentError.

    Parameters
    ----------
    skeleton_or_motion : Skeleton or Motion
        The skeleton whose frames will be pushed (a Motion gives its skeleton).
    lam, sigma : float
        The LGS parameters (order 2), as :func:`mlayer.lgs`: lam >= 0, sigma > 0.
    lag : int
        Output delay in frames (>= 0; 0 is pure filtering).
    alpha : float or array (J,), optional
        Layer scale (needs a base layer): a float scales every channel, an array scales each
        joint's rotation (translations keep 1). Default 1: the main smoothed motion.
    lam_base, sigma_base : float, optional
        Parameters of a base layer (normally stronger smoothing); giving either one makes a
        layered stream (the other defaults to the main layer's value).
    limits : JointLimits, optional
        Joint limits (:func:`mlayer.joint_limits`) applied to every output frame with the
        stream's alphas (``mlr_stream_set_limits``): a soft saturation of each frame on its
        own, so a live exaggeration stays within the ranges as the offline one does.
    max_bytes : int, optional
        The most memory the stream's buffers may take (about 8 bytes x (lag + 1) x the values
        of a frame, twice for a layered stream), checked before they are allocated. Default
        256 MiB: lag 60,000 on a 31-joint skeleton; ``lag=10**6`` on a 165-joint one took
        5.1 GB.
    """
    skeleton: Skeleton
    lam: float
    sigma: float
    lam_base: float | None
    sigma_base: float | None

    _readonly = ("skeleton", "lam", "sigma", "lam_base", "sigma_base", "limits", "_layered",
                 "_J", "_P", "_m", "_q0", "_in", "_out", "_in_buf", "_out_buf", "_pin", "_pout",
                 "_ready", "_in_root", "_in_trans", "_in_rot", "_default_trans")

    def __init__(self, skeleton_or_motion: Skeleton | Motion, *, lam: float, sigma: float,
                 lag: int, alpha: float | ArrayLike | None = None,
                 lam_base: float | None = None, sigma_base: float | None = None,
                 limits: JointLimits | None = None, max_bytes: int = MAX_BYTES) -> None:
        if isinstance(skeleton_or_motion, Motion):
            sk = skeleton_or_motion.skeleton
        elif isinstance(skeleton_or_motion, Skeleton):
            sk = skeleton_or_motion
        else:
            raise InvalidArgumentError("Stream: expected a mlayer.Skeleton or mlayer.Motion, got "
                                       f"{type(skeleton_or_motion).__name__}")
        lag = _as_lag(lag)
        self._layered = lam_base is not None or sigma_base is not None
        if alpha is not None and not self._layered:
            raise InvalidArgumentError("Stream: alpha needs a base layer (lam_base, sigma_base)")
        J, P = sk.n_joints, int(sk.trans_joints.shape[0])
        # the C stream keeps max(lag + 1, 4) frames per smoother (and lag more when layered) and
        # clears them at once: refuse a lag whose buffers cannot fit before asking for them
        m, n_sm = 3 + 3 * P + 4 * J, 2 if self._layered else 1
        need = 8 * (max(lag + 1, 4) * (m + 3) * n_sm + self._layered * lag * m)
        max_bytes = integer(max_bytes, "Stream: max_bytes", 1)
        _arrays.check_memory(float(need), f"Stream: lag={lag} ({m} values per frame)")
        if need > max_bytes:
            raise InvalidArgumentError(
                f"Stream: lag={lag} on {J} joints needs {need} bytes of buffers, more than "
                f"max_bytes={max_bytes} (a smaller lag, or a larger max_bytes)")
        out = ffi.new("mlr_stream **")
        diag = ffi.new("mlr_diag *")
        try:
            lam, sigma = float(lam), float(sigma)
            if self._layered:
                lam_b = lam if lam_base is None else float(lam_base)
                sigma_b = sigma if sigma_base is None else float(sigma_base)
        except (TypeError, ValueError):
            raise InvalidArgumentError("Stream: lam, sigma, lam_base and sigma_base must be "
                                       "numbers") from None
        if self._layered:
            code = lib.mlr_stream_create_layered(J, 1, P, lam, sigma, lam_b, sigma_b, lag,
                                                 ffi.NULL, out, diag)
        else:
            code = lib.mlr_stream_create(J, 1, P, lam, sigma, lag, ffi.NULL, out, diag)
        check(code, "mlayer.Stream", diag)
        self._h = ffi.gc(out[0], lib.mlr_stream_destroy)
        self.skeleton, self.lam, self.sigma = sk, lam, sigma
        self.lam_base = lam_b if self._layered else None
        self.sigma_base = sigma_b if self._layered else None
        self._J, self._P = J, P
        m = int(lib.mlr_stream_frame_size(self._h))
        self._m, self._q0 = m, 3 + 3 * P
        # preallocated buffers and their C pointers: a push copies in, calls C, copies out
        self._in, self._out = np.empty(m), np.empty(m)
        self._in_buf, self._out_buf = ffi.from_buffer(self._in), \
            ffi.from_buffer(self._out, require_writable=True)
        self._pin = ffi.cast("double *", self._in_buf)
        self._pout = ffi.cast("double *", self._out_buf)
        self._ready = ffi.new("size_t *")
        self._diag = ffi.new("mlr_diag *")
        self._in_root = self._in[:3]
        self._in_trans = self._in[3:self._q0].reshape(P, 3)
        self._in_rot = self._in[self._q0:].reshape(J, 4)
        self._default_trans = np.ascontiguousarray(sk.offsets[sk.trans_joints]) if P \
            else np.zeros((0, 3))
        self._frame_time = skeleton_or_motion.frame_time \
            if isinstance(skeleton_or_motion, Motion) else None
        self._alpha = (1.0, np.ones(J))
        self._last_kind = "tuple"
        if limits is not None:
            if not isinstance(limits, JointLimits) or limits.joint_names != sk.joint_names:
                raise InvalidArgumentError("Stream: limits must be the JointLimits of this "
                                           "skeleton (mlayer.joint_limits(clip))")
            check(lib.mlr_stream_set_limits(self._h, limits._h, self._diag),
                  "mlayer.Stream limits", self._diag)
        self.limits = limits  # the C stream borrows the handle: keep it alive
        if alpha is not None:
            self.set_alpha(alpha)

    # ---- properties ------------------------------------------------------------------------

    @property
    def lag(self) -> int:
        """Output delay in frames."""
        return int(lib.mlr_stream_lag(self._live()))

    @property
    def decay_rate(self) -> float:
        """Gap shrink rate per frame of lag for this lam, sigma (see :func:`decay_rate`)."""
        return decay_rate(self.lam, self.sigma)

    @property
    def frame_size(self) -> int:
        """Values per flat frame, 3 + 3 P + 4 J."""
        return self._m

    @property
    def n_pushed(self) -> int:
        """Frames pushed since creation or the last reset."""
        return int(lib.mlr_stream_n_pushed(self._live()))

    @property
    def pending(self) -> int:
        """Frames pushed but not yet output (what flush would return)."""
        return int(lib.mlr_stream_pending(self._live()))

    @property
    def layered(self) -> bool:
        """Whether the stream has a base layer (made with ``lam_base`` / ``sigma_base``)."""
        return self._layered

    @property
    def alpha(self) -> tuple[float, NDArray[np.float64]]:
        """(alpha of the translations, alpha per joint (J,)) of a layered stream."""
        return self._alpha[0], self._alpha[1].copy()

    # ---- frames in and out -----------------------------------------------------------------

    def _load(self, frame: Any) -> str:
        """Copy a frame into the input buffer; return its kind ("flat", "tuple", "motion")."""
        if isinstance(frame, np.ndarray) and frame.ndim == 1:
            if frame.shape[0] != self._m:
                raise InvalidArgumentError(
                    f"Stream.push: a flat frame needs {self._m} values, got {frame.shape[0]}")
            if frame.dtype.kind not in "fiub":
                raise InvalidArgumentError(
                    f"Stream.push: cannot use a {frame.dtype} array as a frame")
            self._in[...] = frame
            return "flat"
        if isinstance(frame, Motion):
            if frame.n_frames != 1:
                raise InvalidArgumentError(
                    f"Stream.push: a Motion frame must hold 1 frame, got {frame.n_frames}")
            if frame.skeleton is not self.skeleton and frame.skeleton != self.skeleton:
                raise InvalidArgumentError("Stream.push: the Motion has another skeleton")
            root, rot, trans = frame._frames()  # the arrays agree (they may have been replaced)
            parts = (root[0], rot[0], trans[0]) if self._P else (root[0], rot[0])
            kind = "motion"
        elif isinstance(frame, tuple) and len(frame) in (2, 3):
            parts = frame if len(frame) == 3 or not self._P \
                else (frame[0], frame[1], self._default_trans)
            kind = "tuple"
        else:
            raise InvalidArgumentError(
                "Stream.push: a frame is (root_pos (3,), rot (J, 4)[, trans (P, 3)]), a one-frame "
                f"Motion or a flat array of {self._m} values, got {type(frame).__name__}")
        for src, dst, name in zip(parts, (self._in_root, self._in_rot, self._in_trans),
                                  ("root_pos", "rot", "trans")):
            a = src if type(src) is np.ndarray else np.asarray(src)
            if a.shape != dst.shape:
                raise InvalidArgumentError(
                    f"Stream.push: {name} must have shape {dst.shape}, got {a.shape}")
            if a.dtype.kind not in "fiub":
                raise InvalidArgumentError(
                    f"Stream.push: cannot use a {a.dtype} array as {name}")
            dst[...] = a
        return kind

    def _wrap(self, x: NDArray[np.float64], kind: str) -> Any:
        """Output rows x ((m,) or (k, m), owned) in the form of the input."""
        if kind == "flat":
            return x
        lead = x.shape[:-1]
        root = x[..., :3]
        trans = x[..., 3:self._q0].reshape(lead + (self._P, 3))
        rot = x[..., self._q0:].reshape(lead + (self._J, 4))
        if kind == "tuple":
            return Frame(root, rot, trans)
        if x.ndim == 1:
            root, rot, trans = root[None], rot[None], trans[None]
        ft = self._frame_time if self._frame_time is not None else 1.0
        return Motion(self.skeleton, ft, np.ascontiguousarray(root), np.ascontiguousarray(rot),
                      np.ascontiguousarray(trans), _trusted=True)

    def push(self, frame: FrameInput) -> FrameOutput | None:
        """Push the next frame; return the smoothed frame from ``lag`` frames ago.

        The output has the form of the input (see the module docstring).

        Parameters
        ----------
        frame : tuple, Motion or numpy.ndarray
            ``(root_pos (3,), rot (J, 4)[, trans (P, 3)])``, a one-frame Motion or a flat
            array of :attr:`frame_size` values.

        Returns
        -------
        Frame, Motion, numpy.ndarray or None
            The smoothed frame, or None while fewer than lag + 1 frames have been pushed.

        Raises
        ------
        mlayer.InvalidArgumentError
            For a wrong shape or a NaN/inf value (the stream is then unchanged).
        mlayer.Error
            After :meth:`flush` (call :meth:`reset`).
        """
        kind = self._load(frame)
        self._last_kind = kind
        code = lib.mlr_stream_push(self._live(), self._pin, self._m, self._pout, self._m,
                                   self._ready, self._diag)
        if code:
            check(code, "mlayer.Stream.push", self._diag)
        if not self._ready[0]:
            return None
        return self._wrap(self._out.copy(), kind)

    def flush(self) -> FrameOutput:
        """End of the clip: the frames not yet output, oldest first.

        They equal the offline solve of the clip pushed so far. The stream then needs
        :meth:`reset`.

        Returns
        -------
        Frame, Motion or numpy.ndarray
            The :attr:`pending` frames in the form of the last pushed frame, with a leading
            axis of k frames (k may be 0).
        """
        k = self.pending
        x = np.empty((k, self._m))
        n = ffi.new("size_t *")
        code = lib.mlr_stream_flush(self._live(), _arrays.ptr_out(x) if k else ffi.NULL, x.size, n,
                                    self._diag)
        if code:
            check(code, "mlayer.Stream.flush", self._diag)
        return self._wrap(x, self._last_kind)

    def reset(self) -> None:
        """Forget every pushed frame (the alphas are kept): the stream is as new."""
        lib.mlr_stream_reset(self._live())

    def set_alpha(self, alpha: float | ArrayLike, alpha_trans: float | None = None) -> None:
        """Layer scales of a layered stream, used from the next output on.

        Parameters
        ----------
        alpha : float or array_like, shape (J,)
            A float (every channel, unless ``alpha_trans`` is given) or one scale per joint
            rotation.
        alpha_trans : float, optional
            The translations' scale (default: ``alpha`` when it is a float, else 1).

        Raises
        ------
        mlayer.InvalidArgumentError
            For a stream without a base layer or an alpha of another shape.
        """
        if not self._layered:
            raise InvalidArgumentError("Stream.set_alpha: the stream has no base layer "
                                       "(create it with lam_base / sigma_base)")
        a = np.asarray(alpha, dtype=np.float64) if not isinstance(alpha, np.ndarray) \
            else alpha.astype(np.float64)
        if a.ndim == 0:
            at = float(a) if alpha_trans is None else float(alpha_trans)
            a = np.full(self._J, float(a))
        elif a.shape == (self._J,):
            at = 1.0 if alpha_trans is None else float(alpha_trans)
            a = np.ascontiguousarray(a)
        else:
            raise InvalidArgumentError(
                f"Stream.set_alpha: alpha must be a float or ({self._J},), got shape {a.shape}")
        check(lib.mlr_stream_set_alpha(self._live(), at, _arrays.ptr(a), self._J, self._diag),
              "mlayer.Stream.set_alpha", self._diag)
        self._alpha = (at, a.copy())

    # ---- whole clips -----------------------------------------------------------------------

    def _stream_flat(self, y: np.ndarray, out: np.ndarray) -> None:
        """Push the N rows of y (N, m), flush; the N outputs into out (N, m), in frame order."""
        N, m = y.shape
        py, po = _arrays.ptr(y), _arrays.ptr_out(out)
        push, h, ready, diag = lib.mlr_stream_push, self._live(), self._ready, self._diag
        done = 0
        for f in range(N):
            code = push(h, py + f * m, m, po + done * m, m, ready, diag)
            if code:
                check(code, f"mlayer.stream_motion (frame {f})", diag)
            done += ready[0]
        n = ffi.new("size_t *")
        code = lib.mlr_stream_flush(h, po + done * m if done < N else ffi.NULL,
                                    (N - done) * m, n, diag)
        if code:
            check(code, "mlayer.stream_motion", diag)
        assert done + n[0] == N

    def __repr__(self) -> str:
        base = f", base lam={self.lam_base:g} sigma={self.sigma_base:g}" if self._layered else ""
        return (f"<mlayer.Stream {self._J} joints, lam={self.lam:g} sigma={self.sigma:g}, "
                f"lag {self.lag}{base}, {self.n_pushed} pushed>")


def motion_channels(motion: Motion) -> NDArray[np.float64]:
    """The frames of a motion as stream channels.

    Parameters
    ----------
    motion : Motion
        The motion.

    Returns
    -------
    numpy.ndarray, shape (N, 3 + 3P + 4J)
        ``[root][trans][rot]`` per frame.
    """
    root_pos, rot, trans = motion._frames()
    N, J, P = motion.n_frames, rot.shape[1], trans.shape[1]
    return np.concatenate([root_pos, trans.reshape(N, 3 * P), rot.reshape(N, 4 * J)], axis=1)


def stream_motion(motion: Motion, *, lam: float, sigma: float, lag: int,
                  alpha: float | ArrayLike | None = None, lam_base: float | None = None,
                  sigma_base: float | None = None, limits: JointLimits | None = None) -> Motion:
    """Stream a whole clip through a new :class:`Stream` (frame by frame, then flush).

    Frame f of the result is what a live stream outputs for frame f: the smoothed frame given
    frames 0 .. f + lag.

    Parameters
    ----------
    motion : Motion
        The clip.
    lam, sigma, lag, alpha, lam_base, sigma_base, limits
        As for :class:`Stream`.

    Returns
    -------
    Motion
        The streamed motion (same skeleton, frame time and frame count).

    Raises
    ------
    mlayer.InvalidArgumentError
        When ``motion`` is not a Motion, or for parameters :class:`Stream` refuses.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError(
            f"stream_motion: expected a mlayer.Motion, got {type(motion).__name__}")
    st = Stream(motion, lam=lam, sigma=sigma, lag=lag, alpha=alpha, lam_base=lam_base,
                sigma_base=sigma_base, limits=limits)
    with st:
        y = motion_channels(motion)
        out = np.empty_like(y)
        if motion.n_frames:
            st._stream_flat(y, out)
        x = st._wrap(out, "tuple")
    return Motion(motion.skeleton, motion.frame_time, np.ascontiguousarray(x.root_pos),
                  np.ascontiguousarray(x.rot), np.ascontiguousarray(x.trans))
