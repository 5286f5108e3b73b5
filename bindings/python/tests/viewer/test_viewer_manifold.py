"""The viewer's motion manifold without a browser (mlayer.viewer.manifold and its endpoints):
training on request, the map data against the model, motions by lattice points, key frames and
start frames against PrimitiveModel's own functions, the BVH download, bad input. The browser
side is in test_viewer_browser.py."""
import base64
import json

import numpy as np
import pytest

import mlayer
from mlayer.manifold.features import pose_features
from mlayer.manifold.markov import Markov
from mlayer.guards.metrics import body_height
from mlayer.manifold.som import u_matrix
from mlayer.viewer.manifold import ManifoldSession, ranked_chain, ranked_cycle, ranked_next
from mlayer.viewer.session import ResultCache, load_clips

from test_viewer import bad_clip, get, get_json, server  # noqa: F401 (fixtures)

WALK = "cmu_131_01_mj_style_walk.bvh"
TRAIN_FRAMES = 300   # the walk's 994 frames at every 4th: 249 training frames


@pytest.fixture(scope="module")
def trained(server):
    # test_viewer's server (the walk, a broken clip, Bandai), its manifold on a few hundred
    # frames
    server.manifold.max_frames = TRAIN_FRAMES
    server.manifold.plan()
    before = get_json(server, "/api/manifold")
    assert before["state"] == "idle" and before["steps"] == []
    # a motion before the training: 409 with what to do
    status, _, body = get(server, "/api/manifold/motion?points=1,1")
    assert status == 409 and "train=1" in json.loads(body)["error"]
    d = get_json(server, "/api/manifold?train=1")
    assert d["state"] in ("training", "ready")
    assert server.manifold.wait(120) == "ready", server.manifold.error
    return get_json(server, "/api/manifold")


def f32(b64, shape):
    return np.frombuffer(base64.b64decode(b64), dtype=np.float32).reshape(shape)


def motion_json(srv, query, expect=200):
    d = get_json(srv, "/api/manifold/motion?" + query, expect)
    if expect == 200:
        d["pos"] = f32(d["positions"], (d["frames"], d["n_points"], 3))
    return d


# ---- the chains (paper Figure 3 (c)) ----------------------------------------------------------

def test_ranked_next_against_a_sorted_row():
    P = np.array([[0.5, 0.1, 0.3, 0.1], [0.2, 0.6, 0.2, 0.0], [0.0, 0.05, 0.9, 0.05],
                  [0.25, 0.25, 0.25, 0.25]])
    mk = Markov(P)
    for j in range(4):
        assert ranked_next(P, j, 1) == mk.most_likely_next(j)
    assert [ranked_next(P, j, 2) for j in range(4)] == [1, 2, 3, 1]  # ties: lowest index
    assert [ranked_next(P, j, 3) for j in range(4)] == [3, 3, 0, 2]
    assert ranked_next(P, 0, 9) == 3            # fewer others than the rank: the last of them
    assert ranked_next(np.ones((1, 1)), 0, 2) == -1
    assert ranked_cycle(P, 0, 1) == [0, 2, 1, 0]
    assert ranked_cycle(P, 0, 2) == [0, 1, 2, 3, 1]
    np.testing.assert_array_equal(ranked_cycle(P, 1, 1), mk.most_likely_path(1))


def test_u_matrix_against_a_loop():
    w = np.random.default_rng(3).normal(size=(4, 5, 3))
    u = u_matrix(w)
    for r in range(4):
        for c in range(5):
            nb = [(r + dr, c + dc) for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1))
                  if 0 <= r + dr < 4 and 0 <= c + dc < 5]
            want = np.mean([np.linalg.norm(w[r, c] - w[a, b]) for a, b in nb])
            assert u[r, c] == pytest.approx(want, rel=1e-12)


# ---- training and the map ----------------------------------------------------------------------

def test_training_set_is_bounded_and_one_skeleton(server, trained, mocap):
    d = trained
    md = server.manifold.model
    walk = mlayer.read_bvh(mocap / WALK)
    assert d["stride"] == 4 and d["frames"] == len(range(0, walk.n_frames, 4)) <= TRAIN_FRAMES
    assert d["clips"] == [0]
    assert [(e["clip"], "another skeleton" in e["reason"]) for e in d["excluded"]] == [(2, True)]
    assert md.points.shape[0] == d["frames"]
    assert any(s.startswith("SOM:") for s in d["steps"]) and d["progress"] == 1.0
    # the model is kept: asking again does not train again
    assert get_json(server, "/api/manifold?train=1")["seconds"] == d["seconds"]


def test_map_data_is_the_models(server, trained):
    d = trained
    md = server.manifold.model
    rows, cols, _ = md.som_codebook.shape
    assert (d["rows"], d["cols"], d["k"]) == (rows, cols, md.centers.shape[0])
    u = np.array(d["umatrix"]).reshape(rows, cols)
    ref = u_matrix(md.som_codebook)
    np.testing.assert_allclose(u, (ref - ref.min()) / (ref.max() - ref.min()), atol=1e-12)
    # each unit's primitive: the nearest centre, as k-means labels the training frames
    regions = np.array(d["regions"]).reshape(rows, cols)
    pts = np.rint(md.points).astype(int)
    np.testing.assert_array_equal(regions[pts[:, 0], pts[:, 1]], md.labels)
    np.testing.assert_allclose(d["P"], md.markov.P)
    np.testing.assert_allclose(np.array(d["P"]).sum(1), 1.0)
    (t,) = d["trajectories"]
    np.testing.assert_array_equal(t["points"], md.points)
    for j in range(d["k"]):
        assert d["cycles"]["most"][j] == list(md.markov.most_likely_path(j))


def test_key_poses_are_the_poses_at_the_centres(server, trained):
    """The key-pose column's data (paper Figures 2 (b) and 5): each primitive's pose is the
    GRBF's rotations at its centre, root at (0, height, 0), no heading; forward kinematics of
    the Motion built here from the model's raw outputs."""
    d = trained
    md = server.manifold.model
    sk = md.skeleton
    k, n_pts = d["k"], d["n_points"]
    kp = f32(d["key_poses"], (k, n_pts, 3))
    assert len(d["parents"]) == len(d["sides"]) == n_pts == sk.n_joints + sk.n_end_sites
    assert d["parents"][:sk.n_joints] == [int(p) for p in sk.parents]
    out = md.predict(md.centers)
    assert md.body_joint == 0  # the walk's root is its body
    for j in range(k):
        root = np.array([[0.0, out["height"][j], 0.0]])
        ref = mlayer.Motion(sk, md.frame_time, root, out["rot"][j:j + 1]).positions()[0]
        h = np.ptp(ref[:, 1])
        np.testing.assert_allclose(kp[j, :sk.n_joints], ref, atol=1e-5 * h)
    # the poses differ from one primitive to the next, and the scale is the tallest
    assert min(np.abs(kp[a] - kp[b]).max() for a in range(k) for b in range(a)) > 1e-3 * h
    assert d["height"] == pytest.approx(np.ptp(kp[..., 1], axis=1).max(), rel=1e-6)


@pytest.mark.parametrize("query", ["points=1,1;12.5,13&frames=80", "keys=0:20,0:600",
                                   "start=0:400&chain=most&frames=80"])
def test_memberships_of_each_frame(server, trained, query):
    """Each frame's fuzzy membership (m = 2) in the primitives and its largest (the colour bar
    under the pose strip, paper Figures 6 and 7), against scipy's distances to the centres;
    the knots' frames (the poses on the map, Figure 4)."""
    from scipy.spatial.distance import cdist
    md = server.manifold.model
    d = motion_json(server, query)
    k = md.centers.shape[0]
    assert d["k"] == k
    u = f32(d["memberships"], (d["frames"], k))
    traj = np.array(d["trajectory"])
    d2 = cdist(traj, md.centers, "sqeuclidean")
    assert d2.min() > 0  # no frame exactly on a centre here
    want = (1.0 / d2) / (1.0 / d2).sum(axis=1, keepdims=True)
    np.testing.assert_allclose(u, want, atol=2e-7)
    np.testing.assert_array_equal(d["membership"], np.argmin(d2, axis=1))
    assert len(set(d["membership"])) >= 2  # the path crosses primitives
    t = np.array(d["knot_times"])
    assert len(t) == len(d["knots"]) and t[0] == 0 and t[-1] == d["frames"] - 1
    assert np.all(np.diff(t) > 0)
    # the knots are where the trajectory is at their times
    for ti, kn in zip(t, d["knots"]):
        if float(ti).is_integer():
            assert np.linalg.norm(traj[int(ti)] - md.clamp(np.array([kn]))[0]) < 0.1


# ---- motions -----------------------------------------------------------------------------------

def test_points_spline_motion_and_download(server, trained, mocap):
    md = server.manifold.model
    q = "points=1,1;12.5,13;3,8&frames=90"
    d = motion_json(server, q)
    assert d["kind"] == "points" and d["frames"] == 90
    traj = np.array(d["trajectory"])
    knots = np.array([[1, 1], [12.5, 13], [3, 8]], dtype=float)
    np.testing.assert_allclose(d["knots"], knots)
    # the spline starts and ends at the first and last point, by chord-length knot times
    chord = np.r_[0, np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))]
    times = chord / chord[-1] * 89
    np.testing.assert_allclose(traj, md.clamp(md.spline(knots, times, 90)))
    assert np.abs(traj[[0, -1]] - knots[[0, -1]]).max() < 0.1
    # the figure is the model's mapping along it, guarded
    ref, _, _ = md.guard(md.motion_along(traj), traj)
    h = body_height(ref)
    fig = d["pos"][:, :ref.n_joints]
    np.testing.assert_allclose(fig, ref.positions(), atol=1e-4 * h)
    assert np.linalg.norm(fig[0] - fig[-1], axis=1).max() > 0.05 * h   # it moves
    # the download: the same motion as BVH, the requested frames
    status, headers, body = get(server, "/api/manifold/download?" + q)
    assert status == 200
    assert headers["Content-Disposition"] == 'attachment; filename="manifold_points.bvh"'
    got = mlayer.read_bvh_string(body.decode(), "manifold_points.bvh")
    assert got.n_frames == 90 and got.joint_names == ref.joint_names
    np.testing.assert_allclose(got.positions(), fig, atol=1e-3 * h)
    # without guards: the raw mapping
    raw = motion_json(server, q + "&guards=0")
    np.testing.assert_allclose(raw["pos"][:, :ref.n_joints], md.motion_along(traj).positions(),
                               atol=1e-4 * h)


def test_one_point_is_a_still_pose(server, trained):
    d = motion_json(server, "points=7,7&frames=10&guards=0")
    assert d["frames"] == 10
    np.testing.assert_allclose(np.array(d["trajectory"]), 7.0)


def test_key_frames_go_through_their_bmus(server, trained, mocap):
    md = server.manifold.model
    walk = mlayer.read_bvh(mocap / WALK)
    keys = [10, 480, 950]
    d = motion_json(server, "keys=" + ",".join(f"0:{k}" for k in keys) + "&frames=100")
    bmus = md.to_manifold(pose_features(walk)[keys])
    np.testing.assert_allclose(d["knots"], bmus)
    traj = np.array(d["trajectory"])
    assert np.abs(traj[[0, 50, 99]] - bmus).max() < 0.6
    assert d["frames"] == 100


@pytest.mark.parametrize("chain, rank", [("most", 1), ("second", 2)])
def test_start_frame_with_the_ranked_chain(server, trained, chain, rank):
    md = server.manifold.model
    d = motion_json(server, f"start=0:400&chain={chain}&frames=120")
    tf = d["start_training_frame"]
    assert tf == 100  # frame 400 at the stride 4
    path = ranked_chain(md.markov, int(md.labels[tf]), 120, rank)
    if rank == 1:
        np.testing.assert_array_equal(path, md.primitive_path(int(md.labels[tf]), 120,
                                                              most_likely=True))
    ref, info = md.generate(120, start_frame=tf, path=path, return_info=True)
    assert d["primitives"] == list(info["primitives"])
    np.testing.assert_allclose(d["pos"][:, :ref.n_joints], ref.positions(),
                               atol=1e-4 * body_height(ref))
    # noise perturbs the matrix the chain follows, seeded
    n1 = motion_json(server, f"start=0:400&chain={chain}&noise=0.3&seed=1")
    pert = md.markov.perturbed(0.3, 1)
    assert n1["primitives"] == list(ranked_chain(pert, int(md.labels[tf]), 120, rank))


def test_start_frame_sampled(server, trained):
    md = server.manifold.model
    d = motion_json(server, "start=0:40&chain=sample&noise=0.05&seed=3&frames=80")
    _, info = md.generate(80, start_frame=10, noise=0.05, seed=3, return_info=True)
    assert d["primitives"] == list(info["primitives"])
    again = motion_json(server, "start=0:40&chain=sample&noise=0.05&seed=3&frames=80")
    # the documented maximum seed is taken (10 digits were refused before, issue 39)
    motion_json(server, "start=0:40&chain=sample&noise=0.05&seed=2147483647&frames=80")
    np.testing.assert_array_equal(again["pos"], d["pos"])


@pytest.mark.parametrize("query, status, words", [
    ("points=20,1", 400, "point 1 (20, 1) is outside the map: rows 0 to 14"),
    ("points=1,1;3,-0.5", 400, "point 2 (3, -0.5) is outside the map"),
    ("points=1,nan", 400, "finite"), ("points=1", 400, "expected ROW,COL"),
    ("points=", 400, "1 to 64 lattice points"),
    ("points=" + ";".join(["1,1"] * 65), 400, "1 to 64"),
    ("keys=0:994", 400, "key 1: frame 994 is beyond clip 0"),
    ("keys=0:5,0:99999", 400, "key 2: frame 99999 is beyond clip 0"),
    ("keys=2:5", 400, "clip 2 is not on the manifold (another skeleton"),
    ("keys=1:5", 400, "clip 1 is not on the manifold (it failed to load)"),
    ("keys=7:5", 400, "no clip 7"), ("keys=0-5", 400, "expected CLIP:FRAME"),
    ("start=0:2000", 400, "start: frame 2000 is beyond clip 0"),
    ("start=0:1&chain=best", 400, "chain must be one of most, second, sample"),
    ("start=0:1&noise=-1", 400, "noise must be in [0, 10]"),
    ("start=0:1&noise=inf", 400, "finite"), ("start=0:1&seed=x", 400, "seed"),
    ("start=0:1&seed=2147483648", 400, "seed must be in 0..2147483647"),
    ("start=0:1&seed=%C2%B2", 400, "seed must be a non-negative integer"),
    ("start=0:1,0:2", 400, "one CLIP:FRAME"), ("points=1,1&noise=0.1", 400, "start= only"),
    ("points=1,1&keys=0:1", 400, "exactly one of"), ("frames=10", 400, "exactly one of"),
    ("points=1,1&frames=1", 400, "frames must be in 3..5000"),
    ("points=1,1;5,5&frames=2", 400, "frames must be in 3..5000"),  # was a 400 from the LGS
    ("points=1,1&frames=-3", 400, "non-negative integer"),
    ("points=1,1&guards=2", 400, "guards must be"), ("points=1,1&path=/etc", 400, "unknown"),
    ("points=1,1&points=2,2", 400, "twice"),
    ("points=1,1;1,2;1,3;1,4;1,5;1,6&frames=5", 400, "more than 5 frames"),
    ("keys=0:1,0:2,0:3,0:4&frames=3", 400, "at least as many frames"),
])
def test_bad_motion_requests(server, trained, query, status, words):
    for path in ("/api/manifold/motion?", "/api/manifold/download?"):
        got, _, body = get(server, path + query)
        assert got == status, body[:300]
        assert words in json.loads(body)["error"]


def test_manifold_endpoint_checks(server, trained):
    assert get(server, "/api/manifold?train=2")[0] == 400
    assert get(server, "/api/manifold?train=1", token=False)[0] == 403
    assert get(server, "/api/manifold/motion?points=1,1", token=False)[0] == 403


def test_output_cap_and_training_cap(mocap):
    """frames x points over max_values: 413 before any work; the training frames within it."""
    clips = load_clips([mocap / WALK])
    s = ManifoldSession(clips, cache=ResultCache(), max_values=1000, max_frames=TRAIN_FRAMES)
    pts = clips[0].n_points
    assert s.stride == -(-994 // (1000 // pts))
    s.start()
    assert s.wait(60) == "ready", s.error
    assert s.model.points.shape[0] * pts <= 1000
    from mlayer.viewer.session import ParamError
    with pytest.raises(ParamError) as e:
        s.parse(f"points=1,1&frames={1000 // pts + 1}")
    assert e.value.status == 413 and "--max-values" in str(e.value)
    assert s.parse(f"points=1,1&frames={1000 // pts}")["frames"] == 1000 // pts


def test_no_clip_to_learn(tmp_path):
    bad = tmp_path / "x.bvh"
    bad.write_text("nothing\n")
    s = ManifoldSession(load_clips([bad]), cache=ResultCache(), max_values=10**6)
    d = json.loads(s.status(start=True))
    assert d["state"] == "failed" and "no clip to learn the manifold from" in d["error"]
