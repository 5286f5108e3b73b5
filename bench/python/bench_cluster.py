"""Clustering speed: mlayer.kmeans against scikit-learn's Lloyd, mlayer.SOM against somoclu and
MiniSom, in one run, same machine, same thread count. Reports medians and ratios (peer time /
mlayer time, > 1 means mlayer is faster).

    python bench/python/bench_cluster.py [--threads 2] [--repeat 3] [--only kmeans|som] [--whole]

k-means: n = 200,000 rows, k = 64, 20 Lloyd iterations (tol = 0) from the same initial centres
(k-means++ of mlayer), time per iteration = wall time of the fit / n_iter, on
  - mocap-like data: pose features (mlayer.pose_features) of the real clips in
    ../shared/data/mocap, one case per CMU skeleton found (31 joints: d = 93; 43 joints:
    d = 129), tiled to 200,000 rows, plus Gaussian jitter of 1% of each column's standard
    deviation (near-duplicate rows, as 120 fps captures have);
  - random normal data, d = 96 (the worst case: no structure for the bounds to exploit).
The repeats are interleaved (mlayer, mlayer Lloyd, scikit-learn, then again), so that load from
other processes falls on all three alike; the ratio of each repeat is printed beside the ratio
of the medians. --whole also times whole fits with the defaults (k-means++ seeding included,
one init, tol 1e-4; each library seeded its own way) and the seeding alone.
SOM: 65 x 65 lattice on 10,000 x 93 pose features (tiled with the same jitter), batch training,
time per epoch; somoclu
(batch, Gaussian, planar, rectangular; `pip install --no-build-isolation somoclu`, optional)
with the same thread count (OMP_NUM_THREADS); MiniSom (online, one row per step, pure NumPy)
timed over 1,000 steps and scaled to one epoch of 10,000 rows, compared with mlayer's online
epoch (median of --repeat single-epoch runs; each step split over the threads) and batch epoch.
"""
from __future__ import annotations

import argparse
import glob
import os
import sys
import time

import numpy as np


def parse():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=["kmeans", "som"], default=None)
    ap.add_argument("--whole", action="store_true",
                    help="also time whole k-means fits with the defaults, seeding included")
    ap.add_argument("--mocap", default=os.path.join(os.path.dirname(__file__), "..", "..", "..",
                                                     "shared", "data", "mocap"))
    return ap.parse_args()


ARGS = parse()
# thread counts of the peers must be fixed before they load OpenMP / BLAS
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = str(ARGS.threads)

import mlayer  # noqa: E402


def median_of(fn, repeat):
    out = []
    for _ in range(repeat):
        out.append(fn())
    return float(np.median(out))


def features_by_width(mocap_dir):
    """Pose features of the clips, stacked per feature width (one skeleton each)."""
    by_shape = {}
    for path in sorted(glob.glob(os.path.join(mocap_dir, "*.bvh"))):
        try:
            m = mlayer.read_bvh(path)
        except mlayer.Error:
            continue
        f = mlayer.pose_features(m)
        by_shape.setdefault(f.shape[1], []).append(f)
    return {d: np.concatenate(fs) for d, fs in by_shape.items()}


def tiled(F, n, seed=0):
    rng = np.random.default_rng(seed)
    X = np.resize(F, (n, F.shape[1]))  # repeats the rows in order
    X = X + rng.normal(size=X.shape) * (0.01 * F.std(axis=0))
    return np.ascontiguousarray(X)


def bench_kmeans(name, X, k=64, iters=20):
    from sklearn.cluster import KMeans
    init = mlayer.kmeans(X[::10], k, seed=1, max_iter=1, n_threads=ARGS.threads).centers

    def ours():
        t0 = time.perf_counter()
        r = mlayer.kmeans(X, k, init=init, max_iter=iters, tol=0.0, n_threads=ARGS.threads)
        return (time.perf_counter() - t0) / r.n_iter, r

    def ours_lloyd():
        t0 = time.perf_counter()
        r = mlayer.kmeans(X, k, init=init, max_iter=iters, tol=0.0, n_threads=ARGS.threads,
                          algorithm="lloyd")
        return (time.perf_counter() - t0) / r.n_iter, r

    def sk():
        t0 = time.perf_counter()
        km = KMeans(k, init=init, n_init=1, max_iter=iters, tol=0.0, algorithm="lloyd").fit(X)
        return (time.perf_counter() - t0) / km.n_iter_, km

    runs = (("mlayer", ours), ("mlayer-lloyd", ours_lloyd), ("sklearn", sk))
    ts = {label: [] for label, _ in runs}
    last = {}
    for _ in range(ARGS.repeat):  # interleaved: load from other processes hits all three
        for label, fn in runs:
            t, last[label] = fn()
            ts[label].append(t)
    res = {label: (float(np.median(ts[label])), last[label]) for label, _ in runs}
    r, km = res["mlayer"][1], res["sklearn"][1]
    same = bool(np.array_equal(r.labels, km.labels_))
    rel = abs(r.inertia - km.inertia_) / km.inertia_
    skipped = r.n_skipped / (len(X) * r.n_iter)
    print(f"kmeans {name}: n={len(X)} d={X.shape[1]} k={k}  iterations mlayer {r.n_iter} "
          f"sklearn {km.n_iter_}  labels equal {same}  inertia rel diff {rel:.1e}  "
          f"rows skipped by bounds {100 * skipped:.0f}%")
    for label in ("mlayer", "mlayer-lloyd", "sklearn"):
        print(f"  {label:13s} {1e3 * res[label][0]:8.2f} ms/iteration")
    each = ", ".join(f"{a / b:.2f}" for a, b in zip(ts["sklearn"], ts["mlayer"]))
    print(f"  ratio sklearn/mlayer {res['sklearn'][0] / res['mlayer'][0]:.2f}x "
          f"(plain Lloyd {res['sklearn'][0] / res['mlayer-lloyd'][0]:.2f}x); "
          f"per repeat {each}")
    sys.stdout.flush()
    if ARGS.whole:
        bench_whole(X, k)


def bench_whole(X, k):
    """Whole fits with the defaults (k-means++ seeding, one init, tol 1e-4), each library
    seeded its own way: the seeding's share shows (labels differ: the seeds do)."""
    from sklearn.cluster import KMeans

    def ours():
        t0 = time.perf_counter()
        r = mlayer.kmeans(X, k, seed=0, n_threads=ARGS.threads)
        t1 = time.perf_counter()
        mlayer.kmeans(X, k, seed=0, max_iter=1, n_threads=ARGS.threads)
        return t1 - t0, time.perf_counter() - t1, r.n_iter, r.inertia

    def sk():
        from sklearn.cluster import kmeans_plusplus
        t0 = time.perf_counter()
        km = KMeans(k, n_init=1, random_state=0).fit(X)
        t1 = time.perf_counter()
        kmeans_plusplus(X, k, random_state=0)
        return t1 - t0, time.perf_counter() - t1, km.n_iter_, km.inertia_

    ts = {"mlayer": [], "sklearn": []}
    for _ in range(ARGS.repeat):
        for label, fn in (("mlayer", ours), ("sklearn", sk)):
            ts[label].append(fn())
    for label, what in (("mlayer", "k-means++ and 1 iteration"),
                        ("sklearn", "kmeans_plusplus alone")):
        a = np.array([t[:2] for t in ts[label]])
        print(f"  whole fit {label:8s} {np.median(a[:, 0]):6.2f} s ({ts[label][-1][2]} "
              f"iterations, inertia {ts[label][-1][3]:.6g}); {what} {np.median(a[:, 1]):.2f} s")
    each = ", ".join(f"{b[0] / a[0]:.2f}" for a, b in zip(ts["mlayer"], ts["sklearn"]))
    ratio = np.median([t[0] for t in ts["sklearn"]]) / np.median([t[0] for t in ts["mlayer"]])
    print(f"  whole fit ratio sklearn/mlayer {ratio:.2f}x; per repeat {each}")
    sys.stdout.flush()


def bench_som(F):
    X = tiled(F, 10_000, seed=1)
    rows = cols = 65
    epochs = 3

    def ours(mode, ep):
        som = mlayer.SOM(rows, cols, X.shape[1], seed=0, n_threads=ARGS.threads)
        t0 = time.perf_counter()
        som.train(X, ep, mode=mode)
        return (time.perf_counter() - t0) / ep, som

    t_batch = median_of(lambda: ours("batch", epochs)[0], ARGS.repeat)
    runs = [ours("online", 1) for _ in range(ARGS.repeat)]
    t_online, som_on = float(np.median([r[0] for r in runs])), runs[0][1]
    som_b = ours("batch", 10)[1]
    print(f"som 65x65 on {X.shape}: mlayer batch {t_batch:.3f} s/epoch, online {t_online:.3f} "
          f"s/epoch; QE batch(10 epochs) {som_b.quantization_error(X):.3f} "
          f"online(1 epoch) {som_on.quantization_error(X):.3f}")
    try:
        import somoclu
    except ImportError:
        print("  somoclu: not installed (pip install --no-build-isolation somoclu)")
    else:
        Xf = X.astype(np.float32)  # somoclu trains in float32

        def sc():
            s = somoclu.Somoclu(cols, rows, maptype="planar", gridtype="rectangular",
                                neighborhood="gaussian", initialization="random")
            t0 = time.perf_counter()
            s.train(Xf, epochs=epochs)
            return (time.perf_counter() - t0) / epochs

        t_sc = median_of(sc, ARGS.repeat)
        print(f"  somoclu batch  {t_sc:.3f} s/epoch   ratio somoclu/mlayer(batch) "
              f"{t_sc / t_batch:.1f}x")
    try:
        from minisom import MiniSom
    except ImportError:
        print("  minisom: not installed")
    else:
        steps = 1000
        ms = MiniSom(rows, cols, X.shape[1], sigma=rows / 2, learning_rate=0.5, random_seed=0)
        ms.random_weights_init(X)
        t0 = time.perf_counter()
        ms.train(X, steps, random_order=True)
        t_ms = (time.perf_counter() - t0) * len(X) / steps
        print(f"  minisom online {t_ms:.2f} s/epoch (1,000 steps scaled to 10,000)   ratio "
              f"minisom/mlayer(online) {t_ms / t_online:.1f}x, minisom/mlayer(batch) "
              f"{t_ms / t_batch:.0f}x")


def main():
    by_width = features_by_width(ARGS.mocap)
    F = by_width[93] if 93 in by_width else max(by_width.values(), key=len)
    print(f"threads {ARGS.threads}; pose features of the clips: {F.shape}")
    if ARGS.only in (None, "kmeans"):
        # the CMU skeletons: 31 joints (93 columns) and 43 joints (129 columns)
        cases = [d for d in (93, 129) if d in by_width] or [F.shape[1]]
        for d in cases:
            Fd = by_width[d] if d in by_width else F
            bench_kmeans(f"mocap-like ({len(Fd)} frames)", tiled(Fd, 200_000))
        rng = np.random.default_rng(0)
        bench_kmeans("random normal", rng.normal(size=(200_000, 96)))
    if ARGS.only in (None, "som"):
        bench_som(F)


if __name__ == "__main__":
    main()
