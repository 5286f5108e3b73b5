"""mlayer.SOM: quantization error against MiniSom with comparable settings, BMUs against a
brute force, determinism across threads, save/load, bad input."""
import numpy as np
import pytest

import mlayer
from conftest import reference


def three_blobs(rng):
    return np.concatenate([rng.normal(size=(400, 4)) + c
                           for c in ([0, 0, 0, 0], [5, 5, 0, 0], [0, 5, 5, 0])])


@pytest.mark.parametrize("mode,epochs", [("online", 5), ("online", 20), ("batch", 20)])
def test_quantization_error_close_to_minisom(rng, mode, epochs):
    minisom = reference("minisom", "MiniSom")
    X = three_blobs(rng)
    # MiniSom's default schedule divides sigma and the learning rate by 3 over the run
    ms = minisom.MiniSom(10, 10, 4, sigma=3.0, learning_rate=0.5, random_seed=1)
    ms.random_weights_init(X)
    ms.train(X, epochs * len(X), random_order=True)
    ref = ms.quantization_error(X)
    som = mlayer.SOM(10, 10, 4, sigma0=3.0, sigma1=1.0, alpha0=0.5, alpha1=0.5 / 3)
    som.train(X, epochs, mode=mode)
    qe = som.quantization_error(X)
    assert abs(qe - ref) <= 0.05 * ref, (qe, ref)
    assert som.topographic_error(X) < 0.15


def test_bmu_errors_brute_force(rng):
    X = rng.normal(size=(700, 5))
    som = mlayer.SOM(6, 4, 5)
    W = rng.normal(size=(6, 4, 5))
    som.codebook = W
    d = ((X[:, None, :] - W.reshape(-1, 5)[None]) ** 2).sum(-1)
    order = np.argsort(d, axis=1, kind="stable")
    bmu = som.bmu(X)
    assert bmu.shape == (700, 2)
    assert np.array_equal(bmu[:, 0] * 4 + bmu[:, 1], order[:, 0])
    qe = np.sqrt(d[np.arange(700), order[:, 0]]).mean()
    assert som.quantization_error(X) == pytest.approx(qe, rel=1e-12)
    r1, c1 = np.divmod(order[:, 0], 4)
    r2, c2 = np.divmod(order[:, 1], 4)
    te = np.mean((abs(r1 - r2) > 1) | (abs(c1 - c2) > 1))
    assert som.topographic_error(X) == pytest.approx(te)


@pytest.mark.parametrize("mode", ["batch", "online"])
def test_bit_identical_across_threads_and_runs(rng, mode):
    X = three_blobs(rng)
    a = mlayer.SOM(9, 7, 4, seed=3, n_threads=1).train(X, 3, mode=mode).codebook
    b = mlayer.SOM(9, 7, 4, seed=3, n_threads=2).train(X, 3, mode=mode).codebook
    c = mlayer.SOM(9, 7, 4, seed=3, n_threads=2).train(X, 3, mode=mode).codebook
    assert a.tobytes() == b.tobytes() == c.tobytes()


def test_online_steps_split_over_threads_on_real_clip(mocap):
    # a 20 x 20 map on 93 pose features is large enough (>= 16,384 codebook values per thread)
    # for each online step to be split over 2 threads: the result is the same to the bit
    X = mlayer.pose_features(mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh"))[:1500]
    a = mlayer.SOM(20, 20, X.shape[1], seed=4, n_threads=1).train(X, 2, mode="online")
    b = mlayer.SOM(20, 20, X.shape[1], seed=4, n_threads=2).train(X, 2, mode="online")
    assert a.codebook.tobytes() == b.codebook.tobytes()


def test_save_load_roundtrip(tmp_path, rng):
    X = three_blobs(rng)
    som = mlayer.SOM(5, 6, 4).train(X, 2)
    p = tmp_path / "map.som"
    som.save(p)
    back = mlayer.SOM.load(p)
    assert (back.rows, back.cols, back.dim) == (5, 6, 4)
    assert np.array_equal(back.codebook, som.codebook)
    blob = bytearray(som.to_bytes())
    blob[-1] ^= 0xFF
    with pytest.raises(mlayer.ParseError, match="hash"):
        mlayer.SOM.from_bytes(bytes(blob))


def test_bad_input(rng):
    with pytest.raises(mlayer.InvalidArgumentError, match="lattice"):
        mlayer.SOM(0, 3, 2)
    som = mlayer.SOM(3, 3, 2)
    with pytest.raises(mlayer.InvalidArgumentError, match="dimension mismatch"):
        som.train(np.zeros((5, 3)), 1)
    with pytest.raises(mlayer.InvalidArgumentError, match="empty"):
        som.train(np.zeros((0, 2)), 1)
    with pytest.raises(mlayer.InvalidArgumentError, match="NaN"):
        som.train(np.array([[0.0, np.nan]]), 1)
    with pytest.raises(mlayer.InvalidArgumentError, match="mode"):
        som.train(np.zeros((5, 2)), 1, mode="fast")
    with pytest.raises(mlayer.InvalidArgumentError, match="shape"):
        som.codebook = np.zeros((3, 3, 3))
