"""Low-dimensional motion manifold (paper 2, section 3): PCA by SVD and the GRBF mapping.

:class:`PCA` gives a linear embedding of pose features. :class:`GRBF` is the generative
mapping of equations 1-2, y = B psi(x): N radial basis functions on a regular lattice of
centres in the 2-D embedding (thin plate ``u^2 log u`` or Gaussian ``exp(-(u/width)^2)``), plus
the polynomial terms 1, x1, x2, fitted to many outputs at once by least squares. numpy only.
"""
from __future__ import annotations

import numpy as np

from . import _arrays
from .errors import InvalidArgumentError, SingularMatrixError

__all__ = ["PCA", "GRBF", "lattice_points"]


def _data(X, name: str = "X", *, min_rows: int = 1) -> np.ndarray:
    X = _arrays.as_f64(X, name, ndim=2)
    if X.shape[0] < min_rows or X.shape[1] == 0:
        raise InvalidArgumentError(f"{name}: empty data, shape {X.shape}" if X.size == 0 else
                                   f"{name}: needs at least {min_rows} rows, got {X.shape[0]}")
    _arrays.require_finite(X, name)
    return X


class PCA:
    """Principal component analysis by the SVD of the centred data.

    After :meth:`fit`: ``mean_`` (d,), ``components_`` (n_components, d, orthonormal rows, the
    sign fixed so that the largest entry of each row is positive), ``singular_values_``,
    ``explained_variance_`` (variance along each component, ddof=1) and
    ``explained_variance_ratio_``.
    """

    def __init__(self, n_components: int = 2):
        if isinstance(n_components, bool) or int(n_components) != n_components \
                or n_components < 1:
            raise InvalidArgumentError(f"PCA: n_components must be an integer >= 1, got "
                                       f"{n_components!r}")
        self.n_components = int(n_components)

    def fit(self, X) -> "PCA":
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

    def _fitted(self):
        if not hasattr(self, "components_"):
            raise InvalidArgumentError("PCA: call fit first")

    def transform(self, X) -> np.ndarray:
        """Coordinates (n, n_components) of the rows of X in the principal axes."""
        self._fitted()
        X = _data(X)
        if X.shape[1] != self.mean_.shape[0]:
            raise InvalidArgumentError(f"PCA: dimension mismatch, X has {X.shape[1]} columns, "
                                       f"the model {self.mean_.shape[0]}")
        return (X - self.mean_) @ self.components_.T

    def fit_transform(self, X) -> np.ndarray:
        return self.fit(X).transform(X)

    def inverse_transform(self, Z) -> np.ndarray:
        """Points of the data space (n, d) for coordinates Z (n, n_components)."""
        self._fitted()
        Z = _arrays.as_f64(Z, "Z", ndim=2)
        if Z.shape[1] != self.n_components:
            raise InvalidArgumentError(f"PCA: Z must have {self.n_components} columns, got "
                                       f"{Z.shape[1]}")
        return Z @ self.components_ + self.mean_


def lattice_points(lattice, bounds) -> np.ndarray:
    """The (rows * cols, 2) points of a regular rows x cols lattice spanning
    bounds ((x0, x1), (y0, y1)), row-major: point r * cols + c is (x0 + r dx, y0 + c dy)."""
    rows, cols = _lattice(lattice)
    (x0, x1), (y0, y1) = bounds
    xs = np.linspace(x0, x1, rows) if rows > 1 else np.array([(x0 + x1) / 2.0])
    ys = np.linspace(y0, y1, cols) if cols > 1 else np.array([(y0 + y1) / 2.0])
    g = np.empty((rows, cols, 2))
    g[..., 0] = xs[:, None]
    g[..., 1] = ys[None, :]
    return g.reshape(-1, 2)


def _lattice(lattice) -> tuple[int, int]:
    try:
        rows, cols = (int(v) for v in lattice)
        ok = all(int(v) == v and not isinstance(v, bool) for v in lattice)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"lattice must be two integers (rows, cols), got "
                                   f"{lattice!r}") from None
    if not ok or rows < 1 or cols < 1:
        raise InvalidArgumentError(f"lattice must be at least 1 x 1, got {tuple(lattice)!r}")
    return rows, cols


_KERNELS = ("thin_plate", "gaussian")


def _sqdist(X: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Squared distances (n, N) between the rows of X and C (2-D: written out, exact 0 on
    coincident points)."""
    d = X[:, None, 0] - C[None, :, 0]
    d2 = d * d
    for j in range(1, X.shape[1]):
        d = X[:, None, j] - C[None, :, j]
        d *= d
        d2 += d
    return d2


class GRBF:
    """Generalized radial basis function mapping from e-dimensional points (e = 2 for the
    manifold) to d outputs: f(x) = sum_i w_i phi(|x - c_i|) + a0 + a . x.

    kernel   "thin_plate" (phi(u) = u^2 log u) or "gaussian" (phi(u) = exp(-(u / width)^2);
             width defaults to the larger lattice spacing).
    lattice  (rows, cols) of the regular lattice of centres (the paper uses 15 x 15), spanning
             ``bounds`` ((x0, x1), (y0, y1)); default bounds: the box of the training points.
    centers  an explicit (N, e) array of centres instead of a lattice.
    smoothing  ridge weight on the kernel weights w, relative to the mean squared norm of the
             basis columns (scale-free; default 0).

    :meth:`fit` solves for B = [w; a] with the side conditions sum w_i = 0, sum w_i c_i = 0
    (which make thin-plate interpolation unique). With as many training points as centres the
    system is square and solved exactly (at points equal to the centres, f interpolates them,
    as scipy's RBFInterpolator does); with more points it is the least-squares fit under the
    same conditions; with fewer it is underdetermined and refused.
    """

    def __init__(self, kernel: str = "thin_plate", lattice=(15, 15), *, centers=None,
                 bounds=None, width: float | None = None, smoothing: float = 0.0):
        if kernel not in _KERNELS:
            raise InvalidArgumentError(f"GRBF: kernel must be one of {_KERNELS}, got {kernel!r}")
        self.kernel = kernel
        self.lattice = None if centers is not None else _lattice(lattice)
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
        self.coef_ = None

    # -- basis ---------------------------------------------------------------------------------

    def _phi(self, X: np.ndarray) -> np.ndarray:
        d2 = _sqdist(X, self.centers_)
        if self.kernel == "thin_plate":
            # u^2 log u = d2 log(d2) / 2, and 0 at u = 0
            with np.errstate(divide="ignore", invalid="ignore"):
                lg = np.log(d2)
            lg[d2 == 0.0] = 0.0
            d2 *= lg
            d2 *= 0.5
            return d2
        d2 *= -1.0 / (self.width_ * self.width_)
        return np.exp(d2, out=d2)

    def _poly(self, X: np.ndarray) -> np.ndarray:
        return np.hstack([np.ones((X.shape[0], 1)), X])

    def design(self, X) -> np.ndarray:
        """psi(X): the (n, N + 1 + e) basis matrix [phi(|x - c_i|) ..., 1, x]."""
        X = self._points(X)
        return np.hstack([self._phi(X), self._poly(X)])

    def _points(self, X) -> np.ndarray:
        X = _data(X, "points")
        if self.coef_ is not None and X.shape[1] != self.centers_.shape[1]:
            raise InvalidArgumentError(f"GRBF: dimension mismatch, points have {X.shape[1]} "
                                       f"columns, the centres {self.centers_.shape[1]}")
        return X

    # -- fit and predict -----------------------------------------------------------------------

    def fit(self, points, values) -> "GRBF":
        """Fit B to values (n, d) (or (n,)) at points (n, e). Returns self."""
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
            C = lattice_points(self.lattice, bounds)
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
        Phi = self._phi(P)
        Pp = self._poly(P)
        Pc = self._poly(C)
        if n == N and self.smoothing == 0.0:
            # square: [[Phi, Pp], [Pc^T, 0]] [w; a] = [Y; 0]
            A = np.zeros((N + m, N + m))
            A[:N, :N] = Phi
            A[:N, N:] = Pp
            A[N:, :N] = Pc.T
            rhs = np.zeros((N + m, Y.shape[1]))
            rhs[:N] = Y
            self.coef_ = _solve(A, rhs)
        else:
            # w = Z beta with Z an orthonormal basis of the null space of Pc^T, then ordinary
            # least squares in (beta, a) (ridge on beta = ridge on w, Z being orthonormal)
            if N <= m:
                raise InvalidArgumentError(f"GRBF: needs more than {m} centres, got {N}")
            q, _ = np.linalg.qr(Pc, mode="complete")
            Z = q[:, m:]
            D = np.hstack([Phi @ Z, Pp])
            if self.smoothing > 0:
                lam = self.smoothing * float(np.mean(np.sum(D[:, :N - m] ** 2, axis=0)))
                reg = np.zeros((N - m, N))
                reg[:, :N - m] = np.sqrt(lam) * np.eye(N - m)
                D = np.vstack([D, reg])
                Y = np.vstack([Y, np.zeros((N - m, Y.shape[1]))])
            sol, _, rank, _ = np.linalg.lstsq(D, Y, rcond=None)
            if rank < D.shape[1]:
                raise SingularMatrixError(
                    f"GRBF: the training points do not determine the {N} centres' weights "
                    f"(rank {rank} < {D.shape[1]}); use fewer centres or spread the points")
            self.coef_ = np.vstack([Z @ sol[:N - m], sol[N - m:]])
        self.n_outputs_ = Y.shape[1]
        return self

    def predict(self, points, *, chunk: int = 4096) -> np.ndarray:
        """Values (n, d) at points (n, e) (shape (n,) if fit was given a vector)."""
        if self.coef_ is None:
            raise InvalidArgumentError("GRBF: call fit first")
        X = self._points(points)
        N = self.centers_.shape[0]
        out = np.empty((X.shape[0], self.coef_.shape[1]))
        W, a = self.coef_[:N], self.coef_[N:]
        for s in range(0, X.shape[0], chunk):
            x = X[s:s + chunk]
            o = out[s:s + chunk]
            np.matmul(self._phi(x), W, out=o)
            o += a[0]
            o += x @ a[1:]
        return out[:, 0] if self._vector else out

    __call__ = predict


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve the square system by LU (LAPACK gesv; its symmetric indefinite sysv measured 8x
    slower here with OpenBLAS)."""
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError as e:
        raise SingularMatrixError(f"GRBF: singular system ({e}); are two training points "
                                  "equal?") from None
