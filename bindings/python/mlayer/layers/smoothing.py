"""The linear Gaussian system of paper 1, section 3: smoothing and resampling of channels.

    (lam^2 L^T L + A^T A / sigma^2) x = A^T y / sigma^2

L is the first (order=1) or second (order=2) difference matrix on the output grid of n_out
frames; A is the identity, or has linear-interpolation rows that place observation i at the
fractional output frame t[i]. Only s = lam^2 sigma^2 changes the mean; sigma also scales the
posterior variance.

Solvers: "banded" (the library's own banded LDL^T, always there and the fastest) and
"cholmod" (SuiteSparse CHOLMOD's sparse Cholesky, a reference path). The wheels on PyPI are
built without CHOLMOD, so that they need no SuiteSparse on the machine that installs them:
there ``have_cholmod()`` is False and ``solver="cholmod"`` raises UnsupportedError. A source
build has it when SuiteSparse is installed (Debian: ``libsuitesparse-dev``), e.g.
``pip install --no-binary mlayer -Csetup-args=-Dcholmod=enabled mlayer``, or
``pip install -Csetup-args=-Dcholmod=enabled .`` in a checkout.
"""
from __future__ import annotations

from typing import Any, Literal, SupportsIndex, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._handles import NativeHandle, ReadOnlyAttributes
from .._native import ffi, lib
from ..errors import InvalidArgumentError, UnsupportedError, check
from .._args import integer, threads as _c_threads

_SOLVERS = {"banded": lib.MLR_LGS_BANDED, "cholmod": lib.MLR_LGS_CHOLMOD}
NO_CHOLMOD = ("solver='cholmod': this mlayer was built without CHOLMOD (the wheels leave it out); "
              "install SuiteSparse (Debian: libsuitesparse-dev) and build from source: "
              "pip install --no-binary mlayer -Csetup-args=-Dcholmod=enabled mlayer")


def have_cholmod() -> bool:
    """Whether this build of mlayer includes the CHOLMOD sparse path.

    Returns
    -------
    bool
        True for a source build with SuiteSparse; never in the wheels.
    """
    return bool(lib.mlr_lgs_have_cholmod())


class LGS(ReadOnlyAttributes, NativeHandle):
    """A factored system, reusable for many right-hand sides with the same positions.

    Create it once and call :meth:`solve` for every batch of channels; :meth:`variance` gives
    the posterior variance per output frame. ``close()`` frees it now rather than at
    collection; a closed LGS raises InvalidArgumentError. ``n_out``, ``n_obs``, ``order``,
    ``solver``, ``lam`` and ``sigma`` are read-only attributes. ``copy.copy``,
    ``copy.deepcopy`` and pickling make an independent system (factored again from the same
    parameters and positions).

    Parameters
    ----------
    n_out : int
        Frames of the output grid (>= 0).
    lam : float, optional
        Smoothness weight (>= 0).
    sigma : float, optional
        Observation noise (> 0).
    order : {1, 2}, optional
        First-difference (tridiagonal) or second-difference (pentadiagonal) prior.
    t : array_like, shape (n_obs,), optional
        Sorted fractional positions of the observations on the output grid, in
        [0, n_out - 1]; default: observation i at frame i.
    n_obs : int, optional
        Observations without ``t`` (default ``n_out``).
    solver : {"banded", "cholmod"}, optional
        The library's banded LDL^T or CHOLMOD's sparse Cholesky.

    Raises
    ------
    mlayer.InvalidArgumentError
        For bad parameters or positions.
    mlayer.UnsupportedError
        For ``solver="cholmod"`` in a build without CHOLMOD.
    mlayer.SingularMatrixError
        When the observations do not determine the result.
    """
    n_out: int
    n_obs: int | None
    order: int
    solver: str
    lam: float
    sigma: float

    _readonly = ("n_out", "n_obs", "order", "solver", "lam", "sigma", "_t")

    def __init__(self, n_out: int, lam: float = 1.0, sigma: float = 1.0, *, order: int = 2,
                 t: ArrayLike | None = None, n_obs: int | None = None,
                 solver: str = "banded") -> None:
        if solver not in _SOLVERS:
            raise InvalidArgumentError(f"solver must be one of {sorted(_SOLVERS)}, got {solver!r}")
        if solver == "cholmod" and not have_cholmod():
            raise UnsupportedError(NO_CHOLMOD)
        integer(order, "order", 1, 2)
        n_out = integer(n_out, "n_out", 0)
        if t is None:
            self._t = None
            n_obs = int(n_out) if n_obs is None else int(n_obs)
            tp = ffi.NULL
        else:
            self._t = _arrays.as_f64(t, "t", ndim=1).copy()
            self._t.setflags(write=False)
            n_obs = self._t.shape[0]
            tp = _arrays.ptr(self._t)
        out = ffi.new("mlr_lgs **")
        diag = ffi.new("mlr_diag *")
        code = lib.mlr_lgs_create(int(n_out), int(order), float(lam), float(sigma), tp, n_obs,
                                  _SOLVERS[solver], ffi.NULL, out, diag)
        check(code, "mlayer.lgs", diag)
        self._h = ffi.gc(out[0], lib.mlr_lgs_destroy)
        self.n_out, self.n_obs, self.order, self.solver = int(n_out), n_obs, int(order), solver
        self.lam, self.sigma = float(lam), float(sigma)

    def _args(self) -> tuple[Any, ...]:
        return (self.n_out, self.lam, self.sigma, self.order, self._t, self.n_obs, self.solver)

    def _clone(self) -> LGS:
        return _make_lgs(*self._args())

    def __reduce_ex__(self, protocol: SupportsIndex) -> tuple[Any, ...]:
        self._live()
        return (_make_lgs, self._args())

    def solve(self, y: ArrayLike, out: NDArray[np.float64] | None = None, *,
              threads: int | None = None) -> NDArray[np.float64]:
        """Posterior mean for observations ``y``.

        Parameters
        ----------
        y : array_like, shape (n_obs,) or (n_obs, m)
            Observations, one column per channel.
        out : numpy.ndarray, optional
            Where to write the result: writable C-contiguous float64 of the result's shape.
        threads : int, optional
            None (default) lets a second thread map the pages of a large output (8 MiB or
            more) while this one solves, when the machine has two processors; 1 solves on this
            thread only. The result is the same, bit for bit.

        Returns
        -------
        numpy.ndarray, shape (n_out,) or (n_out, m)
            The posterior mean (``out`` when given).

        Raises
        ------
        mlayer.InvalidArgumentError
            For a bad shape, a bad ``out``, non-finite values or a closed system.
        """
        h = self._live()
        n_threads = _c_threads(threads)
        y = _arrays.as_f64(y, "y", ndim=(1, 2))
        if y.shape[0] != self.n_obs:
            raise InvalidArgumentError(
                f"y: expected {self.n_obs} observations (rows), got shape {y.shape}")
        m = 1 if y.ndim == 1 else y.shape[1]
        shape = (self.n_out,) if y.ndim == 1 else (self.n_out, m)
        if out is None:
            out = np.empty(shape)
        else:
            _arrays.check_out(out, "out", shape)
        if m == 0 or self.n_out == 0:
            return out
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_lgs_solve_mt(h, _arrays.ptr(y), m, m, _arrays.ptr_out(out), m, n_threads,
                                   diag), "mlayer.lgs", diag)
        return out

    def variance(self) -> NDArray[np.float64]:
        """Posterior variance per output frame, for observation noise ``sigma``.

        Returns
        -------
        numpy.ndarray, shape (n_out,)
            The variances.
        """
        h = self._live()
        var = np.empty(self.n_out)
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_lgs_variance(h, _arrays.ptr_out(var), self.n_out, diag),
              "mlayer.LGS.variance", diag)
        return var


def _make_lgs(n_out: int, lam: float, sigma: float, order: int, t: ArrayLike | None,
              n_obs: int | None, solver: str) -> LGS:
    """An LGS from its parameters (copies and unpickling)."""
    return LGS(n_out, lam, sigma, order=order, t=t, n_obs=n_obs, solver=solver)


@overload
def lgs(y: ArrayLike, lam: float = 1.0, sigma: float = 1.0, *, order: int = 2,
        t: ArrayLike | None = None, n_out: int | None = None, return_var: Literal[False] = False,
        solver: str = "banded", threads: int | None = None) -> NDArray[np.float64]: ...
@overload
def lgs(y: ArrayLike, lam: float = 1.0, sigma: float = 1.0, *, order: int = 2,
        t: ArrayLike | None = None, n_out: int | None = None, return_var: Literal[True],
        solver: str = "banded", threads: int | None = None
        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def lgs(y: ArrayLike, lam: float = 1.0, sigma: float = 1.0, *, order: int = 2,
        t: ArrayLike | None = None, n_out: int | None = None, return_var: bool = False,
        solver: str = "banded", threads: int | None = None
        ) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Posterior mean of the LGS for observations y, one column per channel.

    Parameters
    ----------
    y : array_like, shape (n_obs,) or (n_obs, m)
        Observations; float64 C-contiguous input is used without a copy.
    lam, sigma : float
        Smoothness weight (>= 0) and observation noise (> 0).
    order : {1, 2}
        First-difference (tridiagonal) or second-difference (pentadiagonal) prior.
    t : array_like, shape (n_obs,), optional
        Sorted fractional positions of the observations on the output grid, in
        [0, n_out - 1]. Default: observation i at frame i.
    n_out : int, optional
        Frames of the output grid; default n_obs. Required to differ from n_obs only with t.
    return_var : bool
        Also return the posterior variance per output frame, shape (n_out,).
    solver : {"banded", "cholmod"}
        The library's banded LDL^T (default, O(n m)) or the CHOLMOD sparse path; "cholmod"
        raises UnsupportedError where ``have_cholmod()`` is False (the wheels).
    threads : int, optional
        None (default): on a machine with two or more processors, a second thread maps the
        pages of a large result (8 MiB or more) while the solve fills it, which saves the page
        faults of new memory (about 40% of a 100,000 x 127 solve); 1: one thread. Same result.

    Returns
    -------
    x : numpy.ndarray, shape (n_out,) or (n_out, m)
        The posterior mean.
    var : numpy.ndarray, shape (n_out,)
        Only with ``return_var``: ``(x, var)`` is returned.

    Raises
    ------
    mlayer.InvalidArgumentError
        (also a ValueError) For bad shapes, parameters or non-finite values.
    mlayer.SingularMatrixError
        When the observations do not determine the result.
    mlayer.UnsupportedError
        For ``solver="cholmod"`` in a build without CHOLMOD.

    Examples
    --------
    >>> import numpy as np
    >>> import mlayer
    >>> y = np.sin(np.linspace(0, 3, 50)) + np.random.default_rng(0).normal(0, 0.05, 50)
    >>> x = mlayer.lgs(y, lam=5.0)
    >>> x.shape
    (50,)
    """
    y = _arrays.as_f64(y, "y", ndim=(1, 2))
    n_obs = y.shape[0]
    if n_out is None:
        if t is not None:
            raise InvalidArgumentError("n_out is required when t is given")
        n_out = n_obs
    if return_var and solver != "banded":
        raise InvalidArgumentError("return_var needs solver='banded' (the variance comes from "
                                   "selected inversion of the banded factor)")
    with LGS(n_out, lam, sigma, order=order, t=t, n_obs=n_obs, solver=solver) as g:
        x = g.solve(y, threads=threads)
        if return_var:
            return x, g.variance()
        return x


__all__ = ["LGS", "lgs", "have_cholmod"]
