"""Manifold and primitives (paper 2): PCA, fuzzy c-means, Gaussian mixture, Markov model, GRBF,
synthesis and the `primitives` / `generate` commands, against independent references."""
import numpy as np
import pytest

import mlayer
from conftest import reference, requires
from mlayer import GRBF, PCA, GaussianMixture, InvalidArgumentError, Markov, fuzzy_cmeans


def blobs(rng, n=300, d=2, k=3, spread=0.6):
    centers = rng.normal(scale=4.0, size=(k, d))
    lab = rng.integers(k, size=n)
    return centers[lab] + spread * rng.normal(size=(n, d)), lab


# ---- PCA ---------------------------------------------------------------------------------------

def test_pca_matches_covariance_eigenvectors(rng):
    X = rng.normal(size=(200, 5)) @ rng.normal(size=(5, 5))
    p = PCA(3).fit(X)
    w, v = np.linalg.eigh(np.cov(X.T))
    order = np.argsort(w)[::-1][:3]
    np.testing.assert_allclose(p.explained_variance_, w[order], rtol=1e-10)
    for i, j in enumerate(order):
        assert abs(abs(p.components_[i] @ v[:, j]) - 1.0) < 1e-9
    Z = p.transform(X)
    np.testing.assert_allclose(Z.mean(0), 0, atol=1e-10)
    full = PCA(5).fit(X)
    np.testing.assert_allclose(full.inverse_transform(full.transform(X)), X, atol=1e-9)


# ---- fuzzy c-means -----------------------------------------------------------------------------

def direct_fcm(X, V, m, iters):
    """Textbook Bezdek iteration, written out loop by loop."""
    n, c = X.shape[0], V.shape[0]
    for _ in range(iters):
        U = np.zeros((n, c))
        for i in range(n):
            d = [np.linalg.norm(X[i] - V[k]) for k in range(c)]
            for k in range(c):
                U[i, k] = 1.0 / sum((d[k] / d[j]) ** (2.0 / (m - 1.0)) for j in range(c))
        V = np.array([(U[:, k] ** m) @ X / (U[:, k] ** m).sum() for k in range(c)])
    return U, V


def test_fuzzy_cmeans_memberships_and_direct_reference(rng):
    X, _ = blobs(rng, n=40, d=2, k=3)
    V0 = X[:3].copy() + 0.1
    for m in (2.0, 1.5, 3.0):
        r = fuzzy_cmeans(X, 3, m, init=V0, max_iter=25, tol=0.0)
        np.testing.assert_allclose(r.u.sum(axis=1), 1.0, atol=1e-12)
        assert (r.u >= 0).all()
        # my fit: init memberships from V0, then 25 (centres, memberships) updates
        U, V = direct_fcm(X, V0, m, 1)
        for _ in range(24):
            U, V = direct_fcm(X, V, m, 1)
        np.testing.assert_allclose(r.u, U, atol=1e-9)
        assert r.n_iter == 25


def test_fuzzy_cmeans_seeded_and_separates_blobs(rng):
    X, lab = blobs(rng, n=300, k=3, spread=0.3)
    a = fuzzy_cmeans(X, 3, seed=4)
    b = fuzzy_cmeans(X, 3, seed=4)
    np.testing.assert_array_equal(a.u, b.u)
    # clusters agree with the generating labels up to renaming
    for k in range(3):
        assert len(np.unique(a.labels[lab == k])) == 1
    np.testing.assert_allclose(a.predict_proba(X), a.u, atol=1e-6)


def test_fuzzy_point_on_centre():
    X = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 5.0]])
    r = fuzzy_cmeans(X, 3, init=X.copy(), max_iter=3)
    np.testing.assert_allclose(r.u, np.eye(3))


# ---- Gaussian mixture --------------------------------------------------------------------------

@pytest.mark.parametrize("cov", ["full", "diag"])
def test_gmm_log_likelihood_matches_sklearn(rng, cov):
    sk = reference("sklearn.mixture", "scikit-learn")
    X, _ = blobs(rng, n=600, d=3, k=4, spread=1.0)
    X[:, 1] += 0.5 * X[:, 0]  # correlated
    k = 4
    means = X[rng.choice(X.shape[0], k, replace=False)]
    w0 = np.full(k, 1.0 / k)
    if cov == "full":
        c0 = np.repeat(np.cov(X.T)[None], k, axis=0)
        prec = np.linalg.inv(c0)
    else:
        c0 = np.repeat(X.var(0)[None], k, axis=0)
        prec = 1.0 / c0
    ours = GaussianMixture(k, cov, init=means, weights_init=w0, covariances_init=c0,
                           max_iter=200, tol=1e-6).fit(X)
    ref = sk.GaussianMixture(k, covariance_type=cov, means_init=means, weights_init=w0,
                             precisions_init=prec, max_iter=200, tol=1e-6).fit(X)
    assert abs(ours.score(X) - ref.score(X)) <= 0.01 * abs(ref.score(X))
    np.testing.assert_allclose(ours.score(X), ref.score(X), rtol=1e-6)
    np.testing.assert_allclose(ours.score_samples(X), ref.score_samples(X), rtol=1e-5)
    np.testing.assert_allclose(ours.predict_proba(X), ref.predict_proba(X), atol=1e-5)
    assert (ours.predict(X) == ref.predict(X)).mean() > 0.999
    assert ours.n_iter_ == ref.n_iter_
    np.testing.assert_allclose(ours.log_likelihood(X), ours.score(X) * X.shape[0])


def test_gmm_means_only_init_like_sklearn(rng):
    """Means alone: weights and covariances from the hard assignment to the nearest mean (as
    scikit-learn derives them from its k-means labels); sklearn given those three agrees."""
    sk = reference("sklearn.mixture", "scikit-learn")
    X, _ = blobs(rng, n=400, d=2, k=3)
    means = X[:3].copy()
    lab = np.argmin(((X[:, None, :] - means[None]) ** 2).sum(-1), axis=1)
    w0 = np.bincount(lab, minlength=3) / X.shape[0]
    cov = np.array([np.cov(X[lab == j].T, bias=True) + 1e-6 * np.eye(2) for j in range(3)])
    mu = np.array([X[lab == j].mean(0) for j in range(3)])
    ref = sk.GaussianMixture(3, means_init=means, weights_init=w0,
                             precisions_init=np.linalg.inv(cov), max_iter=300, tol=1e-6).fit(X)
    ours = GaussianMixture(3, "full", init=means, max_iter=300, tol=1e-6).fit(X)
    np.testing.assert_allclose(ours.score(X), ref.score(X), rtol=1e-6)
    one = GaussianMixture(3, "full", init=means, max_iter=1, tol=0).fit(X)
    assert one.n_iter_ == 1
    assert mu.shape == (3, 2)


def test_gmm_kmeanspp_init(rng):
    X, _ = blobs(rng, n=300, k=3, spread=0.3)
    g = GaussianMixture(3, seed=1).fit(X)
    assert g.converged_
    np.testing.assert_allclose(g.predict_proba(X).sum(1), 1.0, atol=1e-12)
    np.testing.assert_allclose(g.weights_.sum(), 1.0)


# ---- Markov ------------------------------------------------------------------------------------

def test_markov_counts_rows_and_eq5():
    lab = np.array([0, 0, 0, 1, 1, 2, 2, 2, 0, 0, 1, 1, 1, 2, 0])
    mk = Markov.fit(lab)
    C = np.zeros((3, 3))
    for a, b in zip(lab[:-1], lab[1:]):
        C[a, b] += 1
    np.testing.assert_allclose(mk.P, C / C.sum(1, keepdims=True))
    np.testing.assert_allclose(mk.P.sum(1), 1.0)
    for j in range(3):
        k = mk.most_likely_next(j)
        assert k != j
        off = [i for i in range(3) if i != j]
        assert mk.P[j, k] == max(mk.P[j, i] for i in off)
    assert mk.most_likely_next(0) == 1 and mk.most_likely_next(1) == 2
    # the diagonal dominates but eq. 5 excludes self
    assert mk.P[0, 0] > mk.P[0, 1]
    # mean run lengths: 0 -> (3 + 2 + 1) / 3, 1 -> (2 + 3) / 2, 2 -> (3 + 1) / 2
    np.testing.assert_allclose(mk.run_length, [2.0, 2.5, 2.0])
    np.testing.assert_array_equal(mk.most_likely_path(0), [0, 1, 2, 0])


def test_markov_clips_and_unseen_rows():
    mk = Markov.fit([np.array([0, 0, 1]), np.array([2, 2])], n_states=4)
    assert mk.counts[1].sum() == 0  # no transition across the clip boundary 1 -> 2
    np.testing.assert_allclose(mk.P[1], 0.25)
    np.testing.assert_allclose(mk.P[3], 0.25)
    np.testing.assert_allclose(mk.P.sum(1), 1.0)


def test_markov_sampling_seeded(rng):
    lab = rng.integers(5, size=2000)
    mk = Markov.fit(lab)
    a = mk.sample(2, 500, seed=7)
    np.testing.assert_array_equal(a, mk.sample(2, 500, seed=7))
    assert a[0] == 2 and not np.array_equal(a, mk.sample(2, 500, seed=8))
    b = mk.sample(2, 300, noise=0.5, seed=3)
    np.testing.assert_array_equal(b, mk.sample(2, 300, noise=0.5, seed=3))
    d = mk.sample(1, 400, seed=2, distinct=True)
    assert (np.diff(d) != 0).all()
    # empirical transitions of a long sample approach P
    s = mk.sample(0, 200000, seed=1)
    emp = Markov.fit(s, n_states=5).P
    np.testing.assert_allclose(emp, mk.P, atol=0.01)
    Q = mk.perturbed(0.3, seed=1).P
    np.testing.assert_allclose(Q.sum(1), 1.0)
    assert not np.allclose(Q, mk.P)
    np.testing.assert_array_equal(Q, mk.perturbed(0.3, seed=1).P)


# ---- GRBF --------------------------------------------------------------------------------------

def smooth_fn(P):
    return np.stack([np.sin(P[:, 0]) * np.cos(0.7 * P[:, 1]), P[:, 0] * P[:, 1] / 10,
                     np.exp(-((P - 2) ** 2).sum(1))], axis=1)


def test_grbf_square_interpolates_and_matches_scipy(rng):
    interp = reference("scipy.interpolate", "scipy")
    lat = (7, 9)
    bounds = ((0.0, 5.0), (-1.0, 4.0))
    C = mlayer.manifold.manifold.lattice_points(lat, bounds)
    Y = smooth_fn(C)
    g = GRBF("thin_plate", lat, bounds=bounds).fit(C, Y)
    np.testing.assert_allclose(g.predict(C), Y, atol=1e-9)
    ref = interp.RBFInterpolator(C, Y, kernel="thin_plate_spline", degree=1)
    Q = rng.uniform([0, -1], [5, 4], size=(500, 2))
    np.testing.assert_allclose(g.predict(Q), ref(Q), atol=1e-8)
    # Gaussian kernel, square: interpolates too
    gg = GRBF("gaussian", lat, bounds=bounds).fit(C, Y)
    np.testing.assert_allclose(gg.predict(C), Y, atol=1e-7)
    # explicit centres = scattered data points
    S = rng.uniform(size=(40, 2)) * 3
    gs = GRBF(centers=S).fit(S, smooth_fn(S))
    ref = interp.RBFInterpolator(S, smooth_fn(S), kernel="thin_plate_spline", degree=1)
    np.testing.assert_allclose(gs.predict(Q), ref(Q), atol=1e-7)


def test_grbf_least_squares(rng):
    P = rng.uniform(0, 4, size=(400, 2))
    Y = smooth_fn(P) + 0.01 * rng.normal(size=(400, 3))
    g = GRBF("thin_plate", (6, 6)).fit(P, Y)
    # independent reference: minimize |D b - Y| subject to Pc^T w = 0 by the KKT system
    D = g.design(P)
    N = 36
    Pc = np.hstack([np.ones((N, 1)), g.centers_])
    Cm = np.hstack([Pc.T, np.zeros((3, 3))])
    K = np.block([[D.T @ D, Cm.T], [Cm, np.zeros((3, 3))]])
    sol = np.linalg.solve(K, np.vstack([D.T @ Y, np.zeros((3, 3))]))[:N + 3]
    np.testing.assert_allclose(g.coef_, sol, rtol=1e-6, atol=1e-8 * np.abs(sol).max())
    np.testing.assert_allclose(Pc.T @ g.coef_[:N], 0, atol=1e-8)
    assert np.sqrt(((g.predict(P) - smooth_fn(P)) ** 2).mean()) < 0.05
    v = GRBF("gaussian", (5, 5)).fit(P, Y[:, 0])
    assert v.predict(P[:3]).shape == (3,)


def test_grbf_least_squares_many_centres(rng):
    # 306 centres: the triangular solve after the QR runs over several blocks; the fitted
    # values (well conditioned, unlike the coefficients) against the KKT reference
    P = rng.uniform(0, 4, size=(1500, 2))
    Y = smooth_fn(P) + 0.01 * rng.normal(size=(1500, 3))
    g = GRBF("thin_plate", (18, 17)).fit(P, Y)
    N, m = 306, 3
    D = g.design(P)
    Pc = np.hstack([np.ones((N, 1)), g.centers_])
    Cm = np.hstack([Pc.T, np.zeros((m, m))])
    K = np.block([[D.T @ D, Cm.T], [Cm, np.zeros((m, m))]])
    sol = np.linalg.solve(K, np.vstack([D.T @ Y, np.zeros((m, 3))]))[:N + m]
    np.testing.assert_allclose(g.predict(P), D @ sol, rtol=0, atol=1e-7 * np.abs(Y).max())
    np.testing.assert_allclose(Pc.T @ g.coef_[:N], 0, atol=1e-8 * np.abs(g.coef_).max())


@pytest.mark.parametrize("lat", [(2, 2), (2, 3), (3, 2), (4, 6), (5, 5), (6, 7), (9, 4)])
@pytest.mark.parametrize("kernel", ["thin_plate", "gaussian"])
def test_grbf_lattice_split_matches_whole_system(rng, monkeypatch, lat, kernel):
    # interpolation on a lattice goes through the four symmetry classes of the lattice (C core,
    # Cholesky per class); the same centres passed explicitly go through LU of the whole
    # bordered system; so does the fallback when the C core finds a class indefinite
    calls = []
    orig = GRBF._fit_lattice_c
    monkeypatch.setattr(GRBF, "_fit_lattice_c", lambda self, Y: calls.append(1) or orig(self, Y))
    bounds = ((-1.0, 3.0), (0.5, 2.0))
    C = mlayer.manifold.manifold.lattice_points(lat, bounds)
    Y = np.hstack([smooth_fn(C), rng.normal(size=(C.shape[0], 2))])
    g = GRBF(kernel, lat, bounds=bounds).fit(C, Y)
    assert calls == [1]
    ref = GRBF(kernel, centers=C, width=g.width_ if kernel == "gaussian" else None).fit(C, Y)
    assert calls == [1]
    scale = np.abs(ref.coef_).max()
    np.testing.assert_allclose(g.coef_, ref.coef_, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(g.predict(C), Y, rtol=0, atol=1e-10 * np.abs(Y).max())
    np.testing.assert_allclose(g.coef_[:-3].sum(0), 0, atol=1e-10 * scale)  # side conditions
    np.testing.assert_allclose(C.T @ g.coef_[:-3], 0, atol=1e-9 * scale)

    def indefinite(self, Y):
        raise mlayer.SingularMatrixError("class indefinite (forced)")
    monkeypatch.setattr(GRBF, "_fit_lattice_c", indefinite)
    fb = GRBF(kernel, lat, bounds=bounds).fit(C, Y)
    np.testing.assert_allclose(fb.coef_, g.coef_, rtol=0, atol=1e-10 * scale)


def test_grbf_bench_case_matches_scipy(rng):
    # the case of bench/python/bench_grbf.py: 40 x 50 lattice, 93 outputs, thin plate with
    # linear terms, interpolating; scipy's RBFInterpolator solves the whole system by LU
    interp = reference("scipy.interpolate", "scipy")
    bounds = ((0.0, 64.0), (0.0, 64.0))
    C = mlayer.manifold.manifold.lattice_points((40, 50), bounds)
    f = rng.normal(scale=0.08, size=(2, 93))
    ph = rng.uniform(0, 2 * np.pi, size=93)
    amp = rng.uniform(1, 20, size=93)
    Y = amp * np.sin(C @ f + ph)
    Q = rng.uniform(0, 64, size=(3000, 2))
    ours = GRBF("thin_plate", (40, 50), bounds=bounds).fit(C, Y).predict(Q)
    ref = interp.RBFInterpolator(C, Y, kernel="thin_plate_spline", degree=1)(Q)
    # both are within rounding of the exact interpolant (condition number about 1e7 here)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


def test_grbf_ridge_matches_kkt_reference(rng):
    P = rng.uniform(0, 4, size=(300, 2))
    Y = smooth_fn(P) + 0.05 * rng.normal(size=(300, 3))
    N, m = 25, 3
    g = GRBF("thin_plate", (5, 5), smoothing=1e-3).fit(P, Y)
    D = g.design(P)
    Pc = np.hstack([np.ones((N, 1)), g.centers_])
    proj = np.eye(N) - Pc @ np.linalg.solve(Pc.T @ Pc, Pc.T)
    lam = 1e-3 * np.sum((D[:, :N] @ proj) ** 2) / (N - m)
    Cm = np.hstack([Pc.T, np.zeros((m, m))])
    H = D.T @ D
    H[:N, :N] += lam * np.eye(N)
    K = np.block([[H, Cm.T], [Cm, np.zeros((m, m))]])
    sol = np.linalg.solve(K, np.vstack([D.T @ Y, np.zeros((m, 3))]))[:N + m]
    np.testing.assert_allclose(g.coef_, sol, rtol=0, atol=1e-8 * np.abs(sol).max())
    plain = GRBF("thin_plate", (5, 5)).fit(P, Y)
    assert np.abs(g.coef_[:N]).sum() < np.abs(plain.coef_[:N]).sum()  # the ridge shrinks w


def test_grbf_threads_and_chunks_do_not_change_values(rng):
    P = rng.uniform(0, 4, size=(500, 2))
    Y = smooth_fn(P)
    Q = rng.uniform(-1, 5, size=(1000, 2))
    a = GRBF("gaussian", (6, 5), n_threads=1).fit(P, Y)
    b = GRBF("gaussian", (6, 5), n_threads=3).fit(P, Y)
    assert a.coef_.tobytes() == b.coef_.tobytes()
    np.testing.assert_array_equal(a.predict(Q), b.predict(Q))
    np.testing.assert_array_equal(a.predict(Q)[77:300], b.predict(Q[77:300]))
    np.testing.assert_allclose(a.predict(Q), a.design(Q) @ a.coef_, rtol=1e-13, atol=1e-13)


# ---- bad input ---------------------------------------------------------------------------------

def test_bad_input_messages(rng):
    X = rng.normal(size=(10, 2))
    cases = [
        (lambda: fuzzy_cmeans(X, 11), "exceeds the number of rows"),
        (lambda: GaussianMixture(11, init=X[:1]).fit(X), "exceeds the number of rows"),
        (lambda: fuzzy_cmeans(np.zeros((0, 2)), 1), "empty data"),
        (lambda: GaussianMixture(2, init=X[:2]).fit(np.zeros((0, 2))), "empty data"),
        (lambda: fuzzy_cmeans(np.where(X > 1, np.nan, X), 2), "NaN"),
        (lambda: PCA(2).fit(np.full((5, 3), np.inf)), "NaN"),
        (lambda: GaussianMixture(2, init=np.zeros((2, 3))).fit(X), "shape"),
        (lambda: GaussianMixture(2, init=X[:2]).fit(X).predict(np.zeros((3, 5))),
         "dimension mismatch"),
        (lambda: PCA(2).fit(X).transform(np.zeros((3, 4))), "dimension mismatch"),
        (lambda: GRBF(lattice=(0, 15)), "lattice rows must be an integer >= 1"),
        (lambda: GRBF(lattice=(15,)), "two integers"),
        (lambda: GRBF(lattice=(3, 3)).fit(X, X[:5]), "10 points but 5 rows"),
        (lambda: GRBF(lattice=(5, 5)).fit(X, X), "underdetermined"),
        (lambda: GRBF(lattice=(2, 2)).fit(X, X).predict(np.zeros((2, 3))),
         "dimension mismatch"),
        (lambda: GRBF(kernel="cubic"), "kernel"),
        (lambda: Markov.fit(np.array([0, 1, 5]), n_states=3), "out of range"),
        (lambda: Markov.fit(np.array([0, -1, 1])), "out of range"),
        (lambda: Markov.fit(np.array([], dtype=int)), "no labels"),
        (lambda: Markov.fit(np.array([0.5, 1.0])), "integers"),
        (lambda: Markov.fit(np.array([0, 1, 1])).most_likely_next(2), "out of range"),
        (lambda: Markov.fit(np.array([0, 1, 1])).sample(0, 5, noise=-1), "noise"),
        (lambda: fuzzy_cmeans(X, 2, m=1.0), "m must be"),
        (lambda: GaussianMixture(2, covariance="spherical"), "covariance"),
    ]
    for fn, text in cases:
        with pytest.raises(InvalidArgumentError, match=text):
            fn()


# ---- synthesis and the commands ----------------------------------------------------------------

@pytest.fixture(scope="module")
def walk_model(mocap):
    from mlayer.manifold.primitives import PrimitiveModel
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    return m, PrimitiveModel.fit([m], som=(12, 12), epochs=8, lattice=(8, 8), k="auto",
                                 ks=range(2, 9))


def test_model_fit_generate_roundtrip(walk_model, tmp_path):
    m, model = walk_model
    k = model.centers.shape[0]
    assert 2 <= k <= 8 and model.labels.max() < k
    np.testing.assert_allclose(model.markov.P.sum(1), 1.0)
    # the GRBF reproduces training poses (positions) to a fraction of the body size
    assert model.fit_error < 0.05 * np.ptp(m.positions()[:, :, 1])
    out, info = model.generate(157, start_frame=30, seed=3, return_info=True)
    assert out.n_frames == 157 and info["trajectory"].shape == (157, 2)
    np.testing.assert_allclose(np.linalg.norm(out.rot, axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(info["trajectory"][0], model.points[30], atol=0.5)
    p = tmp_path / "gen.bvh"
    mlayer.write_bvh(out, p)
    back = mlayer.read_bvh(p)
    assert back.n_frames == 157 and back.skeleton.joint_names == m.skeleton.joint_names
    again = model.generate(157, start_frame=30, seed=3)
    np.testing.assert_array_equal(again.rot, out.rot)
    # save / load gives the same generation
    model.save(tmp_path / "m.npz")
    loaded = type(model).load(tmp_path / "m.npz")
    np.testing.assert_allclose(loaded.generate(157, start_frame=30, seed=3).rot, out.rot,
                               atol=1e-12)
    # inverse mapping of training frames: their own manifold points
    np.testing.assert_array_equal(model.to_manifold(m[:50]), model.points[:50])
    # key poses: the path passes through their manifold points
    keys = mlayer.manifold.features.pose_features(m)[[100, 400, 800]]
    kout, kinfo = model.generate(90, key_poses=keys, return_info=True)
    assert kout.n_frames == 90
    np.testing.assert_allclose(kinfo["trajectory"][[0, 45, 89]].round(),
                               model.points[[100, 400, 800]], atol=1.0)


def test_model_bad_input(walk_model):
    m, model = walk_model
    with pytest.raises(InvalidArgumentError, match="out of range"):
        model.generate(100, start_frame=10 ** 6)
    # the spline and the smoothing are order-2 LGS: 2 frames failed there, after the walk
    for n in (1, 2):
        with pytest.raises(InvalidArgumentError, match="generate: frames must be an integer >= 3"):
            model.generate(n)
    assert model.generate(3, guards=False).n_frames == 3
    with pytest.raises(InvalidArgumentError, match="dimension mismatch"):
        model.to_manifold(np.zeros((2, 5)))
    with pytest.raises(InvalidArgumentError, match="primitives 0"):
        model.generate(50, start_frame=0, path=[0, 99])
    with pytest.raises(InvalidArgumentError, match="exceeds"):
        type(model).fit([m[:5]], k=6, som=(3, 3), epochs=1, lattice=(2, 2))


@requires("plot")  # (the figures of primitives, on by default)
def test_cli_primitives_generate(mocap, tmp_path, capsys):
    from mlayer.cli import main
    model = tmp_path / "model.npz"
    clip = str(mocap / "cmu_131_01_mj_style_walk.bvh")
    assert main(["primitives", clip, "-o", str(model), "--som", "10x10", "--epochs", "5",
                 "--lattice", "6x6"]) == 0
    for suffix in ("_som.png", "_elbow.png", "_transitions.png"):
        assert (tmp_path / ("model" + suffix)).stat().st_size > 1000
    out = tmp_path / "new.bvh"
    assert main(["generate", str(model), "--frames", "120", "--start-frame", "5", "-o",
                 str(out)]) == 0
    assert mlayer.read_bvh(out).n_frames == 120
    capsys.readouterr()
    assert main(["generate", str(model), "--frames", "50", "--start-frame", "99999", "-o",
                 str(tmp_path / "x.bvh")]) == 1
    assert "out of range" in capsys.readouterr().err
    assert not (tmp_path / "x.bvh").exists()
    assert main(["generate", str(model), "--frames", "2", "-o", str(tmp_path / "x.bvh")]) == 1
    assert "--frames must be >= 3, got 2" in capsys.readouterr().err
    assert not (tmp_path / "x.bvh").exists()
    assert main(["generate", str(tmp_path / "missing.npz"), "-o", str(out)]) == 1
    other = str(mocap / "cmu_10_01_soccer_kick.bvh")
    assert main(["primitives", clip, other, "-o", str(tmp_path / "y.npz")]) == 1
    assert "another skeleton" in capsys.readouterr().err


def test_generated_bandai_walk_moves_its_hips(mocap, tmp_path):
    # Bandai: a static joint_Root, the walk in the Hips channels. The model drives Hips (its
    # height, velocity and heading), so the generated hips walk at the training speed
    from mlayer.manifold.primitives import PrimitiveModel
    b = mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")
    hips = b.joint_names.index("Hips")
    model = PrimitiveModel.fit([b], som=(8, 8), epochs=8, lattice=(6, 6), k="auto",
                               ks=range(2, 7))
    assert model.body_joint == hips
    # the mapping itself (guards=False); the guards' effect is checked in test_generate_guards
    out = model.generate(150, start_frame=10, seed=1, guards=False)
    hp, tp = out.positions()[:, hips], b.positions()[:, hips]
    speed = np.linalg.norm(np.diff(hp[:, [0, 2]], axis=0), axis=1).mean()
    train = np.linalg.norm(np.diff(tp[:, [0, 2]], axis=0), axis=1).mean()
    assert 0.7 * train < speed < 1.3 * train, (speed, train)  # measured 4.43 vs 4.57 cm/frame
    travel = np.linalg.norm(hp[-1, [0, 2]] - hp[0, [0, 2]])
    assert travel > 0.5 * train * 149
    assert abs(hp[:, 1].mean() - tp[:, 1].mean()) < 0.05 * np.ptp(tp[:, 1]) + 2.0
    # the root keeps its (static) training translation; other channels their medians
    np.testing.assert_array_equal(out.root_pos, np.broadcast_to(np.median(b.root_pos, axis=0),
                                                                out.root_pos.shape))
    # save / load keeps the body joint and the generation
    model.save(tmp_path / "b.npz")
    loaded = PrimitiveModel.load(tmp_path / "b.npz")
    assert loaded.body_joint == hips
    again = loaded.generate(150, start_frame=10, seed=1, guards=False)
    np.testing.assert_allclose(again.trans, out.trans, atol=1e-9)
    np.testing.assert_allclose(again.rot, out.rot, atol=1e-12)


def test_root_clip_model_drives_the_root(walk_model):
    m, model = walk_model
    assert model.body_joint == 0
    out = model.generate(60, start_frame=30, seed=3)
    assert out.trans.shape == (60, 0, 3)
    assert np.linalg.norm(out.root_pos[-1, [0, 2]] - out.root_pos[0, [0, 2]]) > 0
