"""mlayer.quat against scipy.spatial.transform.Rotation (scalar_first=True) on seeded inputs."""
import warnings

import numpy as np
import pytest

from conftest import reference

scipy_transform = reference("scipy.spatial.transform", "scipy")
Rotation = scipy_transform.Rotation
Slerp = scipy_transform.Slerp

import mlayer  # noqa: E402
from mlayer import quat  # noqa: E402
from mlayer._native import lib  # noqa: E402

ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]
SHAPES = [(), (7,), (5, 3)]  # batch shapes: q of shape (4,), (N, 4), (N, J, 4)
TOL = 1e-12


def random_quats(rng, shape):
    q = rng.normal(size=tuple(shape) + (4,))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def random_rotvecs(rng, shape, angles=None):
    axis = rng.normal(size=tuple(shape) + (3,))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    if angles is None:
        angles = rng.uniform(0, np.pi, size=shape)
    return axis * np.asarray(angles)[..., None]


def sp(q):
    """scipy Rotation of a (..., 4) scalar-first array (flattened)."""
    return Rotation.from_quat(np.reshape(q, (-1, 4)), scalar_first=True)


def sp_quat(r, shape):
    return r.as_quat(scalar_first=True).reshape(tuple(shape) + (4,))


def rotation_distance(a, b):
    """Angle of the rotation between quaternions a and b (signs ignored)."""
    a, b = np.broadcast_arrays(a, b)
    s = np.where(np.sum(a * b, axis=-1) < 0, -1.0, 1.0)[..., None]
    return 4 * np.arctan2(np.linalg.norm(a - s * b, axis=-1), np.linalg.norm(a + s * b, axis=-1))


def assert_same_rotation(a, b, tol=TOL):
    assert np.shape(a) == np.shape(b)
    d = rotation_distance(a, b)
    assert np.max(d, initial=0.0) <= tol, f"max rotation distance {np.max(d)}"


def wrapped_diff(a, b, period):
    d = np.abs(np.asarray(a) - np.asarray(b))
    return np.minimum(d, np.abs(d - period))


# ------------------------------------------------------------------------------- products


@pytest.mark.parametrize("shape", SHAPES)
def test_mul_matches_scipy(shape):
    rng = np.random.default_rng(1)
    a, b = random_quats(rng, shape), random_quats(rng, shape)
    out = quat.mul(a, b)
    assert out.shape == a.shape
    ref = sp_quat(sp(a) * sp(b), shape)
    np.testing.assert_allclose(np.where(np.sum(out * ref, -1, keepdims=True) < 0, -out, out),
                               ref, rtol=0, atol=TOL)


def test_mul_broadcasts():
    rng = np.random.default_rng(2)
    a, b = random_quats(rng, (6, 4)), random_quats(rng, (4,))  # (frames, joints, 4), (joints, 4)
    out = quat.mul(a, b)
    assert out.shape == (6, 4, 4)
    np.testing.assert_array_equal(out, quat.mul(a, np.broadcast_to(b, (6, 4, 4)).copy()))
    np.testing.assert_array_equal(quat.mul(a[2, 1], b[1]), out[2, 1])
    assert quat.mul(a, b[1]).shape == (6, 4, 4)
    with pytest.raises(mlayer.InvalidArgumentError):
        quat.mul(random_quats(rng, (3,)), random_quats(rng, (5,)))


def test_mul_identity_and_associativity():
    rng = np.random.default_rng(3)
    a, b, c = (random_quats(rng, (50,)) for _ in range(3))
    np.testing.assert_array_equal(quat.mul(a, [1.0, 0, 0, 0]), a)
    np.testing.assert_allclose(quat.mul(quat.mul(a, b), c), quat.mul(a, quat.mul(b, c)),
                               rtol=0, atol=1e-15)


@pytest.mark.parametrize("shape", SHAPES)
def test_conj_is_the_inverse(shape):
    rng = np.random.default_rng(4)
    q = random_quats(rng, shape)
    qc = quat.conj(q)
    assert_same_rotation(qc, sp_quat(sp(q).inv(), shape))
    np.testing.assert_allclose(quat.mul(q, qc), np.broadcast_to([1.0, 0, 0, 0], q.shape),
                               rtol=0, atol=1e-15)


def test_normalize():
    rng = np.random.default_rng(5)
    q = random_quats(rng, (40,))
    scale = rng.choice([1e-200, 1e-3, 1.0, 7.5, 1e200], size=(40, 1))
    out = quat.normalize(q * scale)
    np.testing.assert_allclose(out, q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, rtol=0, atol=1e-15)


def test_inputs_are_not_modified_and_outputs_are_new():
    rng = np.random.default_rng(6)
    q = random_quats(rng, (10,))
    keep = q.copy()
    for f in (quat.conj, quat.normalize, quat.log):
        out = f(q)
        assert not np.shares_memory(out, q)
    quat.continuous(q)
    np.testing.assert_array_equal(q, keep)


def test_other_dtypes_and_layouts_are_converted():
    rng = np.random.default_rng(7)
    q = random_quats(rng, (10, 3))
    strided = np.asfortranarray(q)[:, 1]  # not C-contiguous
    np.testing.assert_array_equal(quat.log(strided), quat.log(np.ascontiguousarray(strided)))
    q32 = q.astype(np.float32)
    np.testing.assert_array_equal(quat.conj(q32), quat.conj(q32.astype(np.float64)))
    assert quat.mul(q.tolist(), q.tolist()).shape == (10, 3, 4)


def test_empty_arrays():
    assert quat.mul(np.empty((0, 4)), np.empty((0, 4))).shape == (0, 4)
    assert quat.log(np.empty((0, 2, 4))).shape == (0, 2, 3)
    assert quat.exp(np.empty((0, 3))).shape == (0, 4)
    assert quat.from_euler(np.empty((0, 3)), "ZXY").shape == (0, 4)
    assert quat.to_euler(np.empty((0, 4)), "ZXY").shape == (0, 3)
    assert quat.slerp(np.empty((0, 4)), np.empty((0, 4)), 0.5).shape == (0, 4)
    assert quat.continuous(np.empty((0, 4))).shape == (0, 4)


# ------------------------------------------------------------------------------- exp and log

SPECIAL_ANGLES = [0.0, 1e-300, 1e-12, 1e-9, 1e-6, 0.5, np.pi / 2, np.pi - 1e-6, np.pi - 1e-9,
                  np.pi - 1e-12]


@pytest.mark.parametrize("shape", SHAPES)
def test_exp_matches_scipy(shape):
    rng = np.random.default_rng(10)
    v = random_rotvecs(rng, shape)
    out = quat.exp(v)
    assert out.shape == tuple(shape) + (4,)
    ref = sp_quat(Rotation.from_rotvec(v.reshape(-1, 3)), shape)
    np.testing.assert_allclose(out, ref, rtol=0, atol=TOL)


@pytest.mark.parametrize("shape", SHAPES)
def test_log_matches_scipy(shape):
    rng = np.random.default_rng(11)
    q = random_quats(rng, shape)
    out = quat.log(q)
    assert out.shape == tuple(shape) + (3,)
    ref = sp(q).as_rotvec().reshape(tuple(shape) + (3,))
    np.testing.assert_allclose(out, ref, rtol=0, atol=TOL)
    np.testing.assert_array_equal(quat.log(-q), out)


@pytest.mark.parametrize("angle", SPECIAL_ANGLES)
def test_exp_log_near_zero_and_pi(angle):
    rng = np.random.default_rng(12)
    v = random_rotvecs(rng, (200,), angle)
    q = quat.exp(v)
    np.testing.assert_allclose(q, Rotation.from_rotvec(v).as_quat(scalar_first=True),
                               rtol=0, atol=TOL)
    back = quat.log(q)
    np.testing.assert_allclose(back, Rotation.from_quat(q, scalar_first=True).as_rotvec(),
                               rtol=0, atol=TOL)
    # relative accuracy of the round trip: small angles keep all their digits
    err = np.linalg.norm(back - v, axis=-1)
    assert np.all(err <= 4e-16 * angle + (2e-15 if angle > 3 else 0.0)), err.max()


def test_log_of_unnormalized_is_log_of_rotation():
    rng = np.random.default_rng(13)
    q = random_quats(rng, (50,))
    np.testing.assert_allclose(quat.log(q * 3.0), quat.log(q), rtol=0, atol=1e-15)


# ------------------------------------------------------------------------------- slerp


def slerp_reference(a, b, t):
    """What scipy's Slerp computes: a * exp(t * log(a^-1 b)), on flattened arrays."""
    ra, rb = sp(a), sp(b)
    r = ra * Rotation.from_rotvec((ra.inv() * rb).as_rotvec() * np.reshape(t, (-1, 1)))
    return sp_quat(r, np.shape(a)[:-1])


@pytest.mark.parametrize("shape", SHAPES)
def test_slerp_matches_scipy(shape):
    rng = np.random.default_rng(20)
    a, b = random_quats(rng, shape), random_quats(rng, shape)
    t = rng.uniform(size=shape)
    out = quat.slerp(a, b, t)
    assert out.shape == a.shape
    assert_same_rotation(out, slerp_reference(a, b, t))
    np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, rtol=0, atol=1e-15)


def test_slerp_against_scipy_slerp_class():
    rng = np.random.default_rng(21)
    keys = random_quats(rng, (2,))
    times = np.linspace(0.0, 1.0, 11)
    ref = Slerp([0.0, 1.0], sp(keys))(times).as_quat(scalar_first=True)
    out = quat.slerp(keys[0], keys[1], times)  # t broadcasts against single quaternions
    assert out.shape == (11, 4)
    assert_same_rotation(out, ref)


def test_slerp_endpoints_and_sign_of_b():
    rng = np.random.default_rng(22)
    a, b = random_quats(rng, (100,)), random_quats(rng, (100,))
    assert_same_rotation(quat.slerp(a, b, 0.0), a, 1e-15)
    assert_same_rotation(quat.slerp(a, b, 1.0), b, 1e-15)
    t = rng.uniform(size=100)
    assert_same_rotation(quat.slerp(a, -b, t), quat.slerp(a, b, t), 1e-15)
    # the shorter arc: never further from a than b is
    assert np.all(rotation_distance(a, quat.slerp(a, b, t)) <= rotation_distance(a, b) + 1e-15)


@pytest.mark.parametrize("gap", [0.0, 1e-15, 1e-9, 1e-5])
def test_slerp_nearly_equal_and_opposite(gap):
    rng = np.random.default_rng(23)
    a = random_quats(rng, (50,))
    b = quat.mul(a, quat.exp(random_rotvecs(rng, (50,), gap)))
    t = rng.uniform(size=50)
    for bb in (b, -b):
        out = quat.slerp(a, bb, t)
        assert np.all(np.isfinite(out))
        np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, rtol=0, atol=1e-15)
        assert_same_rotation(out, slerp_reference(a, b, t), 1e-15)


def test_slerp_broadcasts_over_time_and_joints():
    rng = np.random.default_rng(24)
    a, b = random_quats(rng, (3,)), random_quats(rng, (3,))
    t = np.linspace(0, 1, 5)[:, None]
    out = quat.slerp(a, b, t)
    assert out.shape == (5, 3, 4)
    for i in range(5):
        np.testing.assert_array_equal(out[i], quat.slerp(a, b, np.full(3, t[i, 0])))
    with pytest.raises(ValueError):
        quat.slerp(a, b, np.zeros(4))


# ------------------------------------------------------------------------------- Euler angles


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("degrees", [True, False])
@pytest.mark.parametrize("shape", SHAPES)
def test_from_euler_matches_scipy(order, degrees, shape):
    rng = np.random.default_rng(30)
    lim = 180.0 if degrees else np.pi
    angles = rng.uniform(-lim, lim, size=tuple(shape) + (3,))
    out = quat.from_euler(angles, order, degrees=degrees)
    assert out.shape == tuple(shape) + (4,)
    ref = sp_quat(Rotation.from_euler(order, angles.reshape(-1, 3), degrees=degrees), shape)
    assert_same_rotation(out, ref)
    np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, rtol=0, atol=1e-15)


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("degrees", [True, False])
@pytest.mark.parametrize("shape", SHAPES)
def test_to_euler_matches_scipy(order, degrees, shape):
    rng = np.random.default_rng(31)
    q = random_quats(rng, shape)
    out = quat.to_euler(q, order, degrees=degrees)
    assert out.shape == tuple(shape) + (3,)
    ref = sp(q).as_euler(order, degrees=degrees).reshape(tuple(shape) + (3,))
    scale = 180.0 / np.pi if degrees else 1.0
    assert np.max(wrapped_diff(out, ref, 2 * np.pi * scale), initial=0.0) <= TOL * scale
    assert_same_rotation(quat.from_euler(out, order, degrees=degrees), q)


def test_to_euler_of_unnormalized_and_negated():
    rng = np.random.default_rng(32)
    q = random_quats(rng, (50,))
    for order in ORDERS:
        ref = quat.to_euler(q, order)
        np.testing.assert_allclose(quat.to_euler(2.5 * q, order), ref, rtol=0, atol=1e-12)
        assert np.max(wrapped_diff(quat.to_euler(-q, order), ref, 360.0)) <= 1e-12


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("middle", [90.0, -90.0, 90.0 - 1e-9, -90.0 + 1e-6, 89.0])
def test_to_euler_gimbal_lock(order, middle):
    rng = np.random.default_rng(33)
    angles = rng.uniform(-180, 180, size=(100, 3))
    angles[:, 1] = middle
    q = quat.from_euler(angles, order)
    out = quat.to_euler(q, order)
    assert_same_rotation(quat.from_euler(out, order), q)
    np.testing.assert_allclose(out[:, 1], middle, rtol=0, atol=1e-10)
    if abs(middle) == 90.0:
        np.testing.assert_array_equal(out[:, 2], 0.0)  # the third angle carries nothing
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy warns about gimbal lock
        ref = Rotation.from_euler(order, sp(q).as_euler(order, degrees=True), degrees=True)
    assert_same_rotation(quat.from_euler(out, order), ref.as_quat(scalar_first=True), 1e-6)


def test_euler_round_trip_inside_canonical_ranges():
    rng = np.random.default_rng(34)
    angles = np.column_stack([rng.uniform(-179, 179, 200), rng.uniform(-89, 89, 200),
                              rng.uniform(-179, 179, 200)])
    for order in ORDERS:
        np.testing.assert_allclose(quat.to_euler(quat.from_euler(angles, order), order), angles,
                                   rtol=0, atol=1e-10)


def test_euler_order_names():
    assert quat.euler_order("ZXY") == 4
    with pytest.raises(mlayer.InvalidArgumentError, match="uppercase"):
        quat.euler_order("zxy")  # scipy reads lowercase as extrinsic: refuse, don't guess
    for bad in ["XYX", "ABC", "XY", "XYZW", "", "ZXÿ"]:
        with pytest.raises(mlayer.InvalidArgumentError):
            quat.from_euler([0.0, 0.0, 0.0], bad)
    with pytest.raises(ValueError):
        quat.to_euler([1.0, 0, 0, 0], 3)


# ------------------------------------------------------------------------------- continuity


@pytest.mark.parametrize("track_shape", [(), (3,), (2, 3)])
def test_continuous(track_shape):
    rng = np.random.default_rng(40)
    n = 60
    base = random_quats(rng, track_shape)
    steps = random_rotvecs(rng, (n,) + track_shape, 0.3)
    smooth = np.empty((n,) + track_shape + (4,))
    smooth[0] = base
    for f in range(1, n):  # a random walk, 0.3 rad per frame
        smooth[f] = quat.mul(smooth[f - 1], quat.exp(steps[f]))
    signs = rng.choice([-1.0, 1.0], size=(n,) + track_shape + (1,))
    q = smooth * signs
    out = quat.continuous(q)
    assert out.shape == q.shape
    np.testing.assert_array_equal(out[0], q[0])
    np.testing.assert_array_equal(out, smooth * signs[0])
    assert np.all(np.sum(out[1:] * out[:-1], axis=-1) >= 0)


def test_continuous_predictive():
    """A spin that speeds up to 250 degrees per frame (6 degrees per frame more each frame):
    the predictive rule recovers the true track (up to the first sample's sign) where the
    nearest sign turns the spin back; on dense data both rules agree."""
    rng = np.random.default_rng(41)
    n = 120
    w = np.minimum(np.radians(20.0) + np.radians(6.0) * np.arange(n), np.radians(250.0))
    th = np.cumsum(w)[:, None]
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]])
    true = np.concatenate([np.cos(th / 2)[..., None].repeat(2, 1),
                           np.sin(th / 2)[..., None] * axis[None]], axis=-1)  # (n, 2, 4)
    signs = rng.choice([-1.0, 1.0], size=(n, 2, 1))
    q = true * signs
    out = quat.continuous(q, predictive=True)
    np.testing.assert_array_equal(out, true * signs[0])
    near = quat.continuous(q)
    assert np.any(np.sum(near * out, axis=-1) < 0)
    slow = quat.continuous(q[:10], predictive=True)  # steps up to 74 degrees
    np.testing.assert_array_equal(slow, quat.continuous(q[:10]))


def test_continuous_needs_a_frame_axis():
    with pytest.raises(mlayer.InvalidArgumentError):
        quat.continuous([1.0, 0, 0, 0])


# ------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("call", [
    lambda: quat.mul(np.zeros((3, 3)), np.zeros((3, 4))),
    lambda: quat.conj(np.zeros((3, 5))),
    lambda: quat.normalize(np.zeros(3)),
    lambda: quat.exp(np.zeros((2, 4))),
    lambda: quat.log(np.zeros((2, 3))),
    lambda: quat.slerp(np.zeros((2, 3)), np.zeros((2, 4)), 0.5),
    lambda: quat.from_euler(np.zeros((2, 4)), "XYZ"),
    lambda: quat.to_euler(np.zeros((2, 3)), "XYZ"),
    lambda: quat.log(1.0),
    lambda: quat.log("not a number"),
], ids=["mul", "conj", "normalize", "exp", "log", "slerp", "from_euler", "to_euler", "scalar",
        "string"])
def test_wrong_shape_raises(call):
    with pytest.raises(mlayer.Error) as e:
        call()
    assert isinstance(e.value, ValueError)


NAN_Q = np.array([[1.0, 0, 0, 0], [np.nan, 0, 0, 0]])


@pytest.mark.parametrize("call", [
    lambda: quat.normalize(NAN_Q),
    lambda: quat.normalize(np.zeros((2, 4))),
    lambda: quat.normalize([np.inf, 0, 0, 0]),
    lambda: quat.exp([[0.1, np.nan, 0.0]]),
    lambda: quat.log(NAN_Q),
    lambda: quat.log(np.zeros(4)),
    lambda: quat.slerp(NAN_Q, NAN_Q[:1], 0.5),
    lambda: quat.slerp([1.0, 0, 0, 0], [0, 1.0, 0, 0], np.nan),
    lambda: quat.from_euler([[0.0, np.nan, 0.0]], "ZXY"),
    lambda: quat.from_euler([[0.0, np.inf, 0.0]], "ZXY", degrees=False),
    lambda: quat.to_euler(NAN_Q, "ZXY"),
], ids=["normalize-nan", "normalize-zero", "normalize-inf", "exp", "log", "log-zero",
        "slerp", "slerp-t", "from_euler", "from_euler-rad", "to_euler"])
def test_nan_raises(call):
    with pytest.raises(mlayer.InvalidArgumentError) as e:
        call()
    assert isinstance(e.value, ValueError)
    assert e.value.code == lib.MLR_E_INVALID_ARG


def test_scipy_bridge_round_trips_and_agrees_with_our_rotations(rng):
    from scipy.spatial.transform import Rotation
    q = mlayer.quat.normalize(rng.normal(size=(50, 4)))
    r = mlayer.quat.to_scipy(q)
    # scipy applies the same rotation as mlayer's exp/log convention: compare rotation vectors
    np.testing.assert_allclose(r.as_rotvec(), mlayer.quat.log(np.where(q[:, :1] < 0, -q, q)),
                               atol=1e-12)
    back = mlayer.quat.from_scipy(r)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", back, q)), 1.0, atol=1e-12)
    assert mlayer.quat.from_scipy(Rotation.identity()).tolist() == [1.0, 0.0, 0.0, 0.0]
    # the naive call reads the scalar as z: a different rotation
    naive = Rotation.from_quat(q)
    assert np.degrees((naive.inv() * r).magnitude()).mean() > 30
    np.testing.assert_array_equal(mlayer.quat.from_scalar_last(mlayer.quat.to_scalar_last(q)), q)
