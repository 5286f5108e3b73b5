"""mlayer.kmeans against scikit-learn's Lloyd from the same initial centres; k-means++ and
threads; the elbow rule; bad input."""
import numpy as np
import pytest

import mlayer
from conftest import reference, requires
from mlayer.manifold.clustering import elbow_point, predict

sklearn_cluster = reference("sklearn.cluster", "scikit-learn")


def blobs(rng, n, d, c, spread=1.0, scale=6.0):
    mu = rng.normal(size=(c, d)) * scale
    return mu[rng.integers(0, c, n)] + spread * rng.normal(size=(n, d))


@pytest.mark.parametrize("n,d,k", [(1000, 2, 3), (3000, 8, 16), (2500, 40, 25), (600, 93, 64)])
@pytest.mark.parametrize("algorithm", ["lloyd", "hamerly"])
def test_same_as_sklearn_lloyd_from_same_centres(rng, n, d, k, algorithm):
    X = blobs(rng, n, d, max(2, k // 2))
    init = X[rng.choice(n, k, replace=False)]
    sk = sklearn_cluster.KMeans(k, init=init, n_init=1, algorithm="lloyd").fit(X)
    r = mlayer.kmeans(X, k, init=init, algorithm=algorithm, n_threads=2)
    assert np.array_equal(r.labels, sk.labels_)
    assert r.inertia == pytest.approx(sk.inertia_, rel=1e-9)
    assert r.n_iter == sk.n_iter_
    np.testing.assert_allclose(r.centers, sk.cluster_centers_, rtol=1e-9, atol=1e-9)


def test_same_as_sklearn_on_real_pose_features(mocap):
    X = mlayer.pose_features(mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh"))
    k = 20
    init = X[:: len(X) // k][:k]
    sk = sklearn_cluster.KMeans(k, init=init, n_init=1, algorithm="lloyd", max_iter=100).fit(X)
    r = mlayer.kmeans(X, k, init=init, max_iter=100)
    assert np.array_equal(r.labels, sk.labels_)
    assert r.inertia == pytest.approx(sk.inertia_, rel=1e-9)


def test_kmeanspp_is_seeded_and_thread_independent(rng):
    X = blobs(rng, 4000, 5, 8)
    a = mlayer.kmeans(X, 8, n_init=3, seed=7, n_threads=1)
    b = mlayer.kmeans(X, 8, n_init=3, seed=7, n_threads=2)
    c = mlayer.kmeans(X, 8, n_init=3, seed=8)
    assert np.array_equal(a.centers, b.centers) and np.array_equal(a.labels, b.labels)
    assert a.inertia == b.inertia
    assert not np.array_equal(a.centers, c.centers)
    # comparable quality to scikit-learn's k-means++ (different generator)
    sk = sklearn_cluster.KMeans(8, n_init=3, random_state=0).fit(X)
    assert a.inertia <= 1.05 * sk.inertia_
    assert np.array_equal(a.predict(X), a.labels)


def test_predict_brute_force(rng):
    C = rng.normal(size=(13, 6))
    X = rng.normal(size=(500, 6))
    ref = np.argmin(((X[:, None, :] - C[None]) ** 2).sum(-1), axis=1)
    assert np.array_equal(predict(C, X), ref)


def test_elbow_picks_the_number_of_blobs(rng):
    X = blobs(rng, 3000, 3, 4, spread=0.5, scale=10.0)
    e = mlayer.elbow(X, range(1, 11), n_init=2)
    assert e.k == 4
    assert np.all(np.diff(e.inertia) <= 1e-9 * e.inertia[0])
    assert len(e.results) == 10 and e.score.shape == (10,)


def test_elbow_point_rule():
    k, s = elbow_point([1, 2, 3, 4, 5], [100, 30, 20, 15, 12])
    assert k == 2 and s.argmax() == 1
    assert elbow_point([1, 2], [5, 1])[0] == 1
    assert elbow_point([3, 1, 2], [1, 1, 1])[0] == 1


@requires("plot")
def test_elbow_plot(rng):
    import matplotlib
    matplotlib.use("Agg")
    e = mlayer.elbow(blobs(rng, 500, 2, 3), [1, 2, 3, 4, 5])
    ax = e.plot()
    assert ax.get_xlabel() == "k"


@pytest.mark.parametrize("bad,match", [
    (dict(X=np.zeros((3, 2)), k=4), "exceeds"),
    (dict(X=np.zeros((0, 2)), k=1), "empty"),
    (dict(X=np.array([[0.0, np.nan], [1, 2]]), k=1), "NaN"),
    (dict(X=np.zeros((5, 2)), k=2, init=np.zeros((2, 3))), "shape"),
    (dict(X=np.zeros((5, 2)), k=0), "k must"),
    (dict(X=np.zeros((5, 2)), k=2, tol=-1.0), "out of range"),
    (dict(X=np.zeros((5, 2)), k=2, algorithm="elkan"), "algorithm"),
])
def test_bad_input(bad, match):
    with pytest.raises(mlayer.InvalidArgumentError, match=match):
        mlayer.kmeans(**bad)


def test_dimension_mismatch_in_predict():
    with pytest.raises(mlayer.InvalidArgumentError, match="dimension mismatch"):
        predict(np.zeros((2, 3)), np.zeros((4, 2)))
