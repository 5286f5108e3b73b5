"""mlayer.lgs against dense numpy solves of the normal equations."""
import numpy as np
import pytest

import mlayer


def dense_reference(y, lam, sigma, order, t, n_out):
    y2 = y.reshape(y.shape[0], -1)
    L = np.diff(np.eye(n_out), n=order, axis=0)
    if t is None:
        A = np.eye(n_out)
    else:
        A = np.zeros((len(t), n_out))
        for i, ti in enumerate(t):
            lo = min(int(np.floor(ti)), n_out - 2)
            f = ti - lo
            A[i, lo] += 1 - f
            A[i, lo + 1] += f
    M = lam**2 * L.T @ L + A.T @ A / sigma**2
    x = np.linalg.solve(M, A.T @ y2 / sigma**2)
    var = np.diag(np.linalg.inv(M))
    return x.reshape((n_out,) + y.shape[1:]), var


CASES = [
    # n_obs, n_out, m, order, lam, sigma, kind
    (60, None, 1, 2, 1.0, 1.0, "identity"),
    (60, None, 4, 1, 3.0, 0.5, "identity"),
    (80, None, 3, 2, 30.0, 0.1, "identity"),
    (10, 40, 2, 2, 1.0, 1.0, "uniform"),       # upsampling 8 keys -> 40 like paper Table 1
    (8, 40, 3, 1, 0.5, 0.2, "uniform"),
    (90, 30, 5, 2, 2.0, 1.0, "uniform"),       # downsampling
    (35, 50, 2, 2, 1.0, 2.0, "random"),        # non-uniform (time warp)
    (35, 50, 2, 1, 1.0, 2.0, "random"),
]


def positions(kind, n_obs, n_out, rng):
    if kind == "identity":
        return None
    if kind == "uniform":
        return np.linspace(0, n_out - 1, n_obs)
    t = np.sort(rng.uniform(0, n_out - 1, n_obs))
    t[0], t[-1] = 0, n_out - 1
    return t


@pytest.mark.parametrize("n_obs,n_out,m,order,lam,sigma,kind", CASES)
def test_mean_and_variance_match_dense(n_obs, n_out, m, order, lam, sigma, kind, rng):
    n_out = n_obs if n_out is None else n_out
    t = positions(kind, n_obs, n_out, rng)
    y = np.cumsum(rng.normal(size=(n_obs, m)), axis=0)
    x, var = mlayer.lgs(y, lam, sigma, order=order, t=t, n_out=n_out, return_var=True)
    xr, varr = dense_reference(y, lam, sigma, order, t, n_out)
    np.testing.assert_allclose(x, xr, rtol=1e-10, atol=1e-10 * np.abs(xr).max())
    np.testing.assert_allclose(var, varr, rtol=1e-10)


def test_one_dimensional_input_gives_one_dimensional_output(rng):
    y = rng.normal(size=50)
    x = mlayer.lgs(y, 2.0)
    assert x.shape == (50,)
    np.testing.assert_allclose(x, mlayer.lgs(y[:, None], 2.0)[:, 0])


@pytest.mark.skipif(not mlayer.have_cholmod(), reason="built without CHOLMOD")
@pytest.mark.parametrize("n_obs,n_out,m,order,lam,sigma,kind", CASES)
def test_cholmod_agrees_with_banded(n_obs, n_out, m, order, lam, sigma, kind, rng):
    n_out = n_obs if n_out is None else n_out
    t = positions(kind, n_obs, n_out, rng)
    y = rng.normal(size=(n_obs, m))
    xb = mlayer.lgs(y, lam, sigma, order=order, t=t, n_out=n_out)
    xs = mlayer.lgs(y, lam, sigma, order=order, t=t, n_out=n_out, solver="cholmod")
    np.testing.assert_allclose(xs, xb, rtol=0, atol=1e-10 * np.abs(xb).max())


def test_smoothing_reduces_noise_on_a_sine(rng):
    tt = np.linspace(0, 4 * np.pi, 400)
    clean = np.sin(tt)
    noisy = clean + rng.normal(scale=0.2, size=tt.shape)
    x = mlayer.lgs(noisy, lam=30.0, sigma=1.0)
    assert np.sqrt(np.mean((x - clean) ** 2)) < 0.3 * np.sqrt(np.mean((noisy - clean) ** 2))


def test_no_copy_of_contiguous_float64_input(rng):
    y = rng.normal(size=(40, 3))
    g = mlayer.LGS(40, 1.0, 1.0)
    out = np.empty((40, 3))
    res = g.solve(y, out=out)
    assert res is out
    # a strided view is accepted (copied once), a float32 array is converted, not reinterpreted
    np.testing.assert_allclose(g.solve(np.asfortranarray(y)), out)
    np.testing.assert_allclose(g.solve(y.astype(np.float32)),
                               g.solve(y.astype(np.float32).astype(np.float64)))


def test_variance_grows_between_sparse_keys():
    t = np.linspace(0, 40, 5)
    _, var = mlayer.lgs(np.zeros(5), 1.0, 0.1, t=t, n_out=41, return_var=True)
    assert var[5] > 10 * var[0] and var[15] > 10 * var[10]


@pytest.mark.parametrize("kwargs,exc,match", [
    (dict(lam=-1.0), mlayer.InvalidArgumentError, "lam"),
    (dict(sigma=0.0), mlayer.InvalidArgumentError, "sigma"),
    (dict(sigma=float("nan")), mlayer.InvalidArgumentError, "sigma"),
    (dict(order=3), mlayer.InvalidArgumentError, "order"),
    (dict(solver="dense"), mlayer.InvalidArgumentError, "solver"),
    (dict(t=[0, 2, 1], n_out=5), mlayer.InvalidArgumentError, "sorted"),
    (dict(t=[0, 2, 7], n_out=5), mlayer.InvalidArgumentError, "outside"),
    (dict(t=[0, float("nan"), 3], n_out=5), mlayer.InvalidArgumentError, "finite"),
    (dict(t=[2, 2, 2], n_out=5), mlayer.SingularMatrixError, "distinct"),
    (dict(t=[0, 1, 4], n_out=5, lam=0.0), mlayer.SingularMatrixError, "singular"),
    (dict(t=[0, 1, 4]), mlayer.InvalidArgumentError, "n_out"),
])
def test_bad_parameters_raise(kwargs, exc, match):
    y = np.ones(3)
    with pytest.raises(exc, match=match):
        mlayer.lgs(y, **kwargs)


def test_bad_observations_raise():
    with pytest.raises(ValueError, match="NaN"):
        mlayer.lgs(np.array([1.0, np.nan, 2.0, 3.0]))
    with pytest.raises(mlayer.Error, match="NaN"):
        mlayer.lgs(np.array([[1.0, 2.0], [np.inf, 2.0], [0, 0], [1, 1]]))
    with pytest.raises(mlayer.InvalidArgumentError, match="frames"):
        mlayer.lgs(np.ones(2))                       # too few frames for the order-2 prior
    with pytest.raises(mlayer.InvalidArgumentError, match="dimensions"):
        mlayer.lgs(np.ones((4, 2, 2)))
    with pytest.raises(mlayer.InvalidArgumentError, match="observations"):
        mlayer.LGS(10).solve(np.ones(9))
    with pytest.raises(mlayer.InvalidArgumentError, match="convert"):
        mlayer.lgs(["a", "b", "c"])


def test_wrong_output_array_is_refused():
    g = mlayer.LGS(10)
    for bad in (np.empty((10, 2), dtype=np.float32), np.empty((10, 3)), np.empty((2, 10)).T):
        with pytest.raises(mlayer.InvalidArgumentError, match="out"):
            g.solve(np.ones((10, 2)), out=bad)


def test_closed_handle():
    g = mlayer.LGS(10)
    g.close()
    g.close()  # idempotent


def test_page_mapping_thread_gives_the_same_bits(rng):
    # 70,000 x 16 doubles (9 MB) is over the 8 MiB from which a second thread maps the pages
    y = np.cumsum(rng.normal(size=(70000, 16)), axis=0)
    ref = mlayer.lgs(y, 3.0, threads=1)
    for threads in (None, 2, 3):
        assert np.array_equal(mlayer.lgs(y, 3.0, threads=threads), ref)
    g = mlayer.LGS(70000, 3.0)
    out = np.full_like(y, np.nan)
    assert g.solve(y, out=out, threads=2) is out and np.array_equal(out, ref)
    t = np.linspace(0.0, 69998.5, 70000)
    assert np.array_equal(mlayer.lgs(y, 3.0, t=t, n_out=70000),
                          mlayer.lgs(y, 3.0, t=t, n_out=70000, threads=1))


@pytest.mark.parametrize("threads", [0, -1, 1.5, "2", True])
def test_bad_thread_counts_raise(threads):
    with pytest.raises(mlayer.InvalidArgumentError, match="threads"):
        mlayer.lgs(np.ones((5, 2)), threads=threads)
