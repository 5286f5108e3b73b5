"""The guards ease the joint limits' corrections in time (libmlayer/guards/limits_ease.c).

Per-frame limits brake a fast joint within the few frames it takes to cross the soft zone: on
Bandai's walk at alpha 2 the knees stopped at their bound in 30 ms and the feet's acceleration
was 2.07x the larger of the input's and the unguarded synthesis's (1.58x on CMU 131_01 at
alpha 3; 2.6-3.7x on Xia's walks). The guards now treat the correction like an audio
limiter's gain reduction: each component of its rotation vector, positive and negative parts
apart, goes through a running maximum and a Gaussian (sigma 40 ms, both cut at 2.5 sigma).
The reference here is written with scipy's maximum filter and numpy's convolution.
"""
import re
import warnings

import numpy as np
import pytest
from scipy.ndimage import maximum_filter1d

import mlayer

FOOT = re.compile(r"(foot|toe|ankle)", re.I)
LIMITS_ONLY = dict(floor=None, keep_contacts=False)
RAW = dict(limits=None, floor=None, keep_contacts=False)


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], -1)


def _rotvec(q: np.ndarray) -> np.ndarray:
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1)
    k = np.where(s > 1e-300, 2 * np.arctan2(s, q[..., 0]) / np.maximum(s, 1e-300), 2.0)
    return q[..., 1:] * k[..., None]


def _quat(v: np.ndarray) -> np.ndarray:
    a = np.linalg.norm(v, axis=-1)
    k = np.where(a > 1e-300, np.sin(a / 2) / np.maximum(a, 1e-300), 0.5)
    return np.concatenate([np.cos(a / 2)[..., None], v * k[..., None]], -1)


def reference_ease(raw: np.ndarray, lim: np.ndarray, fps: float) -> np.ndarray:
    sigma = 0.04 * fps
    r = int(np.ceil(2.5 * sigma))
    kern = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    kern /= kern.sum()

    def ease(x: np.ndarray) -> np.ndarray:
        m = maximum_filter1d(x, 2 * r + 1, mode="nearest")
        return np.convolve(np.pad(m, r, mode="edge"), kern, mode="valid")

    raw = raw / np.linalg.norm(raw, axis=-1, keepdims=True)
    conj = raw * np.array([1.0, -1.0, -1.0, -1.0])
    v = _rotvec(_qmul(lim, conj))
    out = lim.copy()
    for j in range(raw.shape[1]):
        if not np.any(v[:, j]):
            continue
        e = np.zeros_like(v[:, j])
        for k in range(3):
            c = v[:, j, k]
            e[:, k] = ease(np.maximum(c, 0)) - ease(np.maximum(-c, 0))
        moved = np.any(e != 0, axis=-1)
        out[moved, j] = _qmul(_quat(e[moved]), raw[moved, j])
    return out


def _same_rotation(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(1.0 - np.abs(np.sum(a * b, axis=-1))))


@pytest.mark.parametrize("name, alpha", [("bandai1_walk_happy_001.bvh", 2.0),
                                         ("lafan1_clip_a.bvh", 2.0)])
def test_eased_limits_match_the_reference(mocap, name, alpha):
    """On clips where no hinge swings from one bound to the other within the window (on
    others the guards ease and clamp what is left outside a hinge's range, guards.c
    ease_limits, which the reference does not do)."""
    m = mlayer.read_bvh(mocap / name)
    raw = mlayer.stylize(m, alpha, **RAW)
    out = mlayer.stylize(m, alpha, **LIMITS_ONLY)
    per_frame, _ = mlayer.joint_limits(m).apply(raw.rot, alpha)
    want = reference_ease(np.asarray(raw.rot), np.asarray(per_frame), m.fps)
    assert _same_rotation(np.asarray(out.rot), want) < 1e-12
    # and the easing did something: the per-frame limits differ from it
    assert _same_rotation(np.asarray(per_frame), want) > 1e-4


def _foot_pop(m: mlayer.Motion, out: mlayer.Motion, ref: mlayer.Motion) -> float:
    feet = [j for j, n in enumerate(m.joint_names) if FOOT.search(n) and "index" not in n.lower()]

    def acc(x: mlayer.Motion) -> float:
        P = np.asarray(x.positions())[:, feet]
        return float(np.linalg.norm(P[2:] - 2 * P[1:-1] + P[:-2], axis=-1).max())
    return acc(out) / max(acc(m), acc(ref))


@pytest.mark.parametrize("name, alpha", [("bandai1_walk_happy_001.bvh", 2.0),  # 2.07 per frame
                                         ("cmu_131_01_mj_style_walk.bvh", 3.0)])  # 1.58
def test_limits_alone_do_not_pop_the_feet(mocap, name, alpha):
    m = mlayer.read_bvh(mocap / name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = mlayer.stylize(m, alpha, **LIMITS_ONLY)
        ref = mlayer.stylize(m, alpha, **RAW)
    assert _foot_pop(m, out, ref) <= 1.5


def _turns(rot: np.ndarray) -> np.ndarray:
    """Degrees each local rotation turns from the frame before: (N - 1, J)."""
    d = np.abs(np.einsum("nji,nji->nj", rot[1:], rot[:-1]))
    return np.degrees(2.0 * np.arccos(np.clip(d, 0.0, 1.0)))


def test_cleanup_keeps_the_eased_limits_continuous(mocap) -> None:
    """Where the eased limits leave a joint outside its range, the cleanup's hook corrects only
    what its IK adds. CMU 60_10's right thigh at alpha 3 passes the far side of its twist
    range around frame 303: limited in full on the frames the contact IK solved (and in
    their blends), the nearest bound there is the other one, and the thigh turned 87-100
    degrees in a frame where the unguarded synthesis turns 18-29 (179 at frame 315 where it
    turns 57, before the synthesis's angles were saturated below a half turn)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = mlayer.read_bvh(mocap / "cmu_60_10_salsa_dance.bvh")
        out = mlayer.stylize(m, 3.0)
        ref = mlayer.stylize(m, 3.0, **RAW)
    j = list(m.joint_names).index("rThigh")
    t_out = _turns(np.asarray(out.rot))[295:320, j]
    t_ref = _turns(np.asarray(ref.rot))[295:320, j]
    assert np.all(t_out <= 3.0 * t_ref + 5.0), (t_out.round(1), t_ref.round(1))
