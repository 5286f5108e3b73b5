"""TEST-ONLY stand-ins for mlayer.kmeans, mlayer.som and mlayer.features while the C k-means and
SOM (branch cluster-c) are not merged: same documented interface, built on scikit-learn and
numpy. :func:`install` registers them only when the real modules are missing, so once they
land this file is unused (and should be deleted)."""
from __future__ import annotations

import sys
import types
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class KMeansResult:
    centers: np.ndarray
    labels: np.ndarray
    inertia: float
    n_iter: int


def kmeans(X, k, *, init="k-means++", n_init=1, max_iter=300, tol=1e-4, seed=0, **_):
    from sklearn.cluster import KMeans
    from mlayer.errors import InvalidArgumentError
    X = np.asarray(X, dtype=np.float64)
    if k > X.shape[0]:
        raise InvalidArgumentError(f"k = {k} exceeds the number of rows n = {X.shape[0]}")
    km = KMeans(k, init=init, n_init=n_init if isinstance(init, str) else 1,
                max_iter=max_iter, tol=tol, random_state=seed, algorithm="lloyd").fit(X)
    return KMeansResult(km.cluster_centers_, km.labels_.astype(np.int32), float(km.inertia_),
                        int(km.n_iter_))


@dataclass(frozen=True)
class ElbowResult:
    k: int
    ks: np.ndarray
    inertia: np.ndarray
    score: np.ndarray
    results: tuple

    def plot(self, ax=None):
        import matplotlib.pyplot as plt
        if ax is None:
            ax = plt.figure(figsize=(5, 3.5)).add_subplot()
        ax.plot(self.ks, self.inertia, "o-")
        return ax


def elbow(X, ks, **kw):
    ks = sorted(ks)
    res = tuple(kmeans(X, k, **kw) for k in ks)
    y = np.array([r.inertia for r in res])
    xs = np.asarray(ks, dtype=np.float64)
    if len(ks) < 3 or y.max() == y.min():
        return ElbowResult(ks[0], np.array(ks), y, np.zeros(len(ks)), res)
    score = (1 - (xs - xs[0]) / (xs[-1] - xs[0])) - (y - y.min()) / (y.max() - y.min())
    return ElbowResult(int(ks[int(np.argmax(score))]), np.array(ks), y, score, res)


class SOM:
    """Batch SOM with a Gaussian neighbourhood, radius decaying from max(rows, cols)/2 to 1."""

    def __init__(self, rows, cols, dim, *, seed=0, **_):
        self.rows, self.cols, self.dim, self.seed = rows, cols, dim, seed
        self._w = None
        g = np.indices((rows, cols)).reshape(2, -1).T.astype(np.float64)
        self._grid = g

    def train(self, X, epochs, mode="batch"):
        X = np.asarray(X, dtype=np.float64)
        rng = np.random.default_rng(self.seed)
        if self._w is None:
            self._w = X[rng.integers(X.shape[0], size=self.rows * self.cols)].copy()
        s0, s1 = max(self.rows, self.cols) / 2.0, 1.0
        g2 = ((self._grid[:, None, :] - self._grid[None, :, :]) ** 2).sum(-1)
        for e in range(epochs):
            s = s0 * (s1 / s0) ** (e / max(epochs - 1, 1))
            b = self.bmu_index(X)
            H = np.exp(-g2[:, b] / (2 * s * s))  # (units, n)
            self._w = (H @ X) / H.sum(1, keepdims=True)
        return self

    @property
    def codebook(self):
        return self._w.reshape(self.rows, self.cols, self.dim).copy()

    @codebook.setter
    def codebook(self, w):
        self._w = np.asarray(w, dtype=np.float64).reshape(-1, self.dim).copy()

    def bmu_index(self, X):
        X = np.asarray(X, dtype=np.float64)
        d = (X * X).sum(1)[:, None] - 2 * X @ self._w.T + (self._w ** 2).sum(1)[None]
        return np.argmin(d, axis=1).astype(np.int32)

    def bmu(self, X):
        u = self.bmu_index(X).astype(np.int64)
        return np.stack([u // self.cols, u % self.cols], axis=1)

    def quantization_error(self, X):
        X = np.asarray(X, dtype=np.float64)
        return float(np.linalg.norm(X - self._w[self.bmu_index(X)], axis=1).mean())

    def topographic_error(self, X):
        return 0.0


def heading(rot_root):
    q = np.asarray(rot_root, dtype=np.float64)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.arctan2(2.0 * (x * z + w * y), 1.0 - 2.0 * (x * x + y * y))


def pose_features(motion):
    clips = list(motion) if isinstance(motion, (list, tuple)) else [motion]
    out = []
    for m in clips:
        pos, wrot = m.forward_kinematics()
        rel = pos - pos[:, :1, :]
        yaw = heading(wrot[:, 0])
        c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        o = np.empty_like(rel)
        o[..., 0] = c * rel[..., 0] - s * rel[..., 2]
        o[..., 1] = rel[..., 1]
        o[..., 2] = s * rel[..., 0] + c * rel[..., 2]
        out.append(o.reshape(m.n_frames, -1))
    return np.concatenate(out, axis=0)


def install() -> list[str]:
    """Register the stand-ins for the modules that are missing; returns their names."""
    import importlib
    import mlayer
    made = []
    for name, attrs in (("kmeans", dict(kmeans=kmeans, elbow=elbow, KMeansResult=KMeansResult,
                                        ElbowResult=ElbowResult)),
                        ("som", dict(SOM=SOM)),
                        ("features", dict(pose_features=pose_features, heading=heading))):
        try:
            importlib.import_module(f"mlayer.{name}")
        except ModuleNotFoundError:
            mod = types.ModuleType(f"mlayer.{name}")
            mod.__dict__.update(attrs)
            sys.modules[f"mlayer.{name}"] = mod
            setattr(mlayer, name, mod)
            made.append(name)
    return made
