"""Low-dimensional motion manifold (paper 2, section 3): PCA by SVD and the GRBF mapping.

:class:`PCA` gives a linear embedding of pose features. :class:`GRBF` is the generative
mapping of equations 1-2, y = B psi(x): N radial basis functions on a regular lattice of
centres in the 2-D embedding (thin plate ``u^2 log u`` or Gaussian ``exp(-(u/width)^2)``), plus
the polynomial terms 1, x1, x2, fitted to many outputs at once by least squares. The kernel
values come from the C core (``mlr_grbf_basis``); the solves are numpy's LAPACK.
"""
from __future__ import annotations

from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays, _attrs
from .._native import ffi, lib
from ..errors import InvalidArgumentError, SingularMatrixError, check
from .._args import default_threads, integer

__all__ = ["PCA", "GRBF", "lattice_points"]


def _data(X: ArrayLike, name: str = "X", *, min_rows: int = 1) -> NDArray[np.float64]:
    X = _arrays.as_f64(X, name, ndim=2)
    if X.shape[0] < min_rows or X.shape[1] == 0:
        raise InvalidArgumentError(f"{name}: empty data, shape {X.shape}" if X.size == 0 else
                                   f"{name}: needs at least {min_rows} rows, got {X.shape[0]}")
    _arrays.require_finite(X, name)
    return X


class PCA(_attrs.ReadOnlyAttributes):
    """Principal component analysis by the SVD of the centred data.

    After :meth:`fit`: ``mean_`` (d,), ``components_`` (n_components, d, orthonormal rows, the
    sign fixed so that the largest entry of each row is positive), ``singular_values_``,
    ``explained_variance_`` (variance along each component, ddof=1) and
    ``explained_variance_ratio_``. These and ``n_components`` are read-only (AttributeError
    when assigned): :meth:`fit` sets them together; make a new PCA for another number of
    components.

    Parameters
    ----------
    n_components : int, optional
        Components kept (>= 1).
    """
    n_components: int
    mean_: NDArray[np.float64]
    singular_values_: NDArray[np.float64]
    explained_variance_: NDArray[np.float64]
    explained_variance_ratio_: NDArray[np.float64]

    _readonly = ("n_components", "mean_", "components_", "singular_values_",
                 "explained_variance_", "explained_variance_ratio_")

    def __init__(self, n_components: int = 2) -> None:
        self.n_components = integer(n_components, "PCA: n_components", 1)

    @_attrs.builds
    def fit(self, X: ArrayLike) -> PCA:
        """Fit the components to the rows of X.

        Parameters
        ----------
        X : array_like, shape (n, d)
            At least 2 finite rows; ``n_components <= min(n, d)``.

        Returns
        -------
        PCA
            ``self``.

        Raises
        ------
        mlayer.InvalidArgumentError
            For too few rows or too many components.
        """
        X = _data(X, min_rows=2)
        n, d = X.shape
        if self.n_components > min(n, d):
            raise InvalidArgumentError(f"PCA: n_components = {self.n_components} exceeds "
                                       f"min(n, d) = {min(n, d)} for data of shape {X.shape}")
        self.mean_ = X.mean(axis=0)
        _, s, vt = np.linalg.svd(X - self.mean_, full_matrices=False)
        vt = vt[:self.n_components]
        big = np.argmax(np.abs(vt), axis=1)
        vt *= np.sign(vt[np.arange(vt.shape[0]), big])[:, None]
        self.components_ = vt
        self.singular_values_ = s[:self.n_components]
        var = s ** 2 / (n - 1)
        self.explained_variance_ = var[:self.n_components]
        total = var.sum()
        self.explained_variance_ratio_ = self.explained_variance_ / total if total > 0 \
            else np.zeros(self.n_components)
        return self

    def _fitted(self) -> None:
        if not hasattr(self, "components_"):
            raise InvalidArgumentError("PCA: call fit first")

    def transform(self, X: ArrayLike) -> NDArray[np.float64]:
        """Coordinates of rows in the principal axes.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        numpy.ndarray, shape (n, n_components)
            The coordinates.

        Raises
        ------
        mlayer.InvalidArgumentError
            Before :meth:`fit`, or for another dimension.
        """
        self._fitted()
        X = _data(X)
        if X.shape[1] != self.mean_.shape[0]:
            raise InvalidArgumentError(f"PCA: dimension mismatch, X has {X.shape[1]} columns, "
                                       f"the model {self.mean_.shape[0]}")
        return (X - self.mean_) @ self.components_.T

    def fit_transform(self, X: ArrayLike) -> NDArray[np.float64]:
        """:meth:`fit`, then :meth:`transform` of the same rows.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        numpy.ndarray, shape (n, n_components)
            The coordinates.
        """
        return self.fit(X).transform(X)

    def inverse_transform(self, Z: ArrayLike) -> NDArray[np.float64]:
        """Points of the data space for coordinates in the principal axes.

        Parameters
        ----------
        Z : array_like, shape (n, n_components)
            The coordinates.

        Returns
        -------
        numpy.ndarray, shape (n, d)
            The points.
        """
        self._fitted()
        Z = _arrays.as_f64(Z, "Z", ndim=2)
        if Z.shape[1] != self.n_components:
            raise InvalidArgumentError(f"PCA: Z must have {self.n_components} columns, got "
                                       f"{Z.shape[1]}")
        return Z @ self.components_ + self.mean_


def lattice_points(lattice: tuple[int, int],
                   bounds: tuple[tuple[float, float], tuple[float, float]]
                   ) -> NDArray[np.float64]:
    """The points of a regular rows x cols lattice.

    Parameters
    ----------
    lattice : tuple of int
        (rows, cols).
    bounds : ((float, float), (float, float))
        ((x0, x1), (y0, y1)): the span.

    Returns
    -------
    numpy.ndarray, shape (rows * cols, 2)
        Row-major: point r * cols + c is (x0 + r dx, y0 + c dy).
    """
    rows, cols = _lattice(lattice)
    (x0, x1), (y0, y1) = bounds
    xs = np.linspace(x0, x1, rows) if rows > 1 else np.array([(x0 + x1) / 2.0])
    ys = np.linspace(y0, y1, cols) if cols > 1 else np.array([(y0 + y1) / 2.0])
    g = np.empty((rows, cols, 2))
    g[..., 0] = xs[:, None]
    g[..., 1] = ys[None, :]
    return g.reshape(-1, 2)


def _lattice(lattice: Any) -> tuple[int, int]:
    try:
        rows, cols = lattice
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"lattice must be two integers (rows, cols), got "
                                   f"{lattice!r}") from None
    return integer(rows, "lattice rows", 1), integer(cols, "lattice cols", 1)


_KERNELS = ("thin_plate", "gaussian")


def _sqdist(X: NDArray[np.float64], C: NDArray[np.float64]) -> NDArray[np.float64]:
    """Squared distances (n, N) between the rows of X and C (2-D: written out, exact 0 on
    coincident points)."""
    d = X[:, None, 0] - C[None, :, 0]
    d2 = d * d
    for j in range(1, X.shape[1]):
        d = X[:, None, j] - C[None, :, j]
        d *= d
        d2 += d
    return d2


_KERNEL_IDS = {"thin_plate": lib.MLR_GRBF_THIN_PLATE, "gaussian": lib.MLR_GRBF_GAUSSIAN}

# rows of a triangular block solve
_TRI_BLOCK = 256


class GRBF(_attrs.ReadOnlyAttributes):
    """Generalized radial basis function mapping from e-dimensional points (e = 2 for the
    manifold) to d outputs: ``f(x) = sum_i w_i phi(|x - c_i|) + a0 + a . x``.

    :meth:`fit` solves for B = [w; a] with the side conditions sum w_i = 0, sum w_i c_i = 0
    (which make thin-plate interpolation unique). With as many training points as centres the
    system is square and solved exactly (at points equal to the centres, f interpolates them,
    as scipy's RBFInterpolator does); with more points it is the least-squares fit under the
    same conditions; with fewer it is underdetermined and refused. :meth:`predict` evaluates
    psi(x) B in the C core (``mlr_grbf_eval``), psi never stored.

    How the fit solves:

    - training points equal to a lattice of centres (interpolation on the lattice), in the C
      core (``mlr_grbf_fit_lattice``): the lattice is symmetric under the reflections
      x -> x0 + x1 - x and y -> y0 + y1 - y, and so is the kernel matrix, so in the basis of
      even and odd combinations of mirrored centres the bordered system splits exactly into
      four independent systems of about N/4 unknowns each (the constant term in the even-even
      one, the centred x and y terms in the odd-even and even-odd ones); in each a Householder
      reflection removes the side condition and leaves a positive definite matrix for
      Cholesky. About 1/16 of the work of one LU of the whole system, the same solution up to
      rounding. (Should rounding make a class indefinite, the whole system goes to LU as
      below.)
    - other square systems: numpy's LU of the bordered system [[Phi, Pp], [Pc^T, 0]];
    - more points than centres (or a ridge): w = Z beta with Z an orthonormal basis of the w
      the side conditions allow (Householder QR of Pc = [1, c], applied as a rank-(e+1)
      update), then least squares in (a, beta) by numpy's QR factorization of
      [Pp, Phi Z | Y] (R and Q^T Y at once, no explicit Q), with rows sqrt(lam) I under Phi Z
      for the ridge.

    Parameters
    ----------
    kernel : {"thin_plate", "gaussian"}, optional
        ``phi(u) = u^2 log u`` or ``phi(u) = exp(-(u / width)^2)``.
    lattice : tuple of int, optional
        (rows, cols) of the regular lattice of centres (the paper uses 15 x 15), spanning
        ``bounds``.
    centers : array_like, shape (N, e), optional
        Explicit centres instead of a lattice.
    bounds : ((float, float), (float, float)), optional
        ((x0, x1), (y0, y1)) of the lattice; default: the box of the training points.
    width : float, optional
        The Gaussian's width; default the larger lattice spacing.
    smoothing : float, optional
        Ridge weight on the kernel weights w, relative to the mean squared norm of the basis
        columns (scale-free; default 0).
    n_threads : int, optional
        Threads of the C core's kernel values, lattice fit and evaluation (default: the CPUs
        available; the values do not depend on it). numpy's BLAS, used by the other fits, has
        its own threads.

    Attributes
    ----------
    kernel, lattice, bounds, centers, width, smoothing
        The arguments (read-only: make a new GRBF for others).
    n_threads : int
        Assignable: an integer 1 .. 64 (InvalidArgumentError otherwise).
    centers_, coef_, width_, bounds_, n_outputs_
        After :meth:`fit`, read-only: the centres, the coefficients B (N + 1 + e, d), the
        Gaussian's width, the lattice's box and d.

    Raises
    ------
    mlayer.InvalidArgumentError
        For an unknown kernel or bad lattice, centres, bounds, width or smoothing.
    """
    bounds: tuple[tuple[float, ...], ...] | None
    centers: NDArray[np.float64] | None
    width: float | None
    smoothing: float
    n_threads: int
    width_: float
    n_outputs_: int

    _readonly = ("kernel", "lattice", "bounds", "centers", "width", "smoothing", "centers_",
                 "coef_", "width_", "bounds_", "n_outputs_")
    _checked = {"n_threads": _attrs.integer(1, 64)}

    def __init__(self, kernel: str = "thin_plate", lattice: tuple[int, int] = (15, 15), *,
                 centers: ArrayLike | None = None,
                 bounds: tuple[tuple[float, float], tuple[float, float]] | None = None,
                 width: float | None = None, smoothing: float = 0.0,
                 n_threads: int | None = None) -> None:
        if kernel not in _KERNELS:
            raise InvalidArgumentError(f"GRBF: kernel must be one of {_KERNELS}, got {kernel!r}")
        self.kernel = kernel
        self.lattice: tuple[int, int] | None = None if centers is not None \
            else _lattice(lattice)
        self.bounds = None if bounds is None else tuple(tuple(float(v) for v in b)
                                                        for b in bounds)
        if self.bounds is not None and (len(self.bounds) != 2 or any(
                len(b) != 2 or not np.all(np.isfinite(b)) or b[1] < b[0] for b in self.bounds)):
            raise InvalidArgumentError(f"GRBF: bounds must be ((x0, x1), (y0, y1)) with x0 <= x1,"
                                       f" got {bounds!r}")
        self.centers = None if centers is None else _data(centers, "centers")
        if width is not None and not (np.isfinite(width) and width > 0):
            raise InvalidArgumentError(f"GRBF: width must be finite and > 0, got {width!r}")
        self.width = None if width is None else float(width)
        if not (np.isfinite(smoothing) and smoothing >= 0):
            raise InvalidArgumentError(f"GRBF: smoothing must be finite and >= 0, got "
                                       f"{smoothing!r}")
        self.smoothing = float(smoothing)
        self.n_threads = (default_threads() if n_threads is None
                          else integer(n_threads, "GRBF: n_threads", 1, 64))
        self.coef_: NDArray[np.float64] | None = None

    # -- basis ---------------------------------------------------------------------------------

    def _basis(self, X: NDArray[np.float64], poly: bool,
               out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """[phi(|x - c_j|) ...] (and 1, x with poly) for the rows of X, by the C core, into the
        first columns of the first rows of out (C-contiguous float64, at least that large; a
        new (n, cols) array when None). Returns out."""
        kernel, width, threads = self._c_params()
        C = self._centers()
        N, e = C.shape
        X = self._points(X, e)
        cols = N + (1 + e if poly else 0)
        if out is None:
            out = np.empty((X.shape[0], cols))
        if not (out.flags.c_contiguous and out.shape[0] >= X.shape[0] and out.shape[1] >= cols):
            raise InvalidArgumentError("GRBF: internal basis buffer too small")
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_grbf_basis(kernel, width, _arrays.ptr(C), N, e, _arrays.ptr(X),
                                 X.shape[0], e, e, int(poly), threads, _arrays.ptr_out(out),
                                 out.shape[1], ffi.NULL, diag), "mlayer.GRBF", diag)
        return out

    def design(self, X: ArrayLike) -> NDArray[np.float64]:
        """The basis matrix psi(X).

        Parameters
        ----------
        X : array_like, shape (n, e)
            Points.

        Returns
        -------
        numpy.ndarray, shape (n, N + 1 + e)
            ``[phi(|x - c_i|) ..., 1, x]``.
        """
        if self.coef_ is None:
            raise InvalidArgumentError("GRBF: call fit first")
        return self._basis(self._points(X), True)

    def _points(self, X: ArrayLike, e: int | None = None) -> NDArray[np.float64]:
        X = _data(X, "points")
        if e is None and self.coef_ is not None:
            e = self._centers().shape[1]
        if e is not None and X.shape[1] != e:
            raise InvalidArgumentError(f"GRBF: dimension mismatch, points have {X.shape[1]} "
                                       f"columns, the centres {e}")
        return X

    # The fitted attributes are public (and saved by PrimitiveModel); they are checked again
    # before each C call, which reads them with the sizes given here.
    def _centers(self) -> NDArray[np.float64]:
        C = getattr(self, "centers_", None)
        if C is None:
            raise InvalidArgumentError("GRBF: call fit first")
        return _data(C, "GRBF.centers_")

    def _c_params(self) -> tuple[int, float, int]:
        """(kernel id, width, threads) for the C calls, checked."""
        if self.kernel not in _KERNEL_IDS:
            raise InvalidArgumentError(f"GRBF.kernel must be one of {_KERNELS}, got "
                                       f"{self.kernel!r}")
        width = 0.0
        if self.kernel == "gaussian":
            width = _arrays.finite(getattr(self, "width_", 0.0), "GRBF.width_")
            if not width > 0:
                raise InvalidArgumentError(f"GRBF.width_ must be > 0, got {width!r}")
        return _KERNEL_IDS[self.kernel], width, integer(self.n_threads, "GRBF.n_threads", 1, 64)

    # -- fit and predict -----------------------------------------------------------------------

    @_attrs.builds
    def fit(self, points: ArrayLike, values: ArrayLike) -> GRBF:
        """Fit the coefficients B to values at points.

        Parameters
        ----------
        points : array_like, shape (n, e)
            The training points (at least as many as the centres).
        values : array_like, shape (n, d) or (n,)
            The values there.

        Returns
        -------
        GRBF
            ``self``.

        Raises
        ------
        mlayer.InvalidArgumentError
            For fewer points than centres, a rank-deficient system or bad shapes.
        """
        P = _data(points, "points")
        Y = _arrays.as_f64(values, "values", ndim=(1, 2))
        self._vector = Y.ndim == 1
        if self._vector:
            Y = Y[:, None]
        if Y.shape[0] != P.shape[0]:
            raise InvalidArgumentError(f"GRBF: {P.shape[0]} points but {Y.shape[0]} rows of "
                                       "values")
        if Y.shape[1] == 0:
            raise InvalidArgumentError("GRBF: values have no columns")
        _arrays.require_finite(Y, "values")
        if self.centers is not None:
            C = self.centers
            if C.shape[1] != P.shape[1]:
                raise InvalidArgumentError(f"GRBF: dimension mismatch, centres have "
                                           f"{C.shape[1]} columns, points {P.shape[1]}")
        else:
            if P.shape[1] != 2:
                raise InvalidArgumentError(f"GRBF: a lattice of centres needs 2-D points, got "
                                           f"{P.shape[1]} columns (pass centers=)")
            bounds = self.bounds or tuple((float(P[:, j].min()), float(P[:, j].max()))
                                          for j in range(2))
            self.bounds_ = bounds
            assert self.lattice is not None  # no explicit centres: a lattice
            C = lattice_points(self.lattice, cast(Any, bounds))
        self.centers_ = C
        N, e = C.shape
        if self.kernel == "gaussian":
            if self.width is not None:
                self.width_ = self.width
            elif self.lattice is not None:
                (x0, x1), (y0, y1) = self.bounds_
                r, c = self.lattice
                self.width_ = max((x1 - x0) / max(r - 1, 1), (y1 - y0) / max(c - 1, 1)) or 1.0
            else:
                d2 = _sqdist(C, C)
                np.fill_diagonal(d2, np.inf)
                self.width_ = float(np.sqrt(d2.min(axis=1).max())) if N > 1 else 1.0
        n = P.shape[0]
        m = 1 + e
        if n < N:
            raise InvalidArgumentError(
                f"GRBF: {n} training points for {N} centres: underdetermined (use a smaller "
                "lattice or more points)")
        square = n == N and self.smoothing == 0.0
        coef = None
        if square and self.lattice is not None and min(self.lattice) >= 2 \
                and np.array_equal(P, C):
            try:
                coef = self._fit_lattice_c(Y)
            except SingularMatrixError:  # rounding made a class indefinite: the LU below
                coef = None
        if coef is not None:
            self.coef_ = coef
        elif square:
            # square, general: the bordered system [[Phi, Pp], [Pc^T, 0]] [w; a] = [Y; 0] by LU
            A = np.zeros((N + m, N + m))
            self._basis(P, True, A[:N])
            A[N:, :N] = _poly(C).T
            rhs = np.zeros((N + m, Y.shape[1]))
            rhs[:N] = Y
            self.coef_ = _solve(A, rhs)
        else:
            if N <= m:
                raise InvalidArgumentError(f"GRBF: needs more than {m} centres, got {N}")
            V, T = _householder(_poly(C))
            a, beta = self._fit_least_squares(P, Y, V, T, m)
            w = np.zeros((N, Y.shape[1]))
            w[m:] = beta
            w -= V @ (T @ (V.T @ w))  # w = Q [0; beta]
            self.coef_ = np.vstack([w, a])
        self.n_outputs_ = Y.shape[1]
        return self

    def _fit_lattice_c(self, Y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Interpolation on the lattice by the C core (``mlr_grbf_fit_lattice``: the four
        symmetry classes of the class notes, each by Cholesky after a Householder reflection
        removes its side condition, one thread per class)."""
        assert self.lattice is not None  # called for a lattice of centres only
        R, Cn = self.lattice
        C3 = self.centers_.reshape(R, Cn, 2)
        xs = np.ascontiguousarray(C3[:, 0, 0])
        ys = np.ascontiguousarray(C3[0, :, 1])
        d = Y.shape[1]
        Y = np.ascontiguousarray(Y)
        coef = np.empty((R * Cn + 3, d))
        diag = ffi.new("mlr_diag *")
        kernel, width, threads = self._c_params()
        check(lib.mlr_grbf_fit_lattice(kernel, width, _arrays.ptr(xs), R,
                                       _arrays.ptr(ys), Cn, _arrays.ptr(Y), d, d, threads,
                                       _arrays.ptr_out(coef), d, ffi.NULL, diag),
              "mlayer.GRBF.fit", diag)
        return coef

    def _fit_least_squares(self, P: NDArray[np.float64], Y: NDArray[np.float64],
                           V: NDArray[np.float64], T: NDArray[np.float64], m: int
                           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """More points than centres (or a ridge): least squares in (a, beta) by QR of the
        augmented matrix [Pp, Phi Z, Y] (rows of sqrt(lam) I under Phi Z for the ridge)."""
        N = self.centers_.shape[0]
        n, d = Y.shape
        extra = N - m if self.smoothing > 0 else 0
        M = np.zeros((n + extra, N + d))
        self._basis(P, False, M)  # Phi in M[:n, :N]
        Phi = M[:n, :N]
        Phi -= (Phi @ V) @ (T @ V.T)  # Phi Q; its first m columns (w along Y) are dropped
        M[:n, :m] = _poly(P)
        M[:n, N:] = Y
        if extra:
            lam = self.smoothing * float(np.mean(np.sum(M[:n, m:N] ** 2, axis=0)))
            M[n:, m:N] = np.sqrt(lam) * np.eye(N - m)
        Rm = cast(NDArray[np.float64], np.linalg.qr(M, mode="r"))
        R = Rm[:N, :N]
        diag = np.abs(np.diag(R))
        if not diag.min() > np.finfo(float).eps * max(M.shape) * diag.max():
            raise SingularMatrixError(
                f"GRBF: the training points do not determine the {N} centres' weights "
                "(rank-deficient least squares); use fewer centres or spread the points")
        sol = _solve_upper(R, Rm[:N, N:])
        return sol[:m], sol[m:]

    def predict(self, points: ArrayLike) -> NDArray[np.float64]:
        """Values at points: psi(x) B in one pass of the C core (``mlr_grbf_eval``).

        Kernel values and products are computed block by block, psi never stored.
        ``model(points)`` is the same.

        Parameters
        ----------
        points : array_like, shape (n, e)
            The points.

        Returns
        -------
        numpy.ndarray, shape (n, d) or (n,)
            The values; (n,) if :meth:`fit` was given a vector.

        Raises
        ------
        mlayer.InvalidArgumentError
            Before :meth:`fit`, or for points of another dimension.
        """
        if self.coef_ is None:
            raise InvalidArgumentError("GRBF: call fit first")
        kernel, width, threads = self._c_params()
        C = self._centers()
        N, e = C.shape
        X = self._points(points, e)
        coef = _arrays.as_f64(self.coef_, "GRBF.coef_", ndim=2)
        if coef.shape[0] != N + 1 + e or coef.shape[1] == 0:
            raise InvalidArgumentError(f"GRBF.coef_ must be ({N + 1 + e}, d) for {N} centres of "
                                       f"dimension {e}, got {coef.shape}")
        d = coef.shape[1]
        out = np.empty((X.shape[0], d))
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_grbf_eval(kernel, width, _arrays.ptr(C), N, e, _arrays.ptr(coef), d, d,
                                _arrays.ptr(X), X.shape[0], e, e, threads, _arrays.ptr_out(out),
                                d, ffi.NULL, diag), "mlayer.GRBF.predict", diag)
        return out[:, 0] if getattr(self, "_vector", False) and d == 1 else out

    __call__ = predict


def _poly(X: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.hstack([np.ones((X.shape[0], 1)), X])


def _householder(Pc: NDArray[np.float64]) -> Any:
    """Compact WY form of the Householder QR of Pc (N, m): Q = I - V T V^T (V unit lower
    trapezoidal (N, m), T upper triangular (m, m)). Refuses a rank-deficient Pc (centres on a
    line: the linear terms are not determined)."""
    h, tau = np.linalg.qr(Pc, mode="raw")
    H = h.T
    m = Pc.shape[1]
    R = np.triu(H[:m])
    dr = np.abs(np.diag(R))
    if not dr.min() > np.finfo(float).eps * Pc.shape[0] * dr.max():
        raise SingularMatrixError("GRBF: the centres lie on a line (or a plane in 3-D ...): "
                                  "the polynomial terms are not determined")
    V = np.tril(H, -1)
    V[np.arange(m), np.arange(m)] = 1.0
    T = np.zeros((m, m))
    for j in range(m):  # LAPACK larft, forward, columnwise
        T[j, j] = tau[j]
        if j:
            T[:j, j] = -tau[j] * (T[:j, :j] @ (V[:, :j].T @ V[:, j]))
    return V, T


def _solve_upper(U: np.ndarray, B: np.ndarray) -> np.ndarray:
    """X with U X = B for U upper triangular: backward substitution by blocks."""
    X = np.array(B, dtype=np.float64)
    n = U.shape[0]
    for i1 in range(n, 0, -_TRI_BLOCK):
        i0 = max(i1 - _TRI_BLOCK, 0)
        if i1 < n:
            X[i0:i1] -= U[i0:i1, i1:] @ X[i1:]
        X[i0:i1] = np.linalg.solve(U[i0:i1, i0:i1], X[i0:i1])
    return X


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve the square system by LU (LAPACK gesv)."""
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError as e:
        raise SingularMatrixError(f"GRBF: singular system ({e}); are two training points "
                                  "equal?") from None
