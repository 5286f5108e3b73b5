"""Alpha over time (issue 43, item 2): mlayer.AlphaCurve against the smoothstep written in numpy,
the synthesis with a curve against M' = Mb (+) alpha(t) delta_c written in numpy, stylize with
constant keys bit for bit the constant alpha's (the guards included), the guards taking each
group's peak alpha, frames where the curve is flat equal to the constant synthesis, and the
errors of bad keys."""
import pickle

import numpy as np
import pytest
from conftest import scale_turn

import mlayer
from mlayer import AlphaCurve
from mlayer.pipeline.pipeline import guard_alphas


@pytest.fixture(scope="module")
def clip():
    return mlayer.data.load_sample()[:360]


def _smoothstep_reference(times, values, t):
    """The curve by its formula, in numpy."""
    times, values, t = (np.asarray(x, dtype=float) for x in (times, values, t))
    out = np.empty_like(t)
    for i, x in enumerate(t):
        if x <= times[0]:
            out[i] = values[0]
        elif x >= times[-1]:
            out[i] = values[-1]
        else:
            k = np.searchsorted(times, x, side="right") - 1
            u = (x - times[k]) / (times[k + 1] - times[k])
            out[i] = values[k] + (values[k + 1] - values[k]) * (10 * u**3 - 15 * u**4 + 6 * u**5)
    return out


def test_curve_is_the_smoothstep_between_keys():
    rng = np.random.default_rng(43)
    for n in (1, 2, 3, 7):
        times = np.cumsum(rng.uniform(0.1, 2.0, n)) - 0.5
        values = rng.uniform(-2.0, 4.0, n)
        c = AlphaCurve(list(zip(times, values)))
        t = np.concatenate([np.linspace(times[0] - 1, times[-1] + 1, 500), times])
        np.testing.assert_allclose(c(t), _smoothstep_reference(times, values, t),
                                   rtol=0, atol=1e-13)
        np.testing.assert_array_equal(c(times), values)  # through the keys exactly
        v = c(t)  # within the keys
        assert v.min() >= values.min() and v.max() <= values.max()
    # C2: the slope and the second difference vanish at an inner key
    c = AlphaCurve("0:1,2.5:3,4:1")
    h = 1e-3
    w = c(2.5 + h * np.arange(-2, 3))
    assert abs(w[3] - w[2]) / h < 1e-4 and abs(w[1] - w[2]) / h < 1e-4
    assert abs(w[4] - 2 * w[3] + w[2]) / h**2 < 0.1
    assert c(np.array([[1.25]])).shape == (1, 1) and float(c(1.25)) == pytest.approx(2.0)


def test_curve_forms_and_text():
    c = AlphaCurve.parse(" 0 : 1, 2.5:3 ,4:1")
    assert c == AlphaCurve([(0, 1), (2.5, 3), (4, 1)]) == AlphaCurve(c)
    assert str(c) == "0:1,2.5:3,4:1" and c.keys == [(0.0, 1.0), (2.5, 3.0), (4.0, 1.0)]
    assert c.peak == 3.0 and AlphaCurve("0:1,1:-4,2:4").peak == -4.0
    assert pickle.loads(pickle.dumps(c)) == c
    assert hash(c) == hash(AlphaCurve(str(c)))
    np.testing.assert_array_equal(c.sample(5, 2.0), c(np.arange(5) / 2.0))
    assert c(np.array([])).shape == (0,)
    with pytest.raises(mlayer.InvalidArgumentError, match="time 1 is not finite"):
        c([0.0, np.nan])
    with pytest.raises(AttributeError):
        c.times = np.zeros(3)
    with pytest.raises(ValueError):
        c.times[0] = 5.0


@pytest.mark.parametrize("keys, words", [
    ("0:1,2:3,2:1", "times must increase: key 2"),
    ([(0, 1), (1, np.nan)], "alpha of key 1"),
    ([(0, 1), (np.inf, 2)], "time of key 1"),
    ([], "no keys"),
    ("", "empty"),
    ("0:1,2", "key 1 '2' is not TIME:ALPHA"),
    ("0:1,a:2", "key 1 'a:2': not two numbers"),
    ([(0, 1, 2)], "key 0 (0, 1, 2) is not a (time, alpha) pair"),
    (5, "expected (time, alpha) pairs"),
])
def test_bad_keys_name_the_key(keys, words):
    with pytest.raises(mlayer.InvalidArgumentError, match=None) as e:
        AlphaCurve(keys)
    assert words in str(e.value)


def _quat_mul(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2],
                    axis=-1)


def _quat_exp(v):
    """exp of full-angle rotation vectors: (cos |v|/2, sin |v|/2 v/|v|)."""
    th = np.linalg.norm(v, axis=-1, keepdims=True)
    s = np.where(th > 0, np.sin(th / 2) / np.where(th > 0, th, 1), 0.5)
    return np.concatenate([np.cos(th / 2), s * v], axis=-1)


def test_synthesis_with_curves_is_the_numpy_formula(clip):
    L = mlayer.decompose(clip)
    assert L.body_joint == 0
    curve = AlphaCurve("0:1,0.8:3,1.6:0.5,2.4:-1,2.9:1")
    arms = AlphaCurve("0:0,3:2")
    out = L.synthesize(curve, {"Left*": arms, "Head": 0.25}, root_alpha=1.5)
    # the alphas of every frame, composed in numpy
    t = np.arange(clip.n_frames) / clip.fps
    a = np.repeat(_smoothstep_reference(curve.times, curve.values, t)[:, None],
                  1 + clip.n_joints, axis=1)
    a[:, 0] = 1.5
    names = clip.joint_names
    left = [1 + k for k, n in enumerate(names) if n.startswith("Left")]
    a[:, left] = _smoothstep_reference(arms.times, arms.values, t)[:, None]
    a[:, 1 + names.index("Head")] = 0.25
    np.testing.assert_allclose(L.alphas_over_time(curve, {"Left*": arms, "Head": 0.25}, 1.5), a,
                               rtol=0, atol=1e-13)
    base, control = L.base, np.asarray(L.control)
    root = base.root_pos + a[:, :1] * control[:, 0]
    q = _quat_mul(base.rot, _quat_exp(scale_turn(control[:, 1:], a[:, 1:])))
    q *= np.where(np.sum(q * base.rot, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    np.testing.assert_allclose(out.root_pos, root, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.rot, q, rtol=0, atol=1e-12)


def test_constant_keys_are_the_constant_alpha_bit_for_bit(clip):
    a, ra = mlayer.stylize(clip, 2.0, {"Left*": 0.5}, return_report=True)
    b, rb = mlayer.stylize(clip, [(0.0, 2.0), (1.0, 2.0)], {"Left*": "0:0.5,3:0.5"},
                           return_report=True)
    np.testing.assert_array_equal(a.rot, b.rot)
    np.testing.assert_array_equal(a.root_pos, b.root_pos)
    assert ra == rb and ra.limits_applied
    # keys all 1: the denoised motion
    np.testing.assert_array_equal(mlayer.denoise(clip).rot, mlayer.stylize(clip, "0:1,2:1").rot)


def test_the_guards_take_each_groups_peak(clip):
    s = mlayer.Synthesis(clip)
    curve = AlphaCurve("0:1,1:1,1.5:2.5,2:2.5,2.9:1")
    out, rep = s.run(curve, {"Left*": 0.5})
    assert rep.limits_applied  # the peak is 2.5
    L = s.layers
    rows = L.alphas_over_time(curve, {"Left*": 0.5})
    peaks = rows.max(axis=0)
    left = [n.startswith("Left") for n in clip.joint_names]
    assert peaks[0] == 2.5 and any(left) and np.all(peaks[1:][left] == 0.5)
    ref, rep2 = s.guard(L.synthesize(curve, {"Left*": 0.5}), peaks)
    # the same alphas at the same frame times (i * frame_time): the same bits
    np.testing.assert_array_equal(out.rot, ref.rot)
    np.testing.assert_array_equal(out.root_pos, ref.root_pos)
    assert rep == rep2
    # a curve within [-1, 1] runs no limits, as a constant alpha within it
    assert not s.run(AlphaCurve("0:1,1:-1,2:0.5"))[1].limits_applied
    # a curve that peaks at 1 and dips below is no denoise for the guards: they take the
    # double just below 1 (which the limits read as 1)
    dip = AlphaCurve("0:1,1:0.5,2.5:1")
    rows = L.alphas_over_time(dip)
    a = guard_alphas(rows)
    assert np.all(a == np.nextafter(1.0, 0.0))
    np.testing.assert_array_equal(guard_alphas(L.alphas_over_time(AlphaCurve("0:1,3:1"))),
                                  np.ones(rows.shape[1]))
    out, rep = s.run(dip)
    raw = L.synthesize(dip)
    ref, _ = s.guard(raw, a)
    np.testing.assert_array_equal(out.rot, ref.rot)
    as_denoise, _ = s.guard(raw, np.ones(rows.shape[1]))
    assert np.abs(out.rot - as_denoise.rot).max() > 1e-6  # (the denoise mode differs)
    assert not rep.limits_applied


def test_flat_stretches_are_the_constant_synthesis(clip):
    s = mlayer.Synthesis(clip, limits=None, floor=None, keep_contacts=False)
    curve = AlphaCurve("0:1,0.9:1,1.5:3,2.2:3,2.9:1")
    out, _ = s.run(curve)
    a = curve.sample(clip.n_frames, clip.fps)
    one, three = s.run(1.0)[0], s.run(3.0)[0]
    for value, ref in ((1.0, one), (3.0, three)):
        flat = a == value
        assert flat.sum() > 60
        np.testing.assert_allclose(out.rot[flat], ref.rot[flat], rtol=0, atol=1e-12)
    between = (a > 1) & (a < 3)
    assert between.sum() > 60
    assert not np.allclose(out.rot[between], one.rot[between])


def test_bad_alpha_arguments(clip):
    for alpha, words in (("0:1,0:2", "times must increase"), ({"Left*": 2}, "joints="),
                         ([(0, 1), (1, np.nan)], "alpha of key 1")):
        with pytest.raises(mlayer.InvalidArgumentError) as e:
            mlayer.stylize(clip, alpha)
        assert words in str(e.value)
    with pytest.raises(mlayer.InvalidArgumentError, match="'Tail\\*' matches no joint"):
        mlayer.stylize(clip, 1.0, {"Tail*": "0:1,1:2"})
    with pytest.raises(mlayer.InvalidArgumentError, match="alpha of 'Left\\*'"):
        mlayer.stylize(clip, 1.0, {"Left*": "0:1,x"})
    with pytest.raises(mlayer.InvalidArgumentError, match="alphas_over_time"):
        mlayer.decompose(clip).alphas(AlphaCurve("0:1"))
