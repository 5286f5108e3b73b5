"""The baselines of paper 1's comparisons against independent references: expmap_base (Figure
6) against scipy's rotation vectors and a dense LGS solve; multires_stylize's frequency bands
(Figure 7) against dense filter matrices, its rotations against scipy."""
import numpy as np
import pytest

import mlayer
from mlayer.layers.layers import frequency_bands
from conftest import reference

Rotation = reference("scipy.spatial.transform", "scipy").Rotation


def _dense_lgs(y, s):
    """The second-difference LGS mean, (s D^T D + I) x = y, by a dense solve."""
    n = y.shape[0]
    D = np.diff(np.eye(n), 2, axis=0)
    return np.linalg.solve(s * D.T @ D + np.eye(n), y)


def _angle_deg(a, b):
    return np.degrees((Rotation.from_quat(a, scalar_first=True).inv()
                       * Rotation.from_quat(b, scalar_first=True)).magnitude())


@pytest.fixture(scope="module")
def walk():
    return mlayer.data.load_sample()[:300]


def test_expmap_base_is_the_lgs_of_scipys_rotation_vectors(walk):
    layers = mlayer.decompose(walk, lam_b=30.0, sigma_b=1.0)
    e = mlayer.expmap_base(walk, layers)
    J = walk.n_joints
    v = Rotation.from_quat(walk.rot.reshape(-1, 4), scalar_first=True).as_rotvec().reshape(
        walk.n_frames, J, 3)
    for j in range(J):
        want = Rotation.from_rotvec(_dense_lgs(v[:, j], float(layers.base_s[1 + j])))
        got = Rotation.from_quat(e.rot[:, j], scalar_first=True)
        assert (want.inv() * got).magnitude().max() < 1e-8, j
    # the translations are the base layer's
    np.testing.assert_array_equal(e.root_pos, layers.base.root_pos)
    # the default layers: decompose(motion)
    np.testing.assert_allclose(mlayer.expmap_base(walk).rot, mlayer.expmap_base(
        walk, mlayer.decompose(walk)).rot, atol=0)
    with pytest.raises(mlayer.InvalidArgumentError, match="another motion"):
        mlayer.expmap_base(walk[:100], layers)


def test_expmap_base_breaks_near_pi_where_the_quaternion_base_does_not(walk):
    """Paper 1, Figure 6: a joint turning through pi, smoothed at one strength."""
    t = np.arange(walk.n_frames) / walk.fps
    theta = np.pi + 0.45 * np.pi * np.sin(2 * np.pi * 0.4 * t)
    truth = Rotation.from_rotvec(theta[:, None] * np.array([0.0, 0.6, 0.8]))
    noise = Rotation.from_rotvec(np.random.default_rng(1).normal(0, 0.03, (walk.n_frames, 3)))
    rot = walk.rot.copy()
    j = 5
    rot[:, j] = (truth * noise).as_quat(scalar_first=True)
    c = walk.with_frames(rot=rot)
    layers = mlayer.decompose(c, lam_b=90.0, sigma_b=1.0)
    want = truth.as_quat(scalar_first=True)
    err_q = _angle_deg(layers.base.rot[:, j], want)
    err_e = _angle_deg(mlayer.expmap_base(c, layers).rot[:, j], want)
    near = np.abs(theta - np.pi) < 0.1
    assert err_q.max() < 6 and err_e[near].max() > 90
    far = np.abs(theta - np.pi) > 0.45 * np.pi * 0.9  # the turning points, angle ~0.55 pi
    assert err_e[far].max() < 6  # away from pi the two agree


def _dense_bands(y, levels):
    n = y.shape[0]
    w = np.array([1, 4, 6, 4, 1]) / 16
    g, out = y.copy(), []
    for k in range(levels):
        S = np.zeros((n, n))
        for i in range(n):
            for t in range(5):
                p = i + (t - 2) * 2 ** k
                while p < 0 or p > n - 1:  # mirror about the ends until inside
                    p = -p if p < 0 else 2 * (n - 1) - p
                S[i, p] += w[t]
        out.append(g - S @ g)
        g = S @ g
    return out + [g]


@pytest.mark.parametrize("n,levels", [(50, 3), (37, 6), (9, 4), (2, 2)])
def test_frequency_bands_against_dense_filters(rng, n, levels):
    y = rng.normal(size=(n, 4)).cumsum(axis=0)
    got = frequency_bands(y, levels)
    want = _dense_bands(y, levels)
    assert len(got) == levels + 1
    for a, b in zip(got, want):
        np.testing.assert_allclose(a, b, atol=1e-12)
    np.testing.assert_allclose(sum(got), y, atol=1e-12)
    for bad in (0, 2.5):
        with pytest.raises(mlayer.InvalidArgumentError):
            frequency_bands(y, bad)


def test_multires_stylize_against_scipy_and_dense_bands(walk):
    gains = [1.0, 2.0, 2.0, 2.0, 1.0]
    out = mlayer.multires_stylize(walk, gains)
    bands = _dense_bands(walk.root_pos, 4)
    np.testing.assert_allclose(out.root_pos, sum(g * b for g, b in zip(gains, bands)),
                               atol=1e-9)
    # rotations: low pass of the hemisphere-aligned quaternions, bands of the rotation vectors
    # about it (scipy), the low pass kept
    N, J = walk.n_frames, walk.n_joints
    q = walk.rot.copy()
    for i in range(1, N):
        q[i] *= np.where((q[i] * q[i - 1]).sum(-1) < 0, -1.0, 1.0)[:, None]
    low = _dense_bands(q.reshape(N, 4 * J), 4)[-1].reshape(N, J, 4)
    low /= np.linalg.norm(low, axis=-1, keepdims=True)
    R_low = Rotation.from_quat(low.reshape(-1, 4), scalar_first=True)
    v = (R_low.inv() * Rotation.from_quat(q.reshape(-1, 4), scalar_first=True)).as_rotvec()
    vb = _dense_bands(v.reshape(N, 3 * J), 4)
    vm = sum(g * b for g, b in zip(gains[:-1], vb[:-1])) + vb[-1]
    want = (R_low * Rotation.from_rotvec(vm.reshape(-1, 3))).as_quat(scalar_first=True)
    assert _angle_deg(out.rot.reshape(-1, 4), want).max() < 1e-6
    # gains of 1: the input
    same = mlayer.multires_stylize(walk, [1.0] * 6)
    assert _angle_deg(same.rot.reshape(-1, 4), walk.rot.reshape(-1, 4)).max() < 1e-6
    np.testing.assert_allclose(same.root_pos, walk.root_pos, atol=1e-9)
    for bad in ([1.0], "2", [1.0, float("nan")]):
        with pytest.raises(mlayer.InvalidArgumentError):
            mlayer.multires_stylize(walk, bad)


def test_multires_at_matched_gain_is_close_to_the_layers():
    """Paper 1, Figure 7 on the bundled walk: the two exaggerations differ by much less than
    either differs from the input (docs/layers.md quotes the figures)."""
    from mlayer.guards.metrics import body_height
    m = mlayer.data.load_sample()
    h = body_height(m)
    styl = mlayer.decompose(m).synthesize(2.0).positions()
    mr = mlayer.multires_stylize(m, [1.0] + [2.0] * 6 + [1.0]).positions()
    p0 = m.positions()

    def rms(a, b):
        return np.sqrt(((a - b) ** 2).sum(-1).mean()) / h
    assert rms(mr, styl) < 0.5 * min(rms(styl, p0), rms(mr, p0))
