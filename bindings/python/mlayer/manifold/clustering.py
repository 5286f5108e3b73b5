"""k-means clustering (C core) and the elbow rule for choosing k (paper 2, section 4.1).

``kmeans`` follows scikit-learn's ``KMeans(algorithm="lloyd")``: the same initial centres give
the same labels and inertia (up to rounding). ``tol`` is relative to the mean variance of the
columns of X, as in scikit-learn. Seeds drive mlayer's own generator, not NumPy's.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._args import default_threads, integer
from .._native import ffi, lib
from .._optional import require
from ..errors import InvalidArgumentError, check

if TYPE_CHECKING:
    from matplotlib.axes import Axes

_ALGORITHMS = {"auto": lib.MLR_KMEANS_AUTO, "lloyd": lib.MLR_KMEANS_LLOYD,
               "hamerly": lib.MLR_KMEANS_HAMERLY}


@dataclass(frozen=True)
class KMeansResult:
    """Result of :func:`kmeans`.

    Attributes
    ----------
    centers : numpy.ndarray, shape (k, d)
        The centres.
    labels : numpy.ndarray of int32, shape (n,)
        The centre of each row.
    inertia : float
        Sum of squared distances to the centres.
    n_iter : int
        Lloyd iterations of the kept run.
    n_skipped : int
        Rows whose search the Hamerly bounds skipped, over all iterations.
    """
    centers: NDArray[np.float64]
    labels: NDArray[np.int32]
    inertia: float
    n_iter: int
    n_skipped: int = 0

    def predict(self, X: ArrayLike) -> NDArray[np.int32]:
        """Index of the nearest centre of each row (lowest index on exact ties).

        Parameters
        ----------
        X : array_like, shape (n, d)
            Rows.

        Returns
        -------
        numpy.ndarray of int32, shape (n,)
            The labels.
        """
        return predict(self.centers, X)


def _prepare_data(X: ArrayLike, name: str = "X") -> NDArray[np.float64]:
    X = _arrays.as_f64(X, name, ndim=2)
    if X.shape[0] == 0 or X.shape[1] == 0:
        raise InvalidArgumentError(f"{name}: empty data, shape {X.shape}")
    return X


def kmeans(X: ArrayLike, k: int, *, init: str | ArrayLike = "k-means++", n_init: int = 1,
           max_iter: int = 300, tol: float = 1e-4, seed: int = 0, algorithm: str = "auto",
           n_threads: int | None = None) -> KMeansResult:
    """Cluster rows into k groups.

    Parameters
    ----------
    X : array_like, shape (n, d)
        The rows.
    k : int
        Clusters, 1 <= k <= n.
    init : "k-means++" or array_like, shape (k, d), optional
        ``"k-means++"`` (seeded; ``n_init`` runs, the lowest inertia kept) or initial centres
        (one run).
    n_init : int, optional
        Runs of k-means++.
    max_iter : int, optional
        Iterations per run.
    tol : float, optional
        Relative to the mean variance of the columns of X, as in scikit-learn.
    seed : int, optional
        Seed of mlayer's own generator (not NumPy's).
    algorithm : {"auto", "lloyd", "hamerly"}, optional
        ``"auto"``: Hamerly bounds when k >= 4; all give the same labels.
    n_threads : int, optional
        Default :func:`default_threads`; the result is bit-identical for every thread count.

    Returns
    -------
    KMeansResult
        Centres, labels, inertia and counts.

    Raises
    ------
    mlayer.InvalidArgumentError
        For empty data, k > n, or bad options.
    """
    X = _prepare_data(X)
    n, d = X.shape
    k = integer(k, "k", 1)
    if k > n:
        raise InvalidArgumentError(f"k = {k} exceeds the number of rows n = {n}")
    if algorithm not in _ALGORITHMS:
        raise InvalidArgumentError(f"algorithm must be one of {sorted(_ALGORITHMS)}, "
                                   f"got {algorithm!r}")
    n_threads = default_threads() if n_threads is None else integer(n_threads, "n_threads", 1)
    if isinstance(init, str):
        if init != "k-means++":
            raise InvalidArgumentError(f"init must be 'k-means++' or an array, got {init!r}")
        init_arr = None
    else:
        init_arr = _arrays.as_f64(init, "init", ndim=2)
        if init_arr.shape != (k, d):
            raise InvalidArgumentError(f"init: expected shape {(k, d)}, got {init_arr.shape}")
    out = ffi.new("mlr_kmeans **")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_kmeans_create(k, d, ffi.NULL, out, diag), "mlayer.kmeans", diag)
    h = ffi.gc(out[0], lib.mlr_kmeans_destroy)
    try:
        for key, v, nm in ((lib.MLR_KMEANS_MAX_ITER, integer(max_iter, "max_iter", 1), "max_iter"),
                           (lib.MLR_KMEANS_TOL, float(tol), "tol"),
                           (lib.MLR_KMEANS_N_INIT, integer(n_init, "n_init", 1), "n_init"),
                           (lib.MLR_KMEANS_SEED, integer(seed, "seed", 0), "seed"),
                           (lib.MLR_KMEANS_N_THREADS, n_threads, "n_threads"),
                           (lib.MLR_KMEANS_ALGORITHM, _ALGORITHMS[algorithm], "algorithm")):
            check(lib.mlr_kmeans_set(h, key, float(v), diag), f"mlayer.kmeans ({nm})", diag)
        labels = np.empty(n, dtype=np.int32)
        code = lib.mlr_kmeans_fit(h, _arrays.ptr(X), n, d,
                                  _arrays.ptr(init_arr) if init_arr is not None else ffi.NULL, d,
                                  ffi.cast("int32_t *", ffi.from_buffer(labels,
                                                                        require_writable=True)),
                                  diag)
        check(code, "mlayer.kmeans", diag)
        centers = np.frombuffer(ffi.buffer(lib.mlr_kmeans_centers(h), k * d * 8),
                                dtype=np.float64).reshape(k, d).copy()
        return KMeansResult(centers, labels, float(lib.mlr_kmeans_inertia(h)),
                            int(lib.mlr_kmeans_n_iter(h)), int(lib.mlr_kmeans_n_skipped(h)))
    finally:
        ffi.release(h)


def predict(centers: ArrayLike, X: ArrayLike) -> NDArray[np.int32]:
    """Index of the nearest centre for each row.

    Parameters
    ----------
    centers : array_like, shape (k, d)
        The centres.
    X : array_like, shape (n, d)
        The rows.

    Returns
    -------
    numpy.ndarray of int32, shape (n,)
        The labels (lowest index on exact ties).

    Raises
    ------
    mlayer.InvalidArgumentError
        For a dimension mismatch.
    """
    C = _prepare_data(centers, "centers")
    X = _arrays.as_f64(X, "X", ndim=2)
    k, d = C.shape
    if X.shape[1] != d:
        raise InvalidArgumentError(f"X: dimension mismatch, {X.shape[1]} columns for centres "
                                   f"of dimension {d}")
    out = ffi.new("mlr_kmeans **")
    diag = ffi.new("mlr_diag *")
    where = "mlayer.manifold.clustering.predict"
    check(lib.mlr_kmeans_create(k, d, ffi.NULL, out, diag), where, diag)
    h = ffi.gc(out[0], lib.mlr_kmeans_destroy)
    try:
        check(lib.mlr_kmeans_set_centers(h, _arrays.ptr(C), d, diag), where, diag)
        labels = np.empty(X.shape[0], dtype=np.int32)
        if X.shape[0]:
            check(lib.mlr_kmeans_predict(
                h, _arrays.ptr(X), X.shape[0], d,
                ffi.cast("int32_t *", ffi.from_buffer(labels, require_writable=True)),
                ffi.NULL, diag), where, diag)
        return labels
    finally:
        ffi.release(h)


@dataclass(frozen=True)
class ElbowResult:
    """The elbow rule's choice (:func:`elbow`).

    Attributes
    ----------
    k : int
        The chosen k.
    ks : numpy.ndarray
        The ks tried, increasing.
    inertia : numpy.ndarray
        Their inertias.
    score : numpy.ndarray
        The distance of each point of the normalized curve below the chord (the criterion).
    results : tuple of KMeansResult
        One per k.
    """
    k: int
    ks: NDArray[np.int64]
    inertia: NDArray[np.float64]
    score: NDArray[np.float64]
    results: tuple[KMeansResult, ...]

    def plot(self, ax: Axes | None = None) -> Axes:
        """Inertia against k with the chosen k marked (matplotlib).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new pyplot figure's axes.

        Returns
        -------
        matplotlib.axes.Axes
            The axes.
        """
        require("matplotlib", feature="mlayer.ElbowResult.plot")
        import matplotlib.pyplot as plt
        if ax is None:
            ax = plt.figure(figsize=(5, 3.5)).add_subplot()
        ax.plot(self.ks, self.inertia, "o-", color="tab:blue")
        i = int(np.flatnonzero(self.ks == self.k)[0])
        ax.plot([self.k], [self.inertia[i]], "o", ms=12, mfc="none", color="tab:red",
                label=f"elbow: k = {self.k}")
        ax.set_xlabel("k")
        ax.set_ylabel("inertia")
        ax.legend()
        return ax


def elbow_point(ks: ArrayLike, inertia: ArrayLike) -> tuple[int, NDArray[np.float64]]:
    """The elbow of a decreasing curve inertia(k): the kneedle rule.

    Both axes are scaled to [0, 1] (k by its range, inertia by its range), so the curve runs
    from (0, 1) to (1, 0); the elbow is the k whose point lies farthest below the chord
    joining the end points, i.e. that maximizes (1 - x) - y, the vertical gap to the chord
    (proportional to the Euclidean distance to it). Ties go to the smaller k. With fewer than
    3 ks, or a flat curve, the smallest k is returned.

    Parameters
    ----------
    ks : array_like, shape (m,)
        The ks.
    inertia : array_like, shape (m,)
        Their inertias.

    Returns
    -------
    k : int
        The elbow.
    scores : numpy.ndarray, shape (m,)
        The criterion of each k, in increasing k.
    """
    ks = np.asarray(ks, dtype=np.float64)
    y = np.asarray(inertia, dtype=np.float64)
    if ks.ndim != 1 or ks.shape != y.shape or ks.size == 0:
        raise InvalidArgumentError("ks and inertia must be 1-D of the same non-zero length")
    order = np.argsort(ks, kind="stable")
    ks, y = ks[order], y[order]
    if ks.size < 3 or y.max() == y.min() or ks[-1] == ks[0]:
        return int(ks[0]), np.zeros(ks.size)
    xn = (ks - ks[0]) / (ks[-1] - ks[0])
    yn = (y - y.min()) / (y.max() - y.min())
    score = (1.0 - xn) - yn
    return int(ks[int(np.argmax(score))]), score


def elbow(X: ArrayLike, ks: Iterable[int], **kwargs: Any) -> ElbowResult:
    """Run :func:`kmeans` for every k and choose k by the elbow rule (:func:`elbow_point`).

    Parameters
    ----------
    X : array_like, shape (n, d)
        The rows.
    ks : iterable of int
        Distinct ks.
    **kwargs
        Passed to :func:`kmeans`.

    Returns
    -------
    ElbowResult
        The choice with the curve.
    """
    ks = [integer(k, "k", 1) for k in ks]
    if not ks:
        raise InvalidArgumentError("ks is empty")
    if len(set(ks)) != len(ks):
        raise InvalidArgumentError("ks has repeated values")
    ks = sorted(ks)
    results = tuple(kmeans(X, k, **kwargs) for k in ks)
    inertia = np.array([r.inertia for r in results])
    k, score = elbow_point(ks, inertia)
    return ElbowResult(k, np.array(ks), inertia, score, results)


def silhouette_score(X: ArrayLike, labels: ArrayLike) -> float:
    """Mean silhouette of rows for labels (Euclidean distances).

    As scikit-learn's ``silhouette_score``: ``s_i = (b_i - a_i) / max(a_i, b_i)`` with a_i the
    mean distance to the other rows of i's cluster and b_i the smallest mean distance to
    another cluster's rows; 0 for a row alone in its cluster. Exact, and cheap on manifold
    points with many repeats (SOM lattice positions): equal rows with equal labels are
    counted once, with their multiplicity.

    Parameters
    ----------
    X : array_like, shape (n, d)
        The rows, finite.
    labels : array_like of int, shape (n,)
        Their clusters: 2 <= clusters <= n - 1.

    Returns
    -------
    float
        The mean silhouette, in [-1, 1].
    """
    X = _prepare_data(X)
    _arrays.require_finite(X, "X")
    lab = np.asarray(labels)
    if lab.shape != (X.shape[0],) or (lab.size and not np.issubdtype(lab.dtype, np.integer)):
        raise InvalidArgumentError(f"labels: need {X.shape[0]} integers, got shape {lab.shape}")
    _, lab = np.unique(lab, return_inverse=True)
    k = int(lab.max()) + 1
    if not 2 <= k <= X.shape[0] - 1:
        raise InvalidArgumentError(f"silhouette: {k} clusters for {X.shape[0]} rows (needs "
                                   f"2 .. n - 1)")
    rows, inv, w = np.unique(np.column_stack([X, lab]), axis=0, return_inverse=True,
                             return_counts=True)
    U, ul = rows[:, :-1], rows[:, -1].astype(np.int64)
    W = np.bincount(lab, minlength=k).astype(np.float64)
    onehot = np.zeros((U.shape[0], k))
    onehot[np.arange(U.shape[0]), ul] = w
    s = np.empty(U.shape[0])
    for a in range(0, U.shape[0], 256):
        b = min(a + 256, U.shape[0])
        D = np.sqrt(np.maximum(((U[a:b, None, :] - U[None, :, :]) ** 2).sum(-1), 0.0))
        S = D @ onehot  # (chunk, k): sum of distances to each cluster's rows
        own = ul[a:b]
        n_own = W[own] - 1.0
        ai = np.where(n_own > 0, S[np.arange(b - a), own] / np.maximum(n_own, 1.0), 0.0)
        M = S / W[None, :]
        M[np.arange(b - a), own] = np.inf
        bi = M.min(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            si = (bi - ai) / np.maximum(ai, bi)
        s[a:b] = np.where(n_own > 0, np.nan_to_num(si), 0.0)
    return float((s * w).sum() / X.shape[0])


__all__ = ["kmeans", "KMeansResult", "predict", "elbow", "elbow_point", "ElbowResult",
           "default_threads", "silhouette_score"]
