"""GRBF speed: mlayer.GRBF fit plus evaluation against scipy's RBFInterpolator in the same run.

The case of the issue: 2,000 centres (a 40 x 50 lattice on the manifold box), 93 outputs (pose
features of a 31-joint skeleton), evaluation at 10,000 points. Both fit the same data, the
93 values at the 2,000 lattice points (scipy's centres are its data points, so this is the
square, interpolating system for both, thin plate spline with linear terms), then evaluate at
the same 10,000 random manifold points. The outputs are compared too. Also timed for
information: the least-squares fit the primitives model uses (10,000 training points onto the
2,000 centres), which scipy has no counterpart for. Reports medians and the ratio.

    python bench/python/bench_grbf.py [--centres 40x50] [--outputs 93] [--points 10000]
        [--repeat 5]
"""
from __future__ import annotations

import argparse

import numpy as np
from benchutil import median_seconds
from scipy.interpolate import RBFInterpolator

import mlayer
from mlayer.manifold import lattice_points


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--centres", default="40x50")
    ap.add_argument("--outputs", type=int, default=93)
    ap.add_argument("--points", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
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

    def ours():
        return mlayer.GRBF("thin_plate", (rows, cols), bounds=bounds).fit(C, Y).predict(Q)

    def theirs():
        return RBFInterpolator(C, Y, kernel="thin_plate_spline", degree=1)(Q)

    ours()  # warm-up (imports, BLAS threads)
    t_ours = median_seconds(ours, args.repeat)
    t_scipy = median_seconds(theirs, args.repeat)
    a, b = ours(), theirs()
    diff = float(np.abs(a - b).max() / np.abs(b).max())
    print(f"GRBF fit + evaluation: {C.shape[0]} centres, {args.outputs} outputs, "
          f"{args.points} points (median of {args.repeat})")
    print(f"  mlayer.GRBF           {t_ours * 1e3:9.1f} ms")
    print(f"  scipy RBFInterpolator {t_scipy * 1e3:9.1f} ms")
    print(f"  ratio scipy / mlayer  {t_scipy / t_ours:9.2f}x   (max relative difference "
          f"{diff:.1e})")
    P = rng.uniform(0, 64, size=(args.points, 2))
    YP = values(P)
    t_ls = median_seconds(
        lambda: mlayer.GRBF("thin_plate", (rows, cols), bounds=bounds).fit(P, YP).predict(Q),
        max(1, args.repeat // 2))
    print(f"  least squares, {args.points} training points onto the {C.shape[0]} centres, "
          f"+ evaluation: {t_ls * 1e3:.1f} ms (mlayer only)")


if __name__ == "__main__":
    main()
