"""GRBF speed: mlayer.GRBF fit plus evaluation against scipy's RBFInterpolator in the same run.

The case of the issue: 2,000 centres (a 40 x 50 lattice on the manifold box), 93 outputs (pose
features of a 31-joint skeleton), evaluation at 10,000 points. Both fit the same data, the
93 values at the 2,000 lattice points (scipy's centres are its data points, so this is the
square, interpolating system for both: thin plate spline r^2 log r with linear terms, no
smoothing), then evaluate at the same 10,000 random manifold points. The outputs are compared
too. Timed in turns (mlayer, scipy, mlayer, ...: a load change on the shared machine hits both),
medians of --repeat, BLAS threads fixed to --threads for both (mlayer's kernel evaluation uses as
many; scipy's is single-threaded Pythran).

Rows:
  mlayer.GRBF (lattice)   GRBF("thin_plate", (40, 50)): the lattice fit splits the system by the
                          lattice's reflection symmetry (four systems of N/4);
  mlayer.GRBF (centers=)  the same centres passed as an explicit array: LU of the whole bordered
                          system, as scipy does (for information: the general path);
  scipy RBFInterpolator.
Also timed for information: the least-squares fit the primitives model uses (10,000 training
points onto the 2,000 centres, QR), which scipy has no counterpart for.

    python bench/python/bench_grbf.py [--centres 40x50] [--outputs 93] [--points 10000]
        [--repeat 5] [--threads 2]
"""
from __future__ import annotations

import argparse
import os
import time


def parse():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--centres", default="40x50")
    ap.add_argument("--outputs", type=int, default=93)
    ap.add_argument("--points", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    return ap.parse_args()


ARGS = parse()
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = str(ARGS.threads)

import numpy as np  # noqa: E402
from scipy.interpolate import RBFInterpolator  # noqa: E402

import mlayer  # noqa: E402
from mlayer.manifold.manifold import lattice_points  # noqa: E402


def main() -> None:
    args = ARGS
    rows, cols = (int(v) for v in args.centres.split("x"))
    rng = np.random.default_rng(0)
    bounds = ((0.0, 64.0), (0.0, 64.0))  # a 65 x 65 SOM lattice, as in the paper
    C = lattice_points((rows, cols), bounds)
    # smooth pose-like outputs: random mixtures of low-frequency waves over the manifold
    f = rng.normal(scale=0.08, size=(2, args.outputs))
    ph = rng.uniform(0, 2 * np.pi, size=args.outputs)
    amp = rng.uniform(1, 20, size=args.outputs)
    values = lambda P: amp * np.sin(P @ f + ph)  # noqa: E731
    Y = values(C)
    Q = rng.uniform(0, 64, size=(args.points, 2))
    nt = args.threads

    cases = {
        "mlayer.GRBF (lattice)": lambda: mlayer.GRBF(
            "thin_plate", (rows, cols), bounds=bounds, n_threads=nt).fit(C, Y).predict(Q),
        "mlayer.GRBF (centers=)": lambda: mlayer.GRBF(
            "thin_plate", centers=C, n_threads=nt).fit(C, Y).predict(Q),
        "scipy RBFInterpolator": lambda: RBFInterpolator(
            C, Y, kernel="thin_plate_spline", degree=1)(Q),
    }
    out = {k: fn() for k, fn in cases.items()}  # warm-up (imports, BLAS threads)
    times = {k: [] for k in cases}
    for _ in range(args.repeat):
        for k, fn in cases.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    med = {k: float(np.median(v)) for k, v in times.items()}
    ref = out["scipy RBFInterpolator"]
    print(f"GRBF fit + evaluation: {C.shape[0]} centres, {args.outputs} outputs, "
          f"{args.points} points, BLAS threads {nt} (median of {args.repeat}, in turns)")
    for k in cases:
        diff = float(np.abs(out[k] - ref).max() / np.abs(ref).max())
        extra = "" if k.startswith("scipy") else \
            f"   ratio scipy / this {med['scipy RBFInterpolator'] / med[k]:5.2f}x   " \
            f"(max relative difference {diff:.1e})"
        print(f"  {k:24s} {med[k] * 1e3:8.1f} ms{extra}")
    P = rng.uniform(0, 64, size=(args.points, 2))
    YP = values(P)
    t0 = time.perf_counter()
    mlayer.GRBF("thin_plate", (rows, cols), bounds=bounds, n_threads=nt).fit(P, YP).predict(Q)
    t_ls = time.perf_counter() - t0
    print(f"  least squares, {args.points} training points onto the {C.shape[0]} centres, "
          f"+ evaluation: {t_ls * 1e3:.1f} ms (mlayer only, one run)")


if __name__ == "__main__":
    main()
