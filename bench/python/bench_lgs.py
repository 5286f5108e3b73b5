"""LGS speed: mlayer.lgs against scipy.linalg.solveh_banded (LAPACK pbsv) and CHOLMOD through
scikit-sparse, on the same pentadiagonal smoothing problem in one run, with the memory floor
(a copy of the data) alongside. Reports medians and ratios.

    python bench/python/bench_lgs.py [--sizes 2526x96,100000x127,500000x127] [--repeat 7]

scikit-sparse is optional (pip install scikit-sparse==0.4.16 builds against SuiteSparse 5.12).
"""
from __future__ import annotations

import argparse
import os

import numpy as np
import scipy.linalg
import scipy.sparse

import mlayer
from benchutil import median_seconds

try:
    from sksparse.cholmod import cholesky as sk_cholesky
except ImportError:  # optional peer
    sk_cholesky = None


def system_bands(n, s):
    """Lower band storage (LAPACK, 3 x n) of s L^T L + I, L the second difference."""
    L = scipy.sparse.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(n - 2, n))
    M = (s * (L.T @ L) + scipy.sparse.identity(n)).tocsc()
    ab = np.zeros((3, n))
    for d in range(3):
        ab[d, : n - d] = M.diagonal(-d)
    return M, ab


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2526x96,100000x127,500000x127")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--lam", type=float, default=4.0)
    a = ap.parse_args()
    s = a.lam ** 2
    rng = np.random.default_rng(0)
    print(f"{'n x m':>14} {'copy ms':>9} {'mlayer ms':>10} {'pbsv ms':>9} {'cholmod ms':>11}"
          f" {'mlayer/copy':>12} {'pbsv/mlayer':>12} {'cholmod/mlayer':>15}"
          f" {'copyto ms':>10} {'mlayer out= ms':>15} {'1-thread ms':>12} {'pbsv/1-thread':>14}")
    for spec in a.sizes.split(","):
        n, m = (int(v) for v in spec.split("x"))
        y = np.cumsum(rng.normal(size=(n, m)), axis=0)
        M, ab = system_bands(n, s)
        x_ml = mlayer.lgs(y, a.lam, 1.0)
        x_pb = scipy.linalg.solveh_banded(ab, y, lower=True)
        err = np.abs(x_ml - x_pb).max() / np.abs(x_pb).max()
        assert err < 1e-10, f"mlayer and pbsv disagree: {err:g}"
        t_copy = median_seconds(lambda: y.copy(), a.repeat)
        t_ml = median_seconds(lambda: mlayer.lgs(y, a.lam, 1.0), a.repeat)
        t_ml1 = median_seconds(lambda: mlayer.lgs(y, a.lam, 1.0, threads=1), a.repeat)
        t_pb = median_seconds(lambda: scipy.linalg.solveh_banded(ab, y, lower=True), a.repeat)
        t_ch = float("nan")
        if sk_cholesky is not None:
            def chol():
                return sk_cholesky(M)(y)
            x_ch = chol()
            assert np.abs(x_ch - x_pb).max() / np.abs(x_pb).max() < 1e-10
            t_ch = median_seconds(chol, a.repeat)
        # the same two into an existing array: without the kernel's first-touch page zeroing
        out = np.empty_like(y)
        t_copyto = median_seconds(lambda: np.copyto(out, y), a.repeat)
        g = mlayer.LGS(n, a.lam, 1.0)
        t_ml_out = median_seconds(lambda: g.solve(y, out=out), a.repeat)
        g.close()
        print(f"{spec:>14} {t_copy*1e3:9.2f} {t_ml*1e3:10.2f} {t_pb*1e3:9.1f} {t_ch*1e3:11.1f}"
              f" {t_ml/t_copy:12.2f} {t_pb/t_ml:12.1f} {t_ch/t_ml:15.1f}"
              f" {t_copyto*1e3:10.2f} {t_ml_out*1e3:15.2f} {t_ml1*1e3:12.2f}"
              f" {t_pb/t_ml1:14.1f}")
    print("mlayer, pbsv and cholmod each include building/factoring the system; the copy "
          "is y.copy() (the memory floor). Medians of", a.repeat, "runs.\n"
          "copyto and 'mlayer out=' write into an existing array (np.copyto, LGS.solve(y, out=)),"
          " without the page faults of a new one (the factor is built once there).\n"
          "mlayer.lgs by default lets a second thread map the pages of a result of 8 MiB or "
          "more while it solves; '1-thread' is threads=1. Processors:", os.cpu_count())


if __name__ == "__main__":
    main()
