"""How many primitives: the k that each criterion picks on each representation of a clip.

Paper 2 (section 4.1) clusters "the low dimensional representation" with k-means and reads k
at the elbow of the inertia: 10 primitives for walking, 15 for ballet. This script measures,
per clip, what the elbow (kneedle rule, :func:`mlayer.manifold.clustering.elbow_point`), the largest
silhouette and the smallest GMM BIC (:func:`mlayer.manifold.mixture.k_criteria`) pick on four
representations of the same frames, over two ranges of k:

- ``som``: the 2-D coordinates of each frame's best-matching unit on the SOM that
  :class:`mlayer.PrimitiveModel` trains (its default manifold: what mlayer clusters);
- ``pca2``: the first two principal components of the pose features (``manifold="pca"``);
- ``pca95``: as many principal components as keep 95% of the variance;
- ``features``: the pose features themselves (:func:`mlayer.manifold.features.pose_features`).

Usage: python docs/primitives_k_table.py CLIP.bvh [CLIP.bvh ...] [--frames 3000]
Prints a Markdown table (rows: clip, representation; columns: elbow / silhouette / BIC for
k in 2..20 and in 2..40).
"""
import argparse
import os
import warnings

import numpy as np

import mlayer
from mlayer.manifold.features import pose_features
from mlayer.manifold.manifold import PCA
from mlayer.manifold.mixture import k_criteria
from mlayer.manifold.primitives import default_lattices
from mlayer.manifold.som import SOM


def representations(m, seed=0):
    X = pose_features(m)
    rows, cols = default_lattices(X.shape[0])[0]
    s = SOM(rows, cols, X.shape[1], seed=seed)
    s.train(X, 20, mode="batch")
    p2 = PCA(2).fit(X)
    full = PCA(min(X.shape)).fit(X)
    var = np.asarray(full.explained_variance_ratio_)
    n95 = int(np.searchsorted(np.cumsum(var), 0.95) + 1)
    return {"som": s.bmu(X).astype(np.float64), "pca2": p2.transform(X),
            f"pca95 ({n95} dims)": PCA(n95).fit(X).transform(X), "features": X}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("clips", nargs="+")
    ap.add_argument("--frames", type=int, default=3000)
    a = ap.parse_args()
    print("| clip | representation | elbow 2..20 | silhouette 2..20 | BIC 2..20 "
          "| elbow 2..40 | silhouette 2..40 | BIC 2..40 |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for path in a.clips:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = mlayer.read_bvh(path)
        m = m[:a.frames]
        for name, P in representations(m).items():
            cells = []
            for hi in (20, 40):
                c = k_criteria(P, range(2, hi + 1), seed=0, n_init=3,
                               reg_covar=1e-6 * float(max(P.var(axis=0).max(), 1e-300)))
                cells += [str(c.picks["elbow"]), str(c.picks["silhouette"]),
                          str(c.picks["bic"])]
            print(f"| {os.path.basename(path)} ({m.n_frames} frames) | {name} | "
                  + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
