"""mlayer.Stream / stream_motion: the fixed-lag smoother through Python.

References: a dense numpy solve of each prefix (small synthetic clips), and the offline
mlayer.lgs on the real clips' channels with the quaternions made continuous by the predictive
rule (quat.continuous(predictive=True)), renormalized.
"""
import numpy as np
import pytest

import mlayer
from mlayer.pipeline.stream import Frame, decay_rate, motion_channels

CLIPS = ["cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh",
         "cmu_10_01_soccer_kick.bvh", "cmu_60_10_salsa_dance.bvh",
         "cmu_02_03_run_jog_25fps.bvh", "lafan1_clip_a.bvh", "bandai1_walk_happy_001.bvh",
         "ai4a_dog_D1_008_KAN01_002.bvh"]


def offline(m, lam, sigma):
    """mlayer.lgs on [root][trans][rot] with predictive-aligned quaternions, renormalized."""
    N, J = m.n_frames, m.n_joints
    q = mlayer.quat.continuous(m.rot, predictive=True)
    y = np.concatenate([m.root_pos, m.trans.reshape(N, -1), q.reshape(N, -1)], axis=1)
    x = mlayer.lgs(y, lam, sigma)
    qx = x[:, -4 * J:].reshape(N, J, 4)
    qx /= np.linalg.norm(qx, axis=-1, keepdims=True)
    return x


def gap(m, a, b):
    """Largest gap: translations relative to the clip's size, quaternion components absolute."""
    nt = a.shape[1] - 4 * m.n_joints
    y = motion_channels(m)[:, :nt]
    size = (y.max(axis=0) - y.min(axis=0)).max()
    return max(np.abs(a[:, :nt] - b[:, :nt]).max() / size, np.abs(a[:, nt:] - b[:, nt:]).max())


def dense_prefix(y, s):
    """(s D^T D + I) x = y by a dense solve, D the second difference."""
    n = len(y)
    D = np.diff(np.eye(n), 2, axis=0)
    return np.linalg.solve(s * D.T @ D + np.eye(n), y)


@pytest.fixture(scope="module")
def walk(mocap):
    return mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")


def small_skeleton(J=3):
    return mlayer.Skeleton(["r"] + [f"j{k}" for k in range(1, J)], [-1] + list(range(J - 1)),
                           np.ones((J, 3)))


def random_frames(rng, N, J):
    root = np.cumsum(rng.normal(size=(N, 3)), axis=0)
    q = mlayer.quat.normalize(np.array([1.0, 0, 0, 0]) + 0.3 * rng.normal(size=(N, J, 4)))
    return root, q


# ---- numerics --------------------------------------------------------------------------------

@pytest.mark.parametrize("lag", [0, 1, 3, 7])
def test_every_output_is_the_prefix_solve(rng, lag):
    """Each pushed output is frame n-1-lag of the dense solve of the n frames so far (root
    translations: no renormalization); the flush is the tail of the whole clip's solve."""
    N, lam, sigma = 25, 2.0, 0.8
    sk = small_skeleton(2)
    root, q = random_frames(rng, N, 2)
    st = mlayer.Stream(sk, lam=lam, sigma=sigma, lag=lag)
    for n in range(1, N + 1):
        out = st.push((root[n - 1], q[n - 1]))
        assert (out is None) == (n <= lag)
        if out is not None:
            ref = dense_prefix(root[:n], (lam * sigma) ** 2)[n - 1 - lag]
            np.testing.assert_allclose(out.root_pos, ref, rtol=0, atol=1e-10 * np.abs(root).max())
    tail = st.flush()
    assert tail.root_pos.shape == (min(lag, N), 3)
    ref = dense_prefix(root, (lam * sigma) ** 2)
    np.testing.assert_allclose(tail.root_pos, ref[N - len(tail.root_pos):], rtol=0,
                               atol=1e-10 * np.abs(root).max())


@pytest.mark.parametrize("clip", CLIPS)
def test_gap_to_offline_shrinks_with_lag(mocap, clip):
    """On every real clip the streamed motion's gap to the offline solve is below
    decay_rate ** lag (it shrinks geometrically), for a light and a strong smoothing."""
    m = mlayer.read_bvh(mocap / clip)
    for lam, sigma in ((1.0, 1.0), (4.0, 1.0)):
        rho = decay_rate(lam, sigma)
        ref = offline(m, lam, sigma)
        gaps = []
        for lag in (0, 5, 10, 20):
            x = motion_channels(mlayer.stream_motion(m, lam=lam, sigma=sigma, lag=lag))
            gaps.append(gap(m, x, ref))
            assert gaps[-1] <= rho ** lag + 1e-12, (lam, sigma, lag, gaps[-1], rho ** lag)
        assert gaps == sorted(gaps, reverse=True)


@pytest.mark.parametrize("clip", CLIPS)
def test_flushed_tail_equals_offline(mocap, clip):
    """lag >= N: every frame comes from the flush, the offline solve to 1e-9; lag 40: the
    flushed 40 frames are exact too."""
    m = mlayer.read_bvh(mocap / clip)
    N, lam, sigma = m.n_frames, 3.0, 0.5
    ref = offline(m, lam, sigma)
    x = motion_channels(mlayer.stream_motion(m, lam=lam, sigma=sigma, lag=N))
    assert gap(m, x, ref) <= 1e-9
    st = mlayer.Stream(m, lam=lam, sigma=sigma, lag=40)
    y = motion_channels(m)
    outs = [st.push(row) for row in y]
    assert all(o is None for o in outs[:40]) and all(o is not None for o in outs[40:])
    tail = st.flush()
    assert tail.shape == (40, y.shape[1])
    assert gap(m, tail, ref[N - 40:]) <= 1e-9


def test_signs_follow_the_predictive_rule(rng):
    """A spin reaching 250 degrees per frame with random input signs: with lam 0 the stream
    returns its aligned input, which equals quat.continuous(predictive=True) (and not the
    nearest-sign rule, which turns the spin back)."""
    N, J = 150, 2
    w = np.minimum(np.radians(20.0) + np.radians(6.0) * np.arange(N), np.radians(250.0))
    th = np.cumsum(w)
    axis = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    q = np.concatenate([np.cos(th / 2)[:, None, None].repeat(J, 1),
                        np.sin(th / 2)[:, None, None] * axis[None]], axis=-1)
    q *= rng.choice([-1.0, 1.0], size=(N, J, 1))
    root = np.zeros((N, 3))
    st = mlayer.Stream(small_skeleton(J), lam=0.0, sigma=1.0, lag=0)
    out = np.array([st.push((root[f], q[f])).rot for f in range(N)])
    pred = mlayer.quat.continuous(q, predictive=True)
    near = mlayer.quat.continuous(q)
    np.testing.assert_allclose(out, pred, rtol=0, atol=1e-15)
    assert (np.einsum("fjc,fjc->fj", pred, near) < 0).sum() > N // 4


def test_output_forms_agree(walk):
    """A (root, rot) tuple, a one-frame Motion and a flat array give the same numbers, each
    back in its own form; stream_motion is the push loop plus flush."""
    lag, n = 6, 40
    m = walk[:n]
    s1, s2, s3 = (mlayer.Stream(walk, lam=2.0, sigma=0.5, lag=lag) for _ in range(3))
    y = motion_channels(m)
    rows = []
    for f in range(n):
        a = s1.push((m.root_pos[f], m.rot[f]))
        b = s2.push(m[f])
        c = s3.push(y[f])
        if f < lag:
            assert a is None and b is None and c is None
            continue
        assert isinstance(a, Frame) and a.rot.shape == (m.n_joints, 4) and a.trans.shape == (0, 3)
        assert isinstance(b, mlayer.Motion) and b.n_frames == 1 and b.frame_time == m.frame_time
        assert isinstance(c, np.ndarray) and c.shape == (s3.frame_size,)
        np.testing.assert_array_equal(a.root_pos, c[:3])
        np.testing.assert_array_equal(a.rot.ravel(), c[3:])
        np.testing.assert_array_equal(b.rot[0], a.rot)
        rows.append(c)
    t1, t2, t3 = s1.flush(), s2.flush(), s3.flush()
    assert t1.rot.shape == (lag, m.n_joints, 4) and t2.n_frames == lag and t3.shape[0] == lag
    np.testing.assert_array_equal(t1.rot, t2.rot)
    whole = motion_channels(mlayer.stream_motion(m, lam=2.0, sigma=0.5, lag=lag))
    np.testing.assert_array_equal(whole, np.vstack(rows + [t3]))


def test_extra_translations(mocap):
    """The Bandai clip has position channels on every joint: (root, rot, trans) frames; trans
    left out means the OFFSETs."""
    m = mlayer.read_bvh(mocap / "bandai1_walk_happy_001.bvh")[:30]
    P = m.trans.shape[1]
    assert P > 0
    st = mlayer.Stream(m, lam=1.0, sigma=1.0, lag=0)
    out = st.push((m.root_pos[0], m.rot[0], m.trans[0]))
    np.testing.assert_allclose(out.trans, m.trans[0], atol=1e-12)
    st.reset()
    out = st.push((m.root_pos[0], m.rot[0]))
    np.testing.assert_allclose(out.trans, m.skeleton.offsets[m.skeleton.trans_joints],
                               atol=1e-12)


def test_reset_reproduces(walk):
    m = walk[:200]
    st = mlayer.Stream(m, lam=2.0, sigma=0.3, lag=12)
    y = motion_channels(m)

    def run(k):
        outs = [st.push(r) for r in y[:k]]
        return np.vstack([o for o in outs if o is not None] + [st.flush()])

    run(77)  # a partial run first: reset must forget it
    st.reset()
    assert st.n_pushed == 0 and st.pending == 0
    a = run(len(y))
    st.reset()
    b = run(len(y))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, motion_channels(
        mlayer.stream_motion(m, lam=2.0, sigma=0.3, lag=12)))


def test_non_finite_frame_raises_and_changes_nothing(walk):
    m = walk[:120]
    y = motion_channels(m)
    ref = motion_channels(mlayer.stream_motion(m, lam=4.0, sigma=0.5, lag=9))
    st = mlayer.Stream(m, lam=4.0, sigma=0.5, lag=9)
    got = []
    for f in range(len(y)):
        if f % 31 == 17:
            before = (st.n_pushed, st.pending)
            bad = y[f].copy()
            bad[(7 * f) % len(bad)] = [np.nan, np.inf, -np.inf][f % 3]
            with pytest.raises(mlayer.InvalidArgumentError, match="NaN or infinite"):
                st.push(bad)
            with pytest.raises(ValueError):
                st.push((np.array([np.nan, 0, 0]), m.rot[f]))
            assert (st.n_pushed, st.pending) == before
        o = st.push(y[f])
        if o is not None:
            got.append(o)
    got.append(st.flush())
    np.testing.assert_array_equal(np.vstack(got), ref)


def test_wrong_shapes_and_arguments_raise(walk):
    J = walk.n_joints
    st = mlayer.Stream(walk, lam=1.0, sigma=1.0, lag=2)
    bad_frames = [
        (np.zeros(2), walk.rot[0]),
        (np.zeros(3), walk.rot[0][:-1]),
        (np.zeros(3), walk.rot[0][:, :3]),
        (np.zeros(3), walk.rot[0], np.zeros((1, 3))),  # this skeleton has no extra translations
        (np.zeros(3),),
        np.zeros(st.frame_size - 1),
        np.zeros((2, st.frame_size)),
        walk[:2],
        "frame",
        (np.zeros(3), np.array([["a"] * 4] * J)),
    ]
    for fr in bad_frames:
        with pytest.raises(mlayer.InvalidArgumentError):
            st.push(fr)
    assert st.n_pushed == 0
    other = small_skeleton(J)
    with pytest.raises(mlayer.InvalidArgumentError, match="another skeleton"):
        st.push(mlayer.Motion(other, 0.1, np.zeros((1, 3)), walk.rot[:1]))
    for kw in ({"lag": -1}, {"lag": 2.5}, {"lag": None}, {"lam": -1.0}, {"sigma": 0.0},
               {"lam": float("nan")}, {"alpha": 0.5}):
        args = {"lam": 1.0, "sigma": 1.0, "lag": 2, **kw}
        with pytest.raises(mlayer.InvalidArgumentError):
            mlayer.Stream(walk, **args)
    with pytest.raises(mlayer.InvalidArgumentError):
        mlayer.Stream(walk.rot, lam=1.0, sigma=1.0, lag=2)
    with pytest.raises(mlayer.InvalidArgumentError):
        decay_rate(1.0, -1.0)
    with pytest.raises(mlayer.InvalidArgumentError):
        st.set_alpha(0.5)  # no base layer
    with pytest.raises(mlayer.InvalidArgumentError):
        mlayer.stream_motion(walk.rot, lam=1.0, sigma=1.0, lag=2)


def test_push_after_flush_needs_reset(walk):
    st = mlayer.Stream(walk, lam=1.0, sigma=1.0, lag=3)
    for f in range(5):
        st.push(walk[f])
    assert st.pending == 3
    assert st.flush().n_frames == 3
    with pytest.raises(mlayer.Error, match="reset"):
        st.push(walk[5])
    with pytest.raises(mlayer.Error, match="reset"):
        st.flush()
    st.reset()
    assert st.push(walk[0]) is None


def test_properties(walk):
    st = mlayer.Stream(walk, lam=4.0, sigma=1.0, lag=19)
    assert st.lag == 19
    assert st.decay_rate == decay_rate(4.0, 1.0)
    assert 0.69 < st.decay_rate < 0.71  # mlr_stream.h: lam 4, sigma 1 -> rho 0.70
    assert decay_rate(0.0, 1.0) == 0.0
    assert st.frame_size == 3 + 4 * walk.n_joints
    assert "lag 19" in repr(st)
    st.close()


def test_layers(walk):
    """alpha 1 is the plain stream; alpha 0 (lag >= N) is the offline base layer; alpha per
    joint changes only the modulated joints; set_alpha takes effect at once."""
    m = walk[:150]
    N, lam, sigma, lam_b, sigma_b = m.n_frames, 2.0, 0.5, 20.0, 2.0
    plain = motion_channels(mlayer.stream_motion(m, lam=lam, sigma=sigma, lag=10))
    one = motion_channels(mlayer.stream_motion(m, lam=lam, sigma=sigma, lag=10, lam_base=lam_b,
                                               sigma_base=sigma_b))
    np.testing.assert_array_equal(plain, one)
    zero = motion_channels(mlayer.stream_motion(m, lam=lam, sigma=sigma, lag=N, alpha=0.0,
                                                lam_base=lam_b, sigma_base=sigma_b))
    assert gap(m, zero, offline(m, lam_b, sigma_b)) <= 1e-9
    alpha = np.ones(m.n_joints)
    alpha[5] = 1.8
    st = mlayer.Stream(m, lam=lam, sigma=sigma, lag=N, alpha=alpha, lam_base=lam_b,
                       sigma_base=sigma_b)
    assert st.layered and st.alpha[0] == 1.0 and st.alpha[1][5] == 1.8
    for f in range(N):
        st.push(m[f])
    x = motion_channels(st.flush())
    main = offline(m, lam, sigma)
    changed = np.abs(x - main).max(axis=0) > 1e-9
    q0 = 3
    assert changed[q0 + 20:q0 + 24].all() and not changed[:q0 + 20].any() \
        and not changed[q0 + 24:].any()
    with pytest.raises(mlayer.InvalidArgumentError):
        st.set_alpha(np.ones(3))
    with pytest.raises(mlayer.InvalidArgumentError):
        st.set_alpha(float("nan"))


def test_empty_and_short_clips(walk):
    out = mlayer.stream_motion(walk[:0], lam=1.0, sigma=1.0, lag=5)
    assert out.n_frames == 0
    short = walk[:3]
    out = mlayer.stream_motion(short, lam=1.0, sigma=1.0, lag=5)
    assert out.n_frames == 3
    assert gap(short, motion_channels(out), offline(short, 1.0, 1.0)) <= 1e-9


def test_a_stream_with_limits_keeps_exaggerated_knees_in_range(mocap):
    from mlayer.guards import plausibility as pl
    m = mlayer.read_bvh(mocap / "cmu_131_01_mj_style_walk.bvh")
    lim = mlayer.joint_limits(m)
    kw = dict(lam=1.0, sigma=1.0, lag=8, lam_base=30.0, sigma_base=30.0, alpha=3.0)
    free = mlayer.stream_motion(m, **kw)
    held = mlayer.stream_motion(m, limits=lim, **kw)
    assert pl.hinge_violations(m, free, lim)["fold_frames"] > 0
    v = pl.hinge_violations(m, held, lim)
    assert v["fold_frames"] == 0 and v["reversal_frames"] == 0
    # the same soft saturation as offline, frame by frame (a stream has no frames after, so
    # reads each frame on its own; offline calls unwrap angles beyond the range in time)
    rot = np.concatenate([lim.apply(free.rot[f:f + 1], 3.0)[0] for f in range(free.n_frames)])
    np.testing.assert_allclose(held.positions(), free.with_frames(rot=rot).positions(),
                               atol=1e-9 * 25)
    with pytest.raises(mlayer.InvalidArgumentError, match="limits"):
        mlayer.Stream(m, lam=1.0, sigma=1.0, lag=2, limits="auto")
