"""Primitives of issue 23: how many (elbow, silhouette, GMM BIC side by side, against
scikit-learn), what labels them (k-means, fuzzy c-means, GMM), the checks before training,
generation through map points and key frames, second likely transitions, model formats."""
import numpy as np
import pytest

import mlayer
from conftest import reference
from mlayer import InvalidArgumentError, PrimitiveModel
from mlayer.manifold.clustering import elbow_point, silhouette_score

CLIPS = [("cmu_131_01_mj_style_walk.bvh", None), ("lafan1_clip_a.bvh", 1200),
         ("bandai1_walk_happy_001.bvh", None), ("ai4a_dog_D1_008_KAN01_002.bvh", None)]
OPTS = dict(som=(10, 10), epochs=5, lattice=(6, 6))


def _clip(mocap, name, frames=None):
    path = mocap / name
    if not path.exists():
        pytest.skip(f"{name} not found")
    m = mlayer.read_bvh(path)
    return m[:frames] if frames else m


@pytest.fixture(scope="module")
def bandai(mocap):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")
    return m, PrimitiveModel.fit(m, som=(8, 8), epochs=8, lattice=(6, 6), ks=range(2, 9),
                                 names=["walk.bvh"])


@pytest.mark.parametrize("name,frames", CLIPS)
def test_criteria_match_sklearn(mocap, name, frames):
    sk_metrics = reference("sklearn.metrics", "scikit-learn")
    sk_mixture = reference("sklearn.mixture", "scikit-learn")
    m = _clip(mocap, name, frames)
    model = PrimitiveModel.fit(m, ks=range(2, 11), **OPTS)
    c, X = model.criteria, model.points
    assert list(c.ks) == list(range(2, 11))
    np.testing.assert_array_equal(model.elbow_inertia, c.inertia)
    assert c.picks["elbow"] == elbow_point(c.ks, c.inertia)[0] == model.centers.shape[0]
    assert c.picks["silhouette"] == c.ks[np.nanargmax(c.silhouette)]
    assert c.picks["bic"] == c.ks[np.nanargmin(c.bic)]
    for i, (k, r) in enumerate(zip(c.ks, c.results)):
        assert c.silhouette[i] == pytest.approx(sk_metrics.silhouette_score(X, r.labels),
                                                rel=1e-10, abs=1e-12)
        if k not in (2, 5, 8):  # scikit-learn's EM is slow on a loaded machine: three ks
            continue
        # the same EM from the same start (the k-means centres; weights and covariances of
        # the hard assignment to them, plus reg_covar): scikit-learn's GMM, its BIC
        lab = np.argmin(((X[:, None, :] - r.centers[None]) ** 2).sum(-1), axis=1)
        w0 = np.bincount(lab, minlength=k) / X.shape[0]
        cov = np.array([np.cov(X[lab == j].T, bias=True) + np.eye(2) / 12 for j in range(k)])
        g = sk_mixture.GaussianMixture(k, covariance_type="full", reg_covar=1 / 12,
                                       means_init=r.centers, weights_init=w0,
                                       precisions_init=np.linalg.inv(cov), tol=1e-3,
                                       max_iter=100).fit(X)
        assert c.bic[i] == pytest.approx(g.bic(X), rel=1e-6)


def test_silhouette_reference_and_bad_input(rng):
    sk_metrics = reference("sklearn.metrics", "scikit-learn")
    X = rng.normal(size=(300, 3))
    X[:100] += 4
    lab = (X[:, 0] > 2).astype(int) + 2 * (X[:, 1] > 0)
    assert silhouette_score(X, lab) == pytest.approx(sk_metrics.silhouette_score(X, lab),
                                                     rel=1e-12)
    Xr = np.round(X)  # repeated rows, as SOM lattice points
    assert silhouette_score(Xr, lab) == pytest.approx(sk_metrics.silhouette_score(Xr, lab),
                                                      rel=1e-12)
    with pytest.raises(InvalidArgumentError, match="clusters"):
        silhouette_score(X, np.zeros(300, int))
    with pytest.raises(InvalidArgumentError, match="labels"):
        silhouette_score(X, np.zeros(5, int))


def test_the_user_picks_the_criterion(bandai):
    m, model = bandai
    c = model.criteria
    for crit in ("silhouette", "bic"):
        other = PrimitiveModel.fit(m, som=(8, 8), epochs=8, lattice=(6, 6), ks=range(2, 9),
                                   criterion=crit)
        assert other.criterion == crit and other.centers.shape[0] == c.picks[crit]
        np.testing.assert_array_equal(other.criteria.bic, c.bic)
    # an integer k keeps its k, and the criteria are there when ks are given
    fixed = PrimitiveModel.fit(m, som=(8, 8), epochs=8, lattice=(6, 6), k=5, ks=range(2, 9))
    assert fixed.centers.shape[0] == 5 and fixed.criteria is not None
    assert PrimitiveModel.fit(m, som=(8, 8), epochs=2, lattice=(6, 6), k=3).criteria is None


@pytest.mark.parametrize("cluster", ["fcm", "gmm"])
def test_soft_clusterings_drive_the_labels(bandai, cluster):
    from mlayer.manifold.mixture import GaussianMixture, fuzzy_cmeans
    m, ref = bandai
    k = ref.centers.shape[0]
    model = PrimitiveModel.fit(m, som=(8, 8), epochs=8, lattice=(6, 6), k=k, cluster=cluster)
    np.testing.assert_array_equal(model.points, ref.points)
    init = mlayer.kmeans(ref.points, k, seed=0, n_init=3).centers
    if cluster == "fcm":
        f = fuzzy_cmeans(ref.points, k, init=init)
        labels, centers = f.labels, f.centers
    else:
        g = GaussianMixture(k, init=init, reg_covar=1 / 12).fit(ref.points)
        labels, centers = g.predict(ref.points), g.means_
    used = np.unique(labels)
    np.testing.assert_array_equal(model.labels, np.searchsorted(used, labels))
    np.testing.assert_allclose(model.centers, centers[used])
    # the Markov model counts these labels
    C = np.zeros((used.size, used.size))
    np.add.at(C, (model.labels[:-1], model.labels[1:]), 1)
    np.testing.assert_array_equal(model.markov.counts, C)
    assert model.cluster == cluster
    assert model.generate(80, start_frame=5, seed=1, guards=False).n_frames == 80


def test_primitives_on_the_pose_features(bandai, tmp_path):
    """cluster_on="features": k-means (and the k criteria) on the pose features instead of
    the map's 2-D points; each primitive's centre on the map is its frames' mean point."""
    from mlayer.manifold.features import pose_features
    from mlayer.manifold.mixture import k_criteria
    from sklearn.cluster import KMeans
    from sklearn.metrics import adjusted_rand_score
    m, ref = bandai
    assert ref.cluster_on == "manifold"
    model = PrimitiveModel.fit(m, som=(8, 8), epochs=8, lattice=(6, 6), ks=range(2, 9),
                               cluster_on="features")
    X = pose_features(m)
    np.testing.assert_array_equal(model.points, ref.points)
    c = k_criteria(X, range(2, 9), seed=0, n_init=3,
                   reg_covar=1e-6 * float(X.var(axis=0).max()))
    np.testing.assert_array_equal(model.criteria.inertia, c.inertia)
    k = c.picks["elbow"]
    km = mlayer.kmeans(X, k, seed=0, n_init=3)
    used = np.unique(km.labels)
    np.testing.assert_array_equal(model.labels, np.searchsorted(used, km.labels))
    for i, u in enumerate(used):
        np.testing.assert_allclose(model.centers[i], ref.points[km.labels == u].mean(axis=0))
    # a peer's k-means on the same features finds the same partition
    sk = KMeans(k, n_init=10, random_state=0).fit(X)
    assert adjusted_rand_score(sk.labels_, model.labels) > 0.9
    assert model.cluster_on == "features"
    model.save(tmp_path / "f.npz")
    assert PrimitiveModel.load(tmp_path / "f.npz").cluster_on == "features"
    with pytest.raises(InvalidArgumentError, match="cluster_on"):
        PrimitiveModel.fit(m, k=3, cluster_on="pose")


def test_arguments_are_checked_before_training(mocap, monkeypatch):
    m = _clip(mocap, "bandai1_walk_happy_001.bvh")
    import mlayer.manifold.som

    def no_training(*a, **k):
        raise AssertionError("the SOM trained before the arguments were checked")
    monkeypatch.setattr(mlayer.manifold.som.SOM, "train", no_training)
    cases = [
        (dict(k=10, som=(3, 3), lattice=(2, 2)), r"option k = 10 exceeds the SOM's 3x3 = 9 units"),
        (dict(k=300, som=(30, 30), lattice=(4, 4)), r"k = 300 exceeds the number of training "
                                                     r"frames \(213\)"),
        (dict(ks=range(20, 30), som=(4, 4), lattice=(2, 2)), "every candidate k exceeds"),
        (dict(ks=range(2, 901), som=(4, 4), lattice=(2, 2)),
         r"option ks = 2\.\.900 exceeds the SOM's 4x4 = 16 units .*: give candidates up to 16 "
         r"\(such as 2\.\.16\)"),
        (dict(k=3, ks=[2, 5, 400], som=(4, 4), lattice=(2, 2)),
         r"option ks = 2, 5, 400 exceeds the SOM's"),
        (dict(k=3, som=(8, 8), lattice=(16, 16)), r"lattice 16x16 = 256 GRBF centres exceeds"),
        (dict(k=3, som=(8, 8), lattice=(4, 4), criterion="gap"), "criterion"),
        (dict(k=3, som=(8, 8), lattice=(4, 4), cluster="dbscan"), "cluster"),
        (dict(k=3, som=(8, 8), lattice=(4, 4), order=0), "order must be an integer in 1 .. 3"),
        (dict(k=3, som=(8, 8), lattice=(4, 4), order=4), "order"),
        (dict(k=3, som=(8, 8), lattice=(4, 4), min_count=0), "min_count"),
        (dict(k=3, som=(8, 8), lattice=(4, 4), names=["a", "b"]), "names"),
    ]
    for kw, text in cases:
        with pytest.raises(InvalidArgumentError, match=text):
            PrimitiveModel.fit(m, **kw)


def test_generate_through_points_of_the_map(bandai):
    m, model = bandai
    pts = np.array([[1.0, 1.0], [6.0, 3.0], [2.0, 6.5], [5.0, 5.0]])
    out, info = model.generate(121, through=pts, return_info=True)
    assert out.n_frames == 121 and np.isfinite(out.rot).all()
    arc = np.r_[0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    t = arc * 120 / arc[-1]
    np.testing.assert_allclose(info["times"], t)
    traj = info["trajectory"]
    for p, ti in zip(pts, t):
        assert np.linalg.norm(traj[int(round(ti))] - p) < 0.35
    # the motion is the mapping of that path (the guards only adjust it)
    raw = model.generate(121, through=pts, guards=False)
    np.testing.assert_allclose(raw.rot, model.motion_along(traj).rot, atol=1e-12)
    cases = [
        (dict(through=[[1.0, 1.0], [8.5, 3.0]]), r"point 1 \(row 8.5, column 3\) is outside "
                                                  r"the map \(rows 0 .. 7, columns 0 .. 7\)"),
        (dict(through=[[1.0, -0.5]]), "outside the map"),
        (dict(through=[[1.0, np.nan]]), "finite"),
        (dict(through=[[1.0, 2.0], [1.0, 2.0]]), "the same"),
        (dict(through=np.zeros((3, 3))), r"through: need points \(K, 2\)"),
        (dict(through=[[1, 1]], keys=[(0, 1)]), "exclude each other"),
    ]
    for kw, text in cases:
        with pytest.raises(InvalidArgumentError, match=text):
            model.generate(50, **kw)


def test_generate_through_key_frames(bandai):
    m, model = bandai
    keys = [("walk.bvh", 10), (0, 100), (m, 200)]  # by name, by index, from a Motion
    out, info = model.generate(90, keys=keys, return_info=True)
    want = model.points[[10, 100, 200]]
    np.testing.assert_array_equal(info["knots"], want)
    np.testing.assert_allclose(info["trajectory"][[0, 45, 89]], want, atol=0.35)
    cases = [
        (dict(keys=[(0, 213)]), r"frame 213 is beyond clip 0 \(213 frames, 0 .. 212\)"),
        (dict(keys=[("run.bvh", 3)]), r"no training clip 'run.bvh'"),
        (dict(keys=[(1, 3)]), r"clip index 1 out of range"),
        (dict(keys=[(0, -1)]), "frame must be an integer >= 0"),
        (dict(keys=[(m, 999)]), "beyond the key clip"),
        (dict(keys=[]), "keys"),
        (dict(keys=[(0, 1, 2)]), "pair"),
    ]
    for kw, text in cases:
        with pytest.raises(InvalidArgumentError, match=text):
            model.generate(50, **kw)


def test_keys_from_another_skeleton(bandai, mocap):
    m, model = bandai
    cmu = _clip(mocap, "cmu_131_01_mj_style_walk.bvh")
    with pytest.raises(InvalidArgumentError, match="another skeleton"):
        model.generate(50, keys=[(cmu, 3)])


def test_most_and_second_likely_paths(bandai):
    m, model = bandai
    mk = model.markov
    for rank, kw in ((1, dict(most_likely=True)), (2, dict(second_likely=True))):
        seq = model.primitive_path(int(model.labels[5]), 300, **kw)
        assert len(seq) > 3
        for a, b in zip(seq[:-1], seq[1:]):
            assert b == mk.ranked_next([a], rank)
            p = mk.jump_matrix()[a].copy()
            p[a] = -1
            assert p[b] == np.sort(p)[::-1][min(rank, int((p > 0).sum())) - 1]
        # noise -> 0: the same chain; paper Figure 3 (d): a perturbed chain's path differs
        np.testing.assert_array_equal(model.primitive_path(int(seq[0]), 300, noise=1e-9,
                                                           seed=4, **kw), seq)
    # this walk's jumps form one cycle (each primitive has one successor): noise cannot open
    # transitions never seen, so the most likely path stays; allow_unseen opens them
    paths = {tuple(model.primitive_path(0, 300, most_likely=True, noise=1.0, seed=s))
             for s in range(12)}
    assert (mk.jump_matrix() > 0).sum(1).max() > 1 or len(paths) == 1
    opened = {tuple(model.primitive_path(0, 300, most_likely=True, noise=5.0, seed=s,
                                         allow_unseen=True)) for s in range(30)}
    assert len(opened) > 1
    with pytest.raises(InvalidArgumentError, match="exclude each other"):
        model.generate(50, most_likely=True, second_likely=True)


def test_higher_order_model_generates_and_round_trips(bandai, tmp_path):
    m, _ = bandai
    model = PrimitiveModel.fit(m, som=(8, 8), epochs=8, lattice=(6, 6), k=6, order=3,
                               min_count=2)
    assert model.markov.order == 3 and model.markov.contexts
    seq = model.primitive_path(int(model.labels[0]), 400, seed=3)
    # every step is possible under the back-off distribution of its history
    for t in range(1, len(seq)):
        assert model.markov.next_distribution(seq[max(0, t - 3):t])[seq[t]] > 0
    model.save(tmp_path / "o3.npz")
    back = PrimitiveModel.load(tmp_path / "o3.npz")
    assert back.markov.order == 3 and back.markov.min_count == 2
    assert back.markov.contexts.keys() == model.markov.contexts.keys()
    for key, (cnt, row) in model.markov.contexts.items():
        assert back.markov.contexts[key][0] == cnt
        np.testing.assert_allclose(back.markov.contexts[key][1], row)
    assert back.order_loglik == model.order_loglik and back.clip_names == model.clip_names
    np.testing.assert_array_equal(back.criteria.bic if back.criteria else [], [])
    np.testing.assert_allclose(back.generate(100, start_frame=4, seed=2, noise=0.1).rot,
                               model.generate(100, start_frame=4, seed=2, noise=0.1).rot,
                               atol=1e-12)


def test_format_1_models_load_as_order_1(bandai, tmp_path):
    m, model = bandai
    model.save(tmp_path / "new.npz")
    z = dict(np.load(tmp_path / "new.npz"))
    for key in [k for k in z if k.startswith(("markov_", "crit_")) or k in
                ("criterion", "cluster", "clip_names", "order_loglik")]:
        del z[key]
    z["format"] = np.int64(1)
    np.savez(tmp_path / "old.npz", **z)
    old = PrimitiveModel.load(tmp_path / "old.npz")
    assert old.markov.order == 1 and old.clip_names == ["0"] and old.criteria is None
    np.testing.assert_array_equal(old.markov.P, model.markov.P)
    np.testing.assert_allclose(old.generate(100, start_frame=4, seed=2).rot,
                               model.generate(100, start_frame=4, seed=2).rot, atol=1e-12)
    # keys by index work on old files; the criteria of the new file came back
    assert old.generate(40, keys=[(0, 5), (0, 50)]).n_frames == 40
    back = PrimitiveModel.load(tmp_path / "new.npz")
    np.testing.assert_array_equal(back.criteria.bic, model.criteria.bic)
    assert back.criteria.picks == model.criteria.picks
    z["format"] = np.int64(7)
    np.savez(tmp_path / "future.npz", **z)
    with pytest.raises(mlayer.MlayerIOError, match="model format 7"):
        PrimitiveModel.load(tmp_path / "future.npz")
