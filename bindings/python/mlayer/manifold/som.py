"""Self-organizing map (Kohonen) on a rows x cols lattice, C core (paper 2, section 3).

Batch and online training with exponentially decaying radius sigma and learning rate alpha
(schedules in ``include/mlayer/mlr_som.h``), Gaussian neighbourhood, seeded and bit-identical
across runs and thread counts.
"""
from __future__ import annotations

import os
from typing import Any, Literal, SupportsIndex, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays
from .._files import atomic_output
from .._handles import NativeHandle, ReadOnlyAttributes
from .._native import ffi, lib
from ..errors import InvalidArgumentError, check
from .._args import default_threads, integer

_MODES = {"batch": lib.MLR_SOM_BATCH, "online": lib.MLR_SOM_ONLINE}


class SOM(ReadOnlyAttributes, NativeHandle):
    """A rows x cols map of dim-dimensional codebook vectors.

    ``rows``, ``cols``, ``dim`` and ``n_threads`` are read-only attributes. ``copy.copy``,
    ``copy.deepcopy`` and pickling make an independent map (its own C handle, through
    :meth:`to_bytes`: the same codebook and options). ``close()`` frees the map now; a closed
    map raises InvalidArgumentError.

    Parameters
    ----------
    rows, cols, dim : int
        The lattice and the dimension of the codebook vectors.
    seed : int, optional
        Seed of the initialization from the data.
    sigma0, sigma1 : float, optional
        Neighbourhood radius at the start/end of a training call (lattice units; default
        max(rows, cols)/2 and 1).
    alpha0, alpha1 : float, optional
        Learning rate of online training at the start/end (0.5, 0.01).
    cutoff : float, optional
        Online training leaves a unit alone when its Gaussian factor is below it (1e-3; 0
        updates every unit, as MiniSom does).
    n_threads : int, optional
        Default :func:`mlayer.manifold.clustering.default_threads`; results do not depend on it.

    Raises
    ------
    mlayer.InvalidArgumentError
        For sizes or options out of range.
    """
    rows: int
    cols: int
    dim: int
    n_threads: int

    _readonly = ("rows", "cols", "dim", "n_threads", "_options")

    def __init__(self, rows: int, cols: int, dim: int, *, seed: int = 0,
                 sigma0: float | None = None, sigma1: float = 1.0, alpha0: float = 0.5,
                 alpha1: float = 0.01, cutoff: float = 1e-3, n_threads: int | None = None,
                 _handle: Any = None) -> None:
        rows, cols, dim = (integer(v, nm, 0) for v, nm in ((rows, "rows"), (cols, "cols"),
                                                            (dim, "dim")))
        diag = ffi.new("mlr_diag *")
        if _handle is None:
            out = ffi.new("mlr_som **")
            check(lib.mlr_som_create(int(rows), int(cols), int(dim), ffi.NULL, out, diag),
                  "mlayer.SOM", diag)
            _handle = out[0]
        self._h = ffi.gc(_handle, lib.mlr_som_destroy)
        self.rows, self.cols, self.dim = int(rows), int(cols), int(dim)
        self.n_threads = default_threads() if n_threads is None else integer(n_threads,
                                                                             "n_threads", 1)
        self._options = dict(seed=seed, sigma0=sigma0, sigma1=sigma1, alpha0=alpha0,
                             alpha1=alpha1, cutoff=cutoff, n_threads=self.n_threads)
        opts = [(lib.MLR_SOM_SEED, integer(seed, "seed", 0)),
                (lib.MLR_SOM_N_THREADS, self.n_threads),
                (lib.MLR_SOM_SIGMA1, sigma1), (lib.MLR_SOM_ALPHA0, alpha0),
                (lib.MLR_SOM_ALPHA1, alpha1), (lib.MLR_SOM_CUTOFF, cutoff)]
        if sigma0 is not None:
            opts.append((lib.MLR_SOM_SIGMA0, sigma0))
        for key, v in opts:
            check(lib.mlr_som_set(self._h, key, float(v), diag), "mlayer.SOM", diag)

    def _clone(self) -> SOM:
        return _som_from_blob(self.to_bytes(), self._options)

    def __reduce_ex__(self, protocol: SupportsIndex) -> tuple[Any, ...]:
        return (_som_from_blob, (self.to_bytes(), self._options))

    def _data(self, X: ArrayLike) -> NDArray[np.float64]:
        X = _arrays.as_f64(X, "X", ndim=2)
        if X.shape[0] == 0:
            raise InvalidArgumentError("X: empty data, no rows")
        if X.shape[1] != self.dim:
            raise InvalidArgumentError(
                f"X: dimension mismatch, {X.shape[1]} columns for a map of dimension {self.dim}")
        return X

    def train(self, X: ArrayLike, epochs: int, mode: str = "batch") -> SOM:
        """Train on the rows of X.

        An untrained map starts from rows of X drawn by the seed.

        Parameters
        ----------
        X : array_like, shape (n, dim)
            The data.
        epochs : int
            Passes over the data (>= 1).
        mode : {"batch", "online"}, optional
            The training rule.

        Returns
        -------
        SOM
            ``self``.
        """
        X = self._data(X)
        if mode not in _MODES:
            raise InvalidArgumentError(f"mode must be 'batch' or 'online', got {mode!r}")
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_som_train(self._live(), _arrays.ptr(X), X.shape[0], self.dim,
                                integer(epochs, "epochs", 1), _MODES[mode], diag),
              "mlayer.SOM.train", diag)
        return self

    @property
    def codebook(self) -> NDArray[np.float64]:
        """Copy of the codebook, shape (rows, cols, dim); assignable."""
        n = self.rows * self.cols * self.dim
        return np.frombuffer(ffi.buffer(lib.mlr_som_codebook(self._live()), n * 8),
                             dtype=np.float64).reshape(self.rows, self.cols, self.dim).copy()

    @codebook.setter
    def codebook(self, w: ArrayLike) -> None:
        w = _arrays.as_f64(w, "codebook", ndim=3)
        if w.shape != (self.rows, self.cols, self.dim):
            raise InvalidArgumentError(
                f"codebook: expected shape {(self.rows, self.cols, self.dim)}, got {w.shape}")
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_som_set_codebook(self._live(), _arrays.ptr(w), self.dim, diag),
              "mlayer.SOM.codebook", diag)

    @overload
    def bmu_index(self, X: ArrayLike, *, second: Literal[False] = False) -> NDArray[np.int32]: ...
    @overload
    def bmu_index(self, X: ArrayLike, *, second: Literal[True]
                  ) -> tuple[NDArray[np.int32], NDArray[np.int32]]: ...
    def bmu_index(self, X: ArrayLike, *, second: bool = False
                  ) -> NDArray[np.int32] | tuple[NDArray[np.int32], NDArray[np.int32]]:
        """Unit index (r * cols + c) of each row's best-matching unit.

        Parameters
        ----------
        X : array_like, shape (n, dim)
            The rows.
        second : bool, optional
            Also return the second-best units.

        Returns
        -------
        numpy.ndarray of int32, shape (n,), or a pair of them
            The best units (and the second-best ones with ``second``).
        """
        X = self._data(X)
        n = X.shape[0]
        b = np.empty(n, dtype=np.int32)
        s = np.empty(n, dtype=np.int32) if second else None
        diag = ffi.new("mlr_diag *")
        i32 = lambda a: ffi.cast("int32_t *", ffi.from_buffer(a, require_writable=True))  # noqa: E731
        check(lib.mlr_som_bmu(self._live(), _arrays.ptr(X), n, self.dim, i32(b), ffi.NULL,
                              i32(s) if second else ffi.NULL, diag), "mlayer.SOM.bmu", diag)
        return (b, s) if s is not None else b

    def bmu(self, X: ArrayLike) -> NDArray[np.int64]:
        """Best-matching unit of each row on the lattice.

        Parameters
        ----------
        X : array_like, shape (n, dim)
            The rows.

        Returns
        -------
        numpy.ndarray, shape (n, 2)
            (lattice row, column).
        """
        u = self.bmu_index(X).astype(np.int64)
        return np.stack([u // self.cols, u % self.cols], axis=1)

    def _errors(self, X: ArrayLike) -> tuple[float, float]:
        X = self._data(X)
        qe = ffi.new("double *")
        te = ffi.new("double *")
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_som_errors(self._live(), _arrays.ptr(X), X.shape[0], self.dim, qe, te,
                                 diag), "mlayer.SOM", diag)
        return float(qe[0]), float(te[0])

    def quantization_error(self, X: ArrayLike) -> float:
        """Mean Euclidean distance of the rows of X to their BMU's codebook vector.

        Parameters
        ----------
        X : array_like, shape (n, dim)
            The rows.

        Returns
        -------
        float
            The error.
        """
        return self._errors(X)[0]

    def topographic_error(self, X: ArrayLike) -> float:
        """Fraction of rows whose best and second-best units are not lattice neighbours.

        Neighbours: the 8-neighbourhood.

        Parameters
        ----------
        X : array_like, shape (n, dim)
            The rows.

        Returns
        -------
        float
            In [0, 1].
        """
        return self._errors(X)[1]

    def to_bytes(self) -> bytes:
        """The codebook as a checked blob.

        Returns
        -------
        bytes
            Tag, version, size, hash and the codebook.
        """
        h = self._live()
        size = lib.mlr_som_export_size(h)
        buf = ffi.new("char[]", size)
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_som_export(h, buf, size, diag), "mlayer.SOM.to_bytes", diag)
        return bytes(ffi.buffer(buf, size))

    @classmethod
    def from_bytes(cls, blob: bytes, *, seed: int = 0, n_threads: int | None = None) -> SOM:
        """A map from :meth:`to_bytes` output.

        Parameters
        ----------
        blob : bytes
            The blob.
        seed, n_threads : int, optional
            As for :class:`SOM`.

        Returns
        -------
        SOM
            The map.

        Raises
        ------
        mlayer.ParseError
            For a corrupt blob.
        """
        blob = bytes(blob)
        out = ffi.new("mlr_som **")
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_som_import(blob, len(blob), ffi.NULL, out, diag), "mlayer.SOM.from_bytes",
              diag)
        return _som_from_blob(blob, dict(seed=seed, n_threads=n_threads), out[0])

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the codebook blob to a file (a temporary file renamed into place).

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        """
        blob = self.to_bytes()
        with atomic_output(path) as tmp, open(tmp, "wb") as f:
            f.write(blob)

    @classmethod
    def load(cls, path: str | os.PathLike[str], **kwargs: Any) -> SOM:
        """Read a map written by :meth:`save`.

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        **kwargs
            ``seed``, ``n_threads``, as for :meth:`from_bytes`.

        Returns
        -------
        SOM
            The map.
        """
        with open(os.fspath(path), "rb") as f:
            return cls.from_bytes(f.read(), **kwargs)

    def __repr__(self) -> str:
        return f"SOM({self.rows}, {self.cols}, {self.dim})"


def _som_from_blob(blob: bytes, options: dict[str, Any], handle: Any = None) -> SOM:
    """A map from an export blob (or the handle imported from it) and the constructor's
    options: from_bytes, copies, unpickling."""
    if handle is None:
        out = ffi.new("mlr_som **")
        diag = ffi.new("mlr_diag *")
        check(lib.mlr_som_import(bytes(blob), len(blob), ffi.NULL, out, diag), "mlayer.SOM",
              diag)
        handle = out[0]
    rows, cols = lib.mlr_som_rows(handle), lib.mlr_som_cols(handle)
    return SOM(rows, cols, lib.mlr_som_dim(handle), _handle=handle, **options)


__all__ = ["SOM", "u_matrix"]


def u_matrix(codebook: ArrayLike) -> NDArray[np.float64]:
    """The U-matrix of a SOM codebook.

    Parameters
    ----------
    codebook : array_like, shape (rows, cols, dim)
        The codebook (:attr:`SOM.codebook`).

    Returns
    -------
    numpy.ndarray, shape (rows, cols)
        The mean distance of each unit's codebook vector to those of its 4 lattice neighbours.
    """
    w = np.asarray(codebook, dtype=np.float64)
    rows, cols = w.shape[:2]
    u = np.zeros((rows, cols))
    cnt = np.zeros((rows, cols))
    for axis in (0, 1):
        d = np.linalg.norm(np.diff(w, axis=axis), axis=-1)
        lo = (slice(None, -1), slice(None)) if axis == 0 else (slice(None), slice(None, -1))
        hi = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
        for s in (lo, hi):
            u[s] += d
            cnt[s] += 1
    return u / np.maximum(cnt, 1)
