"""Soft clustering of manifold points (paper 2, section 4.1): fuzzy c-means and a Gaussian
mixture fitted by EM, numpy only. Hard k-means is :func:`mlayer.kmeans` (C core)."""
from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays, _attrs
from .._args import integer
from ..errors import InvalidArgumentError
from .clustering import elbow_point, kmeans, silhouette_score

if TYPE_CHECKING:
    from .clustering import KMeansResult

__all__ = ["fuzzy_cmeans", "FuzzyResult", "GaussianMixture", "k_criteria", "KCriteria",
           "CRITERIA"]


def _data(X: ArrayLike, k: int, what: str, name: str = "X") -> NDArray[np.float64]:
    X = _arrays.as_f64(X, name, ndim=2)
    if X.shape[0] == 0 or X.shape[1] == 0:
        raise InvalidArgumentError(f"{name}: empty data, shape {X.shape}")
    _arrays.require_finite(X, name)
    if k > X.shape[0]:
        raise InvalidArgumentError(f"{what} = {k} exceeds the number of rows n = {X.shape[0]}")
    return X


def _sqdist(X: NDArray[np.float64], C: NDArray[np.float64]) -> NDArray[np.float64]:
    d2 = (X * X).sum(1)[:, None] - 2.0 * (X @ C.T) + (C * C).sum(1)[None, :]
    np.maximum(d2, 0.0, out=d2)
    return d2


def _initial_centers(X: NDArray[np.float64], k: int, init: str | ArrayLike, seed: int,
                     who: str) -> NDArray[np.float64]:
    if isinstance(init, str):
        if init != "k-means++":
            raise InvalidArgumentError(f"{who}: init must be 'k-means++' or an array of "
                                       f"centres, got {init!r}")
        return kmeans(X, k, seed=seed).centers
    C = _arrays.as_f64(init, "init", ndim=2)
    if C.shape != (k, X.shape[1]):
        raise InvalidArgumentError(f"{who}: init must have shape {(k, X.shape[1])}, got "
                                   f"{C.shape}")
    _arrays.require_finite(C, "init")
    return C.copy()


# ---------------------------------------------------------------------------------------------
# fuzzy c-means


@dataclass(frozen=True)
class FuzzyResult:
    """Result of :func:`fuzzy_cmeans`.

    Attributes
    ----------
    centers : numpy.ndarray, shape (c, d)
        The centres.
    u : numpy.ndarray, shape (n, c)
        Memberships (rows sum to 1).
    labels : numpy.ndarray of int32, shape (n,)
        Argmax of u.
    objective : float
        ``J_m = sum u^m |x - v|^2``.
    n_iter : int
        Iterations.
    """
    centers: NDArray[np.float64]
    u: NDArray[np.float64]
    labels: NDArray[np.int32]
    objective: float
    n_iter: int
    _m = 2.0  # the fuzzifier of the fit (set by fuzzy_cmeans; not a field)

    def predict_proba(self, X: ArrayLike, m: float | None = None) -> NDArray[np.float64]:
        """Memberships of new rows to the fitted centres.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.
        m : float, optional
            The fuzzifier; default the exponent of the fit.

        Returns
        -------
        numpy.ndarray, shape (n, c)
            Memberships (rows sum to 1).
        """
        X = _data(X, 1, "c")
        if X.shape[1] != self.centers.shape[1]:
            raise InvalidArgumentError(f"X: dimension mismatch, {X.shape[1]} columns for "
                                       f"centres of dimension {self.centers.shape[1]}")
        return _memberships(_sqdist(X, self.centers), self._m if m is None else m)


def _memberships(d2: NDArray[np.float64], m: float) -> NDArray[np.float64]:
    """u_ik = 1 / sum_j (d_ik / d_ij)^(2 / (m - 1)); a row on a centre belongs to it alone."""
    zero = d2 <= 0.0
    with np.errstate(divide="ignore"):
        w = np.where(zero, 0.0, d2) ** (-1.0 / (m - 1.0))
    w[zero] = 0.0
    hit = zero.any(axis=1)
    if hit.any():  # a row on one or more centres: share among those centres
        w[hit] = zero[hit] / zero[hit].sum(axis=1, keepdims=True)
    # scale-free division: the largest weight is finite because d2 > 0 off the hit rows
    w /= w.sum(axis=1, keepdims=True)
    return w


def fuzzy_cmeans(X: ArrayLike, c: int, m: float = 2.0, *, init: str | ArrayLike | None = None,
                 max_iter: int = 300, tol: float = 1e-6, seed: int = 0) -> FuzzyResult:
    """Fuzzy c-means (Bezdek) of rows into c clusters.

    Iterates centres ``v_k = sum u^m x / sum u^m`` and memberships until the largest
    membership change is below tol or max_iter. Deterministic for a given seed.

    Parameters
    ----------
    X : array_like, shape (n, d)
        The rows, finite.
    c : int
        Clusters, 1 <= c <= n.
    m : float, optional
        Fuzzifier, > 1.
    init : None, "k-means++" or array_like, shape (c, d), optional
        None (memberships drawn from a seeded Dirichlet distribution), ``"k-means++"``
        (centres of :func:`mlayer.kmeans`) or initial centres.
    max_iter : int, optional
        Iterations at most.
    tol : float, optional
        Largest membership change to stop at.
    seed : int, optional
        Seed.

    Returns
    -------
    FuzzyResult
        Centres, memberships, labels, objective, iterations.

    Raises
    ------
    mlayer.InvalidArgumentError
        For parameters out of range.
    """
    c = integer(c, "c", 1)
    X = _data(X, c, "c")
    m = float(m)
    if not (math.isfinite(m) and m > 1.0):
        raise InvalidArgumentError(f"fuzzy_cmeans: m must be finite and > 1, got {m}")
    max_iter = integer(max_iter, "max_iter", 1)
    if not (math.isfinite(tol) and tol >= 0):
        raise InvalidArgumentError(f"fuzzy_cmeans: tol must be >= 0, got {tol}")
    if init is None:
        u = np.random.default_rng(integer(seed, "seed", 0)).dirichlet(np.ones(c), X.shape[0])
    else:
        V = _initial_centers(X, c, init, seed, "fuzzy_cmeans")
        u = _memberships(_sqdist(X, V), m)
    n_iter = 0
    for it in range(1, max_iter + 1):
        n_iter = it
        um = u ** m
        V = (um.T @ X) / um.sum(axis=0)[:, None]
        u_new = _memberships(_sqdist(X, V), m)
        delta = np.abs(u_new - u).max()
        u = u_new
        if delta < tol:
            break
    um = u ** m
    V = (um.T @ X) / um.sum(axis=0)[:, None]
    J = float((um * _sqdist(X, V)).sum())
    res = FuzzyResult(V, u, np.argmax(u, axis=1).astype(np.int32), J, n_iter)
    object.__setattr__(res, "_m", m)
    return res


# ---------------------------------------------------------------------------------------------
# Gaussian mixture

_LOG_2PI = math.log(2.0 * math.pi)


class GaussianMixture(_attrs.ReadOnlyAttributes):
    """Gaussian mixture of k components fitted by EM.

    After :meth:`fit`: ``weights_``, ``means_``, ``covariances_``, ``converged_``,
    ``n_iter_``, ``lower_bound_`` (mean log-likelihood of the training rows), read-only.
    The arguments are kept as attributes of the same names: ``max_iter``, ``tol``,
    ``reg_covar`` and ``seed`` can be assigned (checked as here: InvalidArgumentError for a
    value out of range), the others (whose shapes the fit depends on) are read-only.

    Parameters
    ----------
    k : int
        Components (>= 1).
    covariance : {"full", "diag"}, optional
        Covariances (k, d, d) or (k, d).
    init : "k-means++" or array_like, shape (k, d), optional
        ``"k-means++"`` (the centres of :func:`mlayer.kmeans`, seeded) or initial means.
    weights_init : array_like, shape (k,), optional
        Initial weights, non-negative, summing to 1.
    covariances_init : array_like, shape (k, d, d) or (k, d), optional
        Initial covariances. Missing initial weights and covariances come from the hard
        assignment of the rows to the nearest initial mean, as scikit-learn does.
    max_iter : int, optional
        EM iterations at most.
    tol : float, optional
        EM stops when the mean log-likelihood per row changes by less than tol.
    reg_covar : float, optional
        Added to the diagonal of every covariance (keeps them positive definite).
    seed : int, optional
        Seed of the k-means++ initialization.

    Raises
    ------
    mlayer.InvalidArgumentError
        For parameters out of range.
    """
    k: int
    max_iter: int
    tol: float
    reg_covar: float
    seed: int
    weights_: NDArray[np.float64]
    means_: NDArray[np.float64]
    covariances_: NDArray[np.float64]
    converged_: bool
    n_iter_: int

    _readonly = ("k", "covariance", "init", "weights_init", "covariances_init", "weights_",
                 "means_", "covariances_", "converged_", "n_iter_", "lower_bound_")
    _checked = {"max_iter": _attrs.integer(1), "tol": _attrs.number(0.0),
                "reg_covar": _attrs.number(0.0), "seed": _attrs.integer(0)}

    def __init__(self, k: int, covariance: str = "full", *,
                 init: str | ArrayLike = "k-means++", weights_init: ArrayLike | None = None,
                 covariances_init: ArrayLike | None = None, max_iter: int = 100,
                 tol: float = 1e-3, reg_covar: float = 1e-6, seed: int = 0) -> None:
        self.k = integer(k, "k", 1)
        if covariance not in ("full", "diag"):
            raise InvalidArgumentError(f"GaussianMixture: covariance must be 'full' or 'diag', "
                                       f"got {covariance!r}")
        self.covariance = covariance
        self.init = init
        self.weights_init = weights_init
        self.covariances_init = covariances_init
        self.max_iter = integer(max_iter, "max_iter", 1)
        if not (math.isfinite(tol) and tol >= 0):
            raise InvalidArgumentError(f"GaussianMixture: tol must be >= 0, got {tol}")
        if not (math.isfinite(reg_covar) and reg_covar >= 0):
            raise InvalidArgumentError(f"GaussianMixture: reg_covar must be >= 0, got "
                                       f"{reg_covar}")
        self.tol, self.reg_covar = float(tol), float(reg_covar)
        self.seed = integer(seed, "seed", 0)

    # -- EM pieces -----------------------------------------------------------------------------

    def _m_step(self, X: np.ndarray, resp: np.ndarray) -> None:
        nk = resp.sum(axis=0) + 10.0 * np.finfo(np.float64).eps
        self.weights_ = nk / nk.sum()
        self.means_ = (resp.T @ X) / nk[:, None]
        if self.covariance == "full":
            d = X.shape[1]
            cov = np.empty((self.k, d, d))
            for j in range(self.k):
                D = X - self.means_[j]
                cov[j] = (resp[:, j] * D.T) @ D / nk[j]
                cov[j].flat[::d + 1] += self.reg_covar
            self.covariances_ = cov
        else:
            avg_x2 = (resp.T @ (X * X)) / nk[:, None]
            self.covariances_ = avg_x2 - self.means_ ** 2 + self.reg_covar
        self._factor()

    def _factor(self) -> None:
        if self.covariance == "full":
            try:
                self._chol = np.linalg.cholesky(self.covariances_)
            except np.linalg.LinAlgError:
                raise InvalidArgumentError(
                    "GaussianMixture: a covariance is not positive definite (collapsed "
                    "component; increase reg_covar or reduce k)") from None
        else:
            if not (self.covariances_ > 0).all():
                raise InvalidArgumentError(
                    "GaussianMixture: a variance is not positive (increase reg_covar)")

    def _log_gauss(self, X: np.ndarray) -> np.ndarray:
        """log N(x | mu_j, Sigma_j), shape (n, k)."""
        n, d = X.shape
        out = np.empty((n, self.k))
        if self.covariance == "full":
            for j in range(self.k):
                L = self._chol[j]
                z = np.linalg.solve(L, (X - self.means_[j]).T)  # triangular: L z = x - mu
                out[:, j] = -0.5 * (d * _LOG_2PI + (z * z).sum(axis=0)) \
                    - np.log(np.diag(L)).sum()
        else:
            var = self.covariances_
            for j in range(self.k):
                D = X - self.means_[j]
                out[:, j] = -0.5 * (d * _LOG_2PI + np.log(var[j]).sum()
                                    + (D * D / var[j]).sum(axis=1))
        return out

    def _weighted(self, X: np.ndarray) -> np.ndarray:
        return self._log_gauss(X) + np.log(self.weights_)

    @staticmethod
    def _logsumexp(a: np.ndarray) -> np.ndarray:
        mx = a.max(axis=1, keepdims=True)
        return (mx + np.log(np.exp(a - mx).sum(axis=1, keepdims=True)))[:, 0]

    # -- public --------------------------------------------------------------------------------

    def _check_X(self, X: ArrayLike) -> NDArray[np.float64]:
        if not hasattr(self, "means_"):
            raise InvalidArgumentError("GaussianMixture: call fit first")
        X = _data(X, 1, "k")
        if X.shape[1] != self.means_.shape[1]:
            raise InvalidArgumentError(f"X: dimension mismatch, {X.shape[1]} columns for a "
                                       f"model of dimension {self.means_.shape[1]}")
        return X

    @_attrs.builds
    def fit(self, X: ArrayLike) -> GaussianMixture:
        """Fit the mixture to rows by EM.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows, finite, n >= k.

        Returns
        -------
        GaussianMixture
            ``self``.

        Raises
        ------
        mlayer.InvalidArgumentError
            For bad data or initial parameters.
        """
        X = _data(X, self.k, "k")
        n, d = X.shape
        means = _initial_centers(X, self.k, self.init, self.seed, "GaussianMixture")
        if self.weights_init is None or self.covariances_init is None:
            lab = np.argmin(_sqdist(X, means), axis=1)
            resp = np.zeros((n, self.k))
            resp[np.arange(n), lab] = 1.0
            self._m_step(X, resp)
        if self.weights_init is not None:
            w = _arrays.as_f64(self.weights_init, "weights_init", ndim=1)
            if w.shape != (self.k,) or not np.isfinite(w).all() or (w < 0).any() \
                    or abs(w.sum() - 1.0) > 1e-6:
                raise InvalidArgumentError(f"weights_init: need {self.k} non-negative weights "
                                           "summing to 1")
            self.weights_ = w.copy()
        if self.covariances_init is not None:
            shape = (self.k, d, d) if self.covariance == "full" else (self.k, d)
            cv = _arrays.as_f64(self.covariances_init, "covariances_init")
            if cv.shape != shape:
                raise InvalidArgumentError(f"covariances_init: expected shape {shape}, got "
                                           f"{cv.shape}")
            _arrays.require_finite(cv, "covariances_init")
            self.covariances_ = cv.copy()
        self.means_ = means
        self._factor()
        lower = -np.inf
        self.converged_ = False
        self.n_iter_ = 0
        for it in range(1, self.max_iter + 1):
            lw = self._weighted(X)
            lse = self._logsumexp(lw)
            ll = float(lse.mean())
            self._m_step(X, np.exp(lw - lse[:, None]))
            self.n_iter_ = it
            if abs(ll - lower) < self.tol:
                self.converged_ = True
                lower = ll
                break
            lower = ll
        self.lower_bound_ = lower
        return self

    def predict_proba(self, X: ArrayLike) -> NDArray[np.float64]:
        """Responsibilities of the components for rows.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        numpy.ndarray, shape (n, k)
            Rows sum to 1.
        """
        X = self._check_X(X)
        lw = self._weighted(X)
        return np.exp(lw - self._logsumexp(lw)[:, None])

    def predict(self, X: ArrayLike) -> NDArray[np.int32]:
        """Most responsible component of each row.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        numpy.ndarray of int32, shape (n,)
            The components.
        """
        X = self._check_X(X)
        return np.argmax(self._weighted(X), axis=1).astype(np.int32)

    def score_samples(self, X: ArrayLike) -> NDArray[np.float64]:
        """log p(x) of each row.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        numpy.ndarray, shape (n,)
            The log densities.
        """
        return self._logsumexp(self._weighted(self._check_X(X)))

    def score(self, X: ArrayLike) -> float:
        """Mean log-likelihood per row (scikit-learn's ``score``).

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        float
            The mean of :meth:`score_samples`.
        """
        return float(self.score_samples(X).mean())

    def log_likelihood(self, X: ArrayLike) -> float:
        """Total log-likelihood of rows.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        float
            The sum of :meth:`score_samples`.
        """
        return float(self.score_samples(X).sum())

    def bic(self, X: ArrayLike) -> float:
        """Bayesian information criterion (lower is better).

        Parameters
        ----------
        X : array_like, shape (n, d)
            The rows.

        Returns
        -------
        float
            ``-2 log L + p log n`` with p the free parameters.
        """
        X = self._check_X(X)
        d = X.shape[1]
        cov_p = self.k * d * (d + 1) / 2 if self.covariance == "full" else self.k * d
        p = cov_p + self.k * d + self.k - 1
        return -2.0 * self.log_likelihood(X) + p * math.log(X.shape[0])


# ---------------------------------------------------------------------------------------------
# how many clusters


@dataclass(frozen=True)
class KCriteria:
    """How many clusters, by three criteria side by side (see :func:`k_criteria`).

    Attributes
    ----------
    ks : numpy.ndarray
        The ks, increasing.
    inertia : numpy.ndarray
        k-means inertia per k.
    silhouette : numpy.ndarray
        Silhouette of the k-means labels per k (NaN where undefined).
    bic : numpy.ndarray
        BIC of a Gaussian mixture per k (NaN where it failed).
    picks : dict of str to int
        The k each criterion picks: ``{"elbow": k, "silhouette": k, "bic": k}``.
    results : tuple of KMeansResult
        The k-means results.
    """
    ks: NDArray[np.int64]
    inertia: NDArray[np.float64]
    silhouette: NDArray[np.float64]
    bic: NDArray[np.float64]
    picks: dict[str, int]
    results: tuple[KMeansResult, ...]


CRITERIA = ("elbow", "silhouette", "bic")


def k_criteria(X: ArrayLike, ks: Iterable[int], *, seed: int = 0, n_init: int = 3,
               reg_covar: float = 1e-6) -> KCriteria:
    """How many clusters: three criteria for every k.

    For every k: k-means (``n_init`` seeded runs), its inertia and the silhouette of its
    labels (:func:`mlayer.manifold.clustering.silhouette_score`; NaN for k = 1 or k >= n), and the
    BIC of a full-covariance :class:`GaussianMixture` started from the k-means centres
    (``reg_covar`` added to its covariances). Picks: the elbow of the inertia
    (:func:`mlayer.manifold.clustering.elbow_point`), the largest silhouette, the smallest BIC (the
    smaller k on ties).

    Parameters
    ----------
    X : array_like, shape (n, d)
        The rows.
    ks : iterable of int
        Distinct ks.
    seed : int, optional
        Seed of k-means and the mixtures.
    n_init : int, optional
        k-means++ runs per k.
    reg_covar : float, optional
        Added to the mixtures' covariances.

    Returns
    -------
    KCriteria
        The curves and the picks.
    """
    X = _data(X, 1, "k")
    ks = sorted(integer(k, "k", 1) for k in ks)
    if not ks:
        raise InvalidArgumentError("ks is empty")
    if len(set(ks)) != len(ks):
        raise InvalidArgumentError("ks has repeated values")
    n = X.shape[0]
    results = tuple(kmeans(X, k, seed=seed, n_init=n_init) for k in ks)
    inertia = np.array([r.inertia for r in results])
    sil = np.full(len(ks), np.nan)
    bic = np.full(len(ks), np.nan)
    for i, (k, r) in enumerate(zip(ks, results)):
        if 2 <= len(np.unique(r.labels)) <= n - 1:
            sil[i] = silhouette_score(X, r.labels)
        try:
            g = GaussianMixture(k, init=r.centers, reg_covar=reg_covar, seed=seed).fit(X)
            bic[i] = g.bic(X)
        except InvalidArgumentError:  # a collapsed component: no BIC for this k
            pass
    picks = {"elbow": elbow_point(ks, inertia)[0]}
    for name, v, sign in (("silhouette", sil, -1.0), ("bic", bic, 1.0)):
        ok = np.isfinite(v)
        picks[name] = int(np.array(ks)[ok][np.argmin(sign * v[ok])]) if ok.any() else ks[0]
    return KCriteria(np.array(ks), inertia, sil, bic, picks, results)
