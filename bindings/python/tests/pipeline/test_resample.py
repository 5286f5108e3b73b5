"""mlayer.resample / timewarp / slerp_resample against independent references: a dense numpy
solve of the same LGS, scipy's Slerp, the real clips (round trips measured in MPJPE)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

import mlayer
from mlayer import quat
from mlayer.guards.metrics import body_height

# converter-inserted T-pose and blend frames at the start of the CMU clips (mocap README)
SKIP = {"cmu_01_01_playground_jumps.bvh": 1, "cmu_131_01_mj_style_walk.bvh": 0,
        "cmu_10_01_soccer_kick.bvh": 6, "cmu_60_10_salsa_dance.bvh": 6,
        "cmu_02_03_run_jog_25fps.bvh": 6}
CLIPS_120 = ["cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh",
             "cmu_10_01_soccer_kick.bvh", "cmu_60_10_salsa_dance.bvh"]


# ---- helpers ---------------------------------------------------------------------------------

def dense_lgs(y, t, n, s):
    """Mean and variance (per sigma^2) of the order-2 LGS by a dense solve:
    (s L^T L + A^T A) x = A^T y, A the linear-interpolation rows placing y[i] at t[i]."""
    N = len(t)
    A = np.zeros((N, n))
    for i, ti in enumerate(t):
        k = min(int(np.floor(ti)), n - 2)
        f = ti - k
        A[i, k], A[i, k + 1] = 1 - f, f
    L = np.zeros((n - 2, n))
    for r in range(n - 2):
        L[r, r:r + 3] = (1, -2, 1)
    M = s * L.T @ L + A.T @ A
    return np.linalg.solve(M, A.T @ y), np.diag(np.linalg.inv(M))


def auto_s(N, n):
    """The automatic smoothness as documented in mlr_resample.h."""
    r = (n - 1) / (N - 1)
    return max(0.01 * r ** 3, 0.5 / r)


def axis_angle(axis, ang):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    ang = np.asarray(ang, float)[..., None]
    return np.concatenate([np.cos(ang / 2), np.sin(ang / 2) * axis], -1)


def one_joint(root, rot, fps=120.0):
    rot = np.asarray(rot, float).reshape(len(rot), 1, 4)
    return mlayer.Motion.from_arrays(["root"], [-1], [[0, 0, 0]], root, rot, fps=fps)


def smooth_motion(rng, N=60, with_trans=True):
    """Two joints, the second with position channels; smooth channels."""
    ch = ["Xposition Yposition Zposition Zrotation Yrotation Xrotation"] * 2
    x = np.linspace(0, 1, N)[:, None]
    root = np.sin(2 * np.pi * (x * [1.1, 0.7, 1.9] + rng.uniform(size=3))) * [3, 1, 2]
    ang = 1.5 * np.sin(2 * np.pi * x[:, 0] * 0.8) + 0.3
    rot = np.stack([axis_angle([0.2, 1, 0.1], ang), axis_angle([1, 0.3, -0.2], 0.7 * ang ** 2)],
                   1)
    trans = (np.cos(2 * np.pi * x * [0.5, 1.3, 0.9]) * [0.5, 0.2, 0.3] + [0, 4, 0])[:, None, :]
    return mlayer.Motion.from_arrays(["root", "child"], [-1, 0], [[0, 0, 0], [0, 4, 0]], root,
                                     rot, fps=120, channels=ch,
                                     trans=trans if with_trans else None)


def load(mocap, name):
    m = mlayer.read_bvh(mocap / name)
    return m[SKIP.get(name, 0):]


def unwrap_spin(q):
    """Unwrapped rotation angle about y along a sequence of (n, 4) quaternions."""
    return np.unwrap(2 * np.arctan2(q[:, 2], q[:, 0]))


def spin_keys(steps):
    """Keys of a spin about y with the given steps (degrees); every other key's sign flipped
    (a key's sign carries no information)."""
    ang = np.radians(np.concatenate([[0.0], np.cumsum(steps)]))
    q = axis_angle([0, 1, 0], ang)
    q[1::2] *= -1
    return q


# ---- against a dense solve of the same LGS ---------------------------------------------------

@pytest.mark.parametrize("N,n", [(60, 16), (60, 60), (25, 97), (8, 40)])
def test_matches_a_dense_solve(rng, N, n):
    m = smooth_motion(rng, N)
    out, var = mlayer.resample(m, n_frames=n, return_var=True)
    t = np.arange(N) * (n - 1) / (N - 1)
    s = auto_s(N, n)
    ref, ref_var = dense_lgs(np.concatenate([m.root_pos, m.trans[:, 0]], 1), t, n, s)
    np.testing.assert_allclose(out.root_pos, ref[:, :3], atol=1e-9 * np.abs(ref).max())
    np.testing.assert_allclose(out.trans[:, 0], ref[:, 3:], atol=1e-9 * np.abs(ref).max())
    np.testing.assert_allclose(var, ref_var, rtol=1e-9)
    # quaternions: the components are solved the same way and renormalized (the input signs
    # are already continuous and the steps small, so prediction changes nothing)
    qref, _ = dense_lgs(m.rot.reshape(N, 8), t, n, s)
    qref = qref.reshape(n, 2, 4)
    qref /= np.linalg.norm(qref, axis=-1, keepdims=True)
    np.testing.assert_allclose(out.rot, qref, atol=1e-9)
    # the new frame time keeps the first and last frames' times
    assert out.frame_time == pytest.approx(m.frame_time * (N - 1) / (n - 1), rel=1e-12)
    assert out.skeleton is m.skeleton


def test_explicit_lam_sigma_and_time_map_match_a_dense_solve(rng):
    m = smooth_motion(rng, 50)
    t = np.cumsum(np.r_[0, 1 + 1.5 * np.sin(np.linspace(0, 3, 49)) ** 2])
    n = 90
    t *= (n - 1) / t[-1]
    t[-1] = n - 1
    lam, sigma = 0.7, 0.2
    out, var = mlayer.timewarp(m, time_map=t, n_frames=n, lam=lam, sigma=sigma,
                               return_var=True)
    ref, ref_var = dense_lgs(m.root_pos, t, n, lam ** 2 * sigma ** 2)
    np.testing.assert_allclose(out.root_pos, ref, atol=1e-9 * np.abs(ref).max())
    np.testing.assert_allclose(var, sigma ** 2 * ref_var, rtol=1e-9)
    assert out.frame_time == m.frame_time


def test_resample_by_fps_counts_frames_like_the_c_core():
    m = mlayer.read_bvh(mlayer.data.sample_path())  # 994 frames at 120.0005 fps
    out = mlayer.resample(m, fps=30)
    assert len(out) == 249
    assert out.fps == pytest.approx(30.0) and out.skeleton is m.skeleton
    for fps in (60, 24, 25, 29.97, 240, 1000):
        # the exact grid: the last output time k / fps within the input's duration
        want = int(np.floor(993 * fps / m.fps + 1e-9)) + 1
        assert len(mlayer.resample(m, fps=fps)) == want
        assert len(mlayer.slerp_resample(m, fps=fps)) == want
        assert (want - 1) / fps <= 993 / m.fps < want / fps


def test_fps_puts_output_frame_k_at_time_k_over_fps():
    """A root moving linearly in time and a joint at constant angular speed: the output frame
    k holds the input's state at time k / fps (exactly for the root, whose line the order-2
    prior does not bend; the joint to the chordal approximation of the LGS)."""
    fps_in, N = 120.0, 301
    time = np.arange(N) / fps_in
    root = np.stack([1 + 3 * time, -2 * time, np.full(N, 0.5)], 1)
    m = one_joint(root, quat.exp(np.outer(1.0 * time, [0.0, 1.0, 0.0])), fps=fps_in)
    for fps in (30, 29.97, 24, 200):
        for out in (mlayer.resample(m, fps=fps, keep_contacts=False),
                    mlayer.slerp_resample(m, fps=fps)):
            k = np.arange(len(out))
            assert (k[-1] / fps <= time[-1] + 1e-12) and (len(out) / fps > time[-1])
            np.testing.assert_allclose(out.root_pos[:, 0], 1 + 3 * k / fps, atol=1e-9)
            np.testing.assert_allclose(out.root_pos[:, 1], -2 * k / fps, atol=1e-9)
            ang = 2 * np.arctan2(np.abs(out.rot[:, 0, 2]), np.abs(out.rot[:, 0, 0]))
            np.testing.assert_allclose(ang, 1.0 * k / fps, atol=2e-4)


def test_n_frames_still_fits_the_duration():
    m = mlayer.read_bvh(mlayer.data.sample_path())
    for fn in (mlayer.resample, mlayer.slerp_resample):
        out = fn(m, n_frames=300)
        assert len(out) == 300
        assert out.frame_time * 299 == pytest.approx(m.frame_time * 993, rel=1e-12)
    # the first and the last frame stay put (SLERP interpolates them exactly)
    np.testing.assert_allclose(out.root_pos[[0, -1]], m.root_pos[[0, -1]], atol=1e-12)


def test_per_joint_translations_are_resampled(mocap):
    m = load(mocap, "bandai1_walk_happy_001.bvh")  # 21 joints with position channels
    assert m.trans.shape[1] == 21
    out = mlayer.resample(m, fps=60)
    assert out.trans.shape == (len(out), 21, 3)
    # Hips carries the body's travel, most others hold their OFFSETs in every frame: a constant
    # channel stays constant, a moving one follows the input at the input frames' times
    const = np.ptp(m.trans, axis=0).max(axis=1) == 0
    assert const.sum() >= 10 and not const[0]
    np.testing.assert_allclose(out.trans[:, const],
                               np.broadcast_to(m.trans[0, const], out.trans[:, const].shape),
                               atol=1e-9 * np.abs(m.trans).max())
    t = np.arange(len(m)) * 60 / m.fps  # input frame i at its time on the 60 fps grid
    inside = t <= len(out) - 1
    assert inside.sum() >= len(m) - 1
    for p in range(21):
        for c in range(3):
            ref = np.interp(t[inside], np.arange(len(out)), out.trans[:, p, c])
            assert rms(ref - m.trans[inside, p, c]) < 0.002 * body_height(m)
    back = mlayer.resample(out, fps=m.fps)
    assert len(m) - 2 <= len(back) <= len(m)
    assert mlayer.metrics.mpjpe(m[:len(back)], back) < 0.005 * body_height(m)


# ---- the SLERP baseline against scipy --------------------------------------------------------

@pytest.mark.parametrize("n", [7, 50, 133])
def test_slerp_resample_matches_scipy(rng, n):
    N, J = 30, 3
    rv = np.cumsum(rng.normal(scale=0.4, size=(N, J, 3)), 0)
    q = quat.exp(rv)
    q *= np.where(rng.uniform(size=(N, J, 1)) < 0.5, -1.0, 1.0)  # signs must not matter
    root = np.cumsum(rng.normal(size=(N, 3)), 0)
    m = mlayer.Motion.from_arrays(["a", "b", "c"], [-1, 0, 1], np.ones((J, 3)), root, q)
    out = mlayer.slerp_resample(m, n_frames=n)
    t_in, t_out = np.arange(N) * (n - 1) / (N - 1), np.arange(n, dtype=float)
    for j in range(J):
        r = Rotation.from_quat(q[:, j][:, [1, 2, 3, 0]])
        ref = Slerp(t_in, r)(np.clip(t_out, 0, t_in[-1])).as_quat()[:, [3, 0, 1, 2]]
        dots = np.abs(np.einsum("ij,ij->i", ref, out.rot[:, j]))
        np.testing.assert_allclose(dots, 1.0, atol=1e-10)
    for c in range(3):
        np.testing.assert_allclose(out.root_pos[:, c], np.interp(t_out, t_in, root[:, c]),
                                   atol=1e-10)


# ---- sparse keys: a spin that SLERP gets backwards -------------------------------------------

def test_spin_keys_lgs_turns_forward_where_slerp_takes_the_short_way():
    """Paper Table 1 (8 key poses to 40 frames): key steps grow from 120 past 180 to 270
    degrees. SLERP (and the LGS with nearest-sign continuity only) takes the short way round
    for the steps beyond 180 degrees, so the spin goes backwards; mlayer's prediction of the
    angular velocity keeps it turning forward through every key."""
    steps = [120, 145, 170, 195, 220, 245, 270]
    m = one_joint(np.zeros((8, 3)), spin_keys(steps), fps=8)
    lgs = unwrap_spin(mlayer.resample(m, n_frames=40).rot[:, 0])
    slerp = unwrap_spin(mlayer.slerp_resample(m, n_frames=40).rot[:, 0])
    nearest = unwrap_spin(mlayer.resample(m, n_frames=40, nearest_sign=True).rot[:, 0])
    total = np.radians(sum(steps))
    assert (np.diff(lgs) > 0).all(), "the LGS turns backwards"
    assert (np.diff(slerp) < 0).any() and (np.diff(nearest) < 0).any()
    assert abs(lgs[-1] - lgs[0] - total) < np.radians(12)
    assert slerp[-1] - slerp[0] < total - np.pi
    # the LGS passes near every key
    keys = np.radians(np.concatenate([[0], np.cumsum(steps)])) + lgs[0]
    at_keys = np.interp(np.arange(8) * 39 / 7, np.arange(40), lgs)
    assert np.abs(at_keys - keys).max() < np.radians(12)


def test_upsampling_variance_is_larger_between_keys():
    m = one_joint(np.zeros((8, 3)), spin_keys([30] * 7), fps=8)
    _, var = mlayer.resample(m, n_frames=36, return_var=True)  # keys at every 5th frame
    keys = np.arange(0, 36, 5)
    between = keys[:-1] + 2
    assert (var[between] > 1.5 * var[keys[:-1]]).all()


def test_variance_grows_where_observations_are_sparse(rng):
    N = 30
    steps = np.where((np.arange(N - 1) >= 10) & (np.arange(N - 1) < 20), 6.0, 1.0)
    t = np.r_[0, np.cumsum(steps)]
    m = smooth_motion(rng, N)
    _, var = mlayer.timewarp(m, time_map=t, lam=1.0, sigma=0.1, return_var=True)
    dense = var[3:8].max()
    sparse = var[int(t[10]) + 1:int(t[19])].max()
    assert sparse > 2 * dense
    assert (var > 0).all()


# ---- downsampling does not alias -------------------------------------------------------------

def rms(x):
    return float(np.sqrt(np.mean((x - x.mean()) ** 2)))


@pytest.mark.parametrize("hz", [16, 17, 20, 25, 33, 55])
def test_downsampling_does_not_alias(hz):
    """120 -> 30 fps: a sinusoid above the new Nyquist (15 Hz) is removed (under 6 % of its
    amplitude comes back), where plain decimation (and SLERP, which samples every 4th frame)
    returns it whole as a slow alias."""
    N = 961
    i = np.arange(N)
    root = np.zeros((N, 3))
    root[:, 0] = np.sin(2 * np.pi * hz * i / 120 + 0.3)
    m = one_joint(root, np.tile([1.0, 0, 0, 0], (N, 1)))
    out = mlayer.resample(m, fps=30)
    slerp = mlayer.slerp_resample(m, fps=30)
    assert len(out) == 241
    assert rms(out.root_pos[8:-8, 0]) < 0.06 * rms(root[:, 0])
    assert rms(slerp.root_pos[2:-2, 0]) > 0.5 * rms(root[:, 0])


def test_downsampling_keeps_slow_motion():
    N = 961
    root = np.zeros((N, 3))
    root[:, 0] = np.sin(2 * np.pi * 2.0 * np.arange(N) / 120)
    out = mlayer.resample(one_joint(root, np.tile([1.0, 0, 0, 0], (N, 1))), fps=30)
    assert rms(out.root_pos[8:-8, 0]) > 0.97 * rms(root[32:-32, 0])


# ---- real clips: 120 -> 30 -> 120 fps round trips --------------------------------------------

@pytest.mark.parametrize("name", CLIPS_120)
def test_round_trip_120_30_120_on_real_clips(mocap, name):
    """The round trip moves the joints by under 0.6 % of the body size (MPJPE; about 1 cm for a
    1.7 m person). Measured: 0.1 to 0.4 % (the 30 fps passband keeps > 0.94 of the motion
    below 2.8 Hz, so what is lost is the fast part of feet and hands in jumps and spins); the
    bound leaves 1.5x margin over the worst clip (salsa spins). The SLERP round trip
    (decimation, then interpolation) is measured alongside and is of the same order."""
    m = load(mocap, name)
    size = body_height(m)
    m30 = mlayer.resample(m, fps=30)
    assert 0 <= (len(m) - 1) * 30 / m.fps - (len(m30) - 1) < 1
    back = mlayer.resample(m30, fps=m.fps)  # the exact grid: frame k at k / fps both ways
    assert len(m) - 4 <= len(back) <= len(m)
    err = mlayer.metrics.mpjpe(m[:len(back)], back)
    back_slerp = mlayer.slerp_resample(mlayer.slerp_resample(m, fps=30), fps=m.fps)
    err_slerp = mlayer.metrics.mpjpe(m[:len(back_slerp)], back_slerp)
    print(f"{name}: size {size:.3g}, MPJPE LGS {err:.4g} ({100 * err / size:.3f} %), "
          f"SLERP {err_slerp:.4g} ({100 * err_slerp / size:.3f} %)")
    assert err < 0.006 * size
    assert err < 3 * err_slerp


def _mpjpe_per_frame(a, b):
    n = min(len(a), len(b))
    return np.linalg.norm(a[:n].positions() - b[:n].positions(), axis=2).mean(axis=1)


@pytest.mark.parametrize("method", ["resample", "slerp_resample"])
def test_fps_round_trip_does_not_drift(mocap, method):
    """120 -> 30 -> 120 fps on the walk: output frame k is compared with input frame k (both
    at time k / 120 s). With exact retiming the error at the end of the clip is not larger
    than at its start. Measured (bench/python/bench_retiming.py): LGS 3.1e-4 of the body height
    over the first 10 % of the frames, 2.3e-4 over the last 10 % (before: 3.2e-4 and 7.0e-4,
    growing through the clip to 8.2e-3 at 72 %)."""
    m = load(mocap, "cmu_131_01_mj_style_walk.bvh")
    fn = getattr(mlayer, method)
    back = fn(fn(m, fps=30), fps=m.fps)
    assert len(m) - 4 <= len(back) <= len(m)
    e = _mpjpe_per_frame(m, back) / mlayer.metrics.body_height(m)
    k = len(e) // 10
    print(f"{method}: first 10 % {e[:k].mean():.3g}, last 10 % {e[-k:].mean():.3g}, "
          f"mean {e.mean():.3g}")
    assert e[-k:].mean() <= e[:k].mean()
    assert e.mean() < 2e-3


def test_two_cuts_resampled_separately_agree_at_the_same_times(mocap):
    """Two cuts of one clip (the second 40 input frames = 10 output frames later and shorter)
    resampled separately to 30 fps: frames at the same time agree, exactly for SLERP and for
    the LGS away from the cuts' ends (its end effects fade over about 0.5 s)."""
    # the file says 0.0083333 s (120.0005 fps); at exactly 120 fps 40 input frames are exactly
    # 10 output frames, so the two cuts share output times
    m = load(mocap, "cmu_131_01_mj_style_walk.bvh").with_frames(frame_time=1 / 120)
    a, b = m[0:900], m[40:611]
    for fn, margin, tol in ((mlayer.slerp_resample, 0, 1e-12), (mlayer.resample, 16, 1e-7)):
        kw = {} if fn is mlayer.slerp_resample else {"keep_contacts": False}
        ra, rb = fn(a, fps=30, **kw), fn(b, fps=30, **kw)
        assert len(ra) == 899 // 4 + 1 and len(rb) == 570 // 4 + 1
        sl = slice(margin, len(rb) - margin)
        pa = ra[10:10 + len(rb)].positions()[sl]
        pb = rb.positions()[sl]
        err = np.abs(pa - pb).max() / mlayer.metrics.body_height(m)
        print(f"{fn.__name__}: largest difference {err:.3g} of the body height")
        assert err <= tol


# ---- time warping ----------------------------------------------------------------------------

def burst_motion(N=100):
    """One joint that turns slowly, then fast around frame 50, then slowly again."""
    x = (np.arange(N) - 50) / 8
    ang = np.cumsum(0.01 + 0.2 * np.exp(-x * x))
    return one_joint(np.zeros((N, 3)), axis_angle([0, 0, 1], ang))


def test_timewarp_keeps_the_ends_is_monotone_and_slows_large_motion():
    m = burst_motion()
    out, t = mlayer.timewarp(m, strength=1.0, return_map=True)
    assert len(out) == len(m) and out.frame_time == m.frame_time
    assert t[0] == 0 and t[-1] == len(m) - 1
    rate = np.diff(t)
    assert (rate > 0).all()
    assert rate[50] > 3 * rate[5] and rate[50] > 0.9 * rate.max()
    # easing in and out: no jump in the local rate
    assert np.abs(np.diff(rate)).max() < 0.15 * rate.max()
    # the output motion: the burst is spread over more frames, so its peak speed drops
    w_in = np.degrees(np.linalg.norm(quat.log(quat.mul(quat.conj(m.rot[:-1]), m.rot[1:])),
                                     axis=-1))
    w_out = np.degrees(np.linalg.norm(
        quat.log(quat.mul(quat.conj(out.rot[:-1]), out.rot[1:])), axis=-1))
    assert w_out.max() < 0.5 * w_in.max()
    # boundary frames stay put (up to the LGS's smoothing of a slow start and end)
    assert np.abs(np.einsum("ij,ij->i", out.rot[[0, -1], 0], m.rot[[0, -1], 0])) \
        == pytest.approx([1, 1], abs=1e-4)
    # a longer target slows everything down, the burst most
    out2, t2 = mlayer.timewarp(m, strength=1.0, n_frames=200, return_map=True)
    assert len(out2) == 200 and t2[-1] == 199
    assert np.diff(t2)[50] > np.diff(t2)[5]


def test_timewarp_strength_zero_is_uniform_and_maps_compose():
    m = burst_motion()
    t0 = mlayer.timewarp_map(m, strength=0.0)
    np.testing.assert_allclose(t0, np.arange(len(m)), atol=1e-9)
    a = mlayer.timewarp(m, strength=0.0)
    b = mlayer.resample(m, n_frames=len(m))
    np.testing.assert_allclose(a.rot, b.rot, atol=1e-7)
    # the automatic map given explicitly gives the same motion
    t = mlayer.timewarp_map(m, strength=1.5, n_frames=130)
    np.testing.assert_array_equal(mlayer.timewarp(m, time_map=t).rot,
                                  mlayer.timewarp(m, strength=1.5, n_frames=130).rot)
    # stronger warps slow the burst more
    r1 = np.diff(mlayer.timewarp_map(m, strength=1.0))
    r2 = np.diff(mlayer.timewarp_map(m, strength=2.0))
    assert r2[50] / r2[5] > r1[50] / r1[5]


def test_timewarp_real_clip_slows_the_kick(mocap):
    m = load(mocap, "cmu_10_01_soccer_kick.bvh")
    speed = mlayer.timewarp_speed(m)
    out, t = mlayer.timewarp(m, strength=1.0, n_frames=len(m) * 5 // 4, return_map=True)
    rate = np.diff(t)
    assert (rate > 0).all() and t[-1] == len(out) - 1
    assert abs(int(np.argmax(rate)) - int(np.argmax(speed))) < 60
    # the kick (fastest second of the clip) gets more output time than a uniform stretch
    k = int(np.argmax(speed))
    lo, hi = max(0, k - 60), min(len(m) - 1, k + 60)
    assert (t[hi] - t[lo]) > 1.3 * (hi - lo) * (len(out) - 1) / (len(m) - 1)
    # units: the same clip in other length units gets the same map
    sk = mlayer.Skeleton(m.joint_names, m.parents, m.offsets * 37.0, m.channels,
                         m.end_site_parents, m.end_site_offsets * 37.0)
    scaled = mlayer.Motion(sk, m.frame_time, m.root_pos * 37.0, m.rot, m.trans * 37.0)
    np.testing.assert_allclose(mlayer.timewarp_map(scaled, n_frames=len(out)), t, rtol=1e-9,
                               atol=1e-9)


# ---- bad input -------------------------------------------------------------------------------

def test_bad_input_gives_clear_errors():
    m = burst_motion()
    E = mlayer.InvalidArgumentError
    with pytest.raises(E, match="exactly one of fps or n_frames"):
        mlayer.resample(m)
    with pytest.raises(E, match="exactly one of fps or n_frames"):
        mlayer.resample(m, fps=30, n_frames=20)
    for bad in (0, -30, float("nan"), float("inf")):
        with pytest.raises(E, match="fps must be finite and > 0"):
            mlayer.resample(m, fps=bad)
        with pytest.raises(E, match="fps must be finite and > 0"):
            mlayer.slerp_resample(m, fps=bad)
    with pytest.raises(E, match="n_frames must be an integer >= 2"):
        mlayer.resample(m, n_frames=1)
    with pytest.raises(E, match="must be an integer"):
        mlayer.resample(m, n_frames=20.5)
    # absurd factors: a frame time passed as a frame rate, or 1000x more frames
    with pytest.raises(E, match="beyond 100x.*flag allow_extreme"):
        mlayer.resample(m, fps=1 / 120)
    with pytest.raises(E, match="beyond 100x"):
        mlayer.resample(m, n_frames=100 * 99 + 2)
    with pytest.raises(E, match="beyond 100x"):
        mlayer.timewarp(m, n_frames=100 * 99 + 2)
    assert len(mlayer.resample(m, n_frames=100 * 99 + 1)) == 9901  # exactly 100x passes
    # (100 frames at 120 fps last 0.825 s: not one frame period at 1 fps, beyond 100x or not)
    with pytest.raises(E, match="less than one frame at 1 fps"):
        mlayer.resample(m, fps=1.0, allow_extreme=True)
    assert len(mlayer.resample(m[:2].with_frames(frame_time=1.0), fps=101,
                               allow_extreme=True)) == 102
    assert len(mlayer.slerp_resample(m, n_frames=12000, allow_extreme=True)) == 12000
    # fewer than 2 frames
    for f in (mlayer.resample, mlayer.slerp_resample):
        with pytest.raises(E, match="at least 2 frames, got 1"):
            f(m[:1], fps=30)
    with pytest.raises(E, match="at least 2 frames, got 1"):
        mlayer.timewarp(m[:1])
    # time maps
    t = np.arange(len(m), dtype=float)
    bad = t.copy()
    bad[40], bad[41] = bad[41], bad[40]
    with pytest.raises(E, match=r"not strictly increasing: t\[40\]"):
        mlayer.timewarp(m, time_map=bad)
    with pytest.raises(E, match="not strictly increasing"):
        mlayer.slerp_resample(m, time_map=np.r_[0, 0, t[2:]])
    with pytest.raises(E, match="one output position per input frame"):
        mlayer.timewarp(m, time_map=t[:-1])
    with pytest.raises(E, match=r"t\[0\] must be 0"):
        mlayer.timewarp(m, time_map=t + 1, n_frames=len(m) + 1)
    with pytest.raises(E, match="must be n_out - 1"):
        mlayer.timewarp(m, time_map=t, n_frames=len(m) + 5)
    with pytest.raises(E, match="integer"):
        mlayer.timewarp(m, time_map=t * 1.00001)
    with pytest.raises(E, match="NaN"):
        mlayer.timewarp(m, time_map=np.r_[t[:-1], np.nan])
    steep = t.copy()
    steep[1:] += 300
    with pytest.raises(E, match="step .* beyond the 100x.*flag allow_extreme"):
        mlayer.timewarp(m, time_map=steep)
    assert len(mlayer.timewarp(m, time_map=steep, allow_extreme=True)) == len(m) + 300
    # non-finite frames (edited in place after construction): the C core says where
    bad_m = m.copy()
    bad_m.root_pos[3, 0] = np.nan
    with pytest.raises(E, match="root_pos of frame 3 is not finite"):
        mlayer.resample(bad_m, fps=30)
    bad_m = m.copy()
    bad_m.rot[7, 0] = 0
    with pytest.raises(E, match="rot of frame 7, joint 0 is zero or not finite"):
        mlayer.slerp_resample(bad_m, fps=30)
    # parameters
    with pytest.raises(E, match="strength"):
        mlayer.timewarp(m, strength=-1)
    with pytest.raises(E, match="strength"):
        mlayer.timewarp(m, strength=11)
    with pytest.raises(E, match="lam"):
        mlayer.resample(m, fps=30, lam=-1)
    with pytest.raises(E, match="sigma"):
        mlayer.resample(m, fps=30, sigma=0)
    with pytest.raises(E, match="joint_weights"):
        mlayer.timewarp(m, joint_weights=[1, 2])
    with pytest.raises(TypeError, match="mlayer.Motion"):
        mlayer.resample(np.zeros((10, 3)), fps=30)
    # lam = 0 leaves output frames unobserved when upsampling: singular
    with pytest.raises(mlayer.SingularMatrixError):
        mlayer.resample(m, n_frames=300, lam=0)


# ---- composition with style modulation -------------------------------------------------------

def test_retime_then_stylize_or_both_in_one_call():
    """resample returns a Motion that stylize takes (retime, then stylize); style= does both in
    one call (stylize at the input rate, then retime). The two orders agree closely (measured:
    they differ by 0.5 % of what the style change moves on the sample walk)."""
    m = mlayer.read_bvh(mlayer.data.sample_path())
    plain = mlayer.resample(m, fps=30)
    a = mlayer.stylize(plain, 2.0)
    b = mlayer.resample(m, fps=30, style=2.0)
    assert isinstance(a, mlayer.Motion) and len(a) == len(b) == len(plain) == 249
    assert a.fps == pytest.approx(30) and b.fps == pytest.approx(30)
    # style= is stylize then resample (the retimed contact cleanup, on by default, follows the
    # original's feet, so compare without it)
    np.testing.assert_array_equal(
        mlayer.resample(m, fps=30, style=2.0, keep_contacts=False).rot,
        mlayer.resample(mlayer.stylize(m, 2.0), fps=30, keep_contacts=False).rot)
    # the layer arithmetic commutes with retiming; the contact cleanup (on by default) is a
    # nonlinear step run at the rate it is given, so compare the orders without it
    plain = mlayer.resample(m, fps=30, keep_contacts=False)
    a = mlayer.stylize(plain, 2.0, keep_contacts=False)
    b = mlayer.resample(m, fps=30, style={"alpha": 2.0, "keep_contacts": False},
                        keep_contacts=False)
    moved = mlayer.metrics.mpjpe(a, plain)
    assert moved > 0.05 * body_height(m)  # the style really is exaggerated
    assert mlayer.metrics.mpjpe(a, b) < 0.05 * moved
    # time warps compose the same way; a dict passes stylize's other arguments
    c = mlayer.timewarp(m, strength=1.0, n_frames=1200, style={"alpha": 0.5, "joints": {"*": 0.5}},
                        keep_contacts=False)
    ref = mlayer.timewarp(mlayer.stylize(m, 0.5, {"*": 0.5}), strength=1.0, n_frames=1200,
                          time_map=mlayer.timewarp_map(m, strength=1.0, n_frames=1200),
                          keep_contacts=False)
    assert len(c) == 1200
    np.testing.assert_array_equal(c.rot, ref.rot)
    with pytest.raises(mlayer.InvalidArgumentError, match="alpha"):
        mlayer.resample(m, fps=30, style={"joints": {"*": 2}})
    with pytest.raises(mlayer.InvalidArgumentError, match="style must be"):
        mlayer.resample(m, fps=30, style="big")
