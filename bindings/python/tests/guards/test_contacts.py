"""Foot contacts: detection on the real clips, cleanup after stylize, metrics, bad input."""
import numpy as np
import pytest

import mlayer
from mlayer.guards import contacts as C
from mlayer.guards.metrics import body_height, foot_sliding, jitter

WALKS = ["cmu_131_01_mj_style_walk.bvh", "bandai1_walk_happy_001.bvh", "lafan1_clip_a.bvh",
         "ai4a_dog_D1_008_KAN01_002.bvh"]
ALL = WALKS + ["cmu_01_01_playground_jumps.bvh", "cmu_02_03_run_jog_25fps.bvh",
               "cmu_10_01_soccer_kick.bvh", "cmu_60_10_salsa_dance.bvh"]
FEET = {
    "cmu_131_01_mj_style_walk.bvh": ["LeftAnkle", "LeftToe", "RightAnkle", "RightToe"],
    "bandai1_walk_happy_001.bvh": ["Foot_L", "Toes_L", "Foot_R", "Toes_R"],
    "lafan1_clip_a.bvh": ["LeftFoot", "LeftToe", "RightFoot", "RightToe"],
    "cmu_01_01_playground_jumps.bvh": ["LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"],
    "cmu_10_01_soccer_kick.bvh": ["rFoot", "rFoot/End", "lFoot", "lFoot/End"],
    "ai4a_dog_D1_008_KAN01_002.bvh": ["LeftHand", "LeftHand/End", "RightHand", "RightHand/End",
                                      "LeftFoot", "LeftFoot/End", "RightFoot",
                                      "RightFoot/End"],
}


def _read(mocap, name, frames=None):
    m = mlayer.read_bvh(mocap / name)
    return m[:frames] if frames else m


@pytest.mark.parametrize("name", ALL)
def test_feet_found_by_name(mocap, name):
    m = _read(mocap, name)
    names, c = mlayer.detect_contacts(m)
    if name in FEET:
        assert names == FEET[name]
    assert c.dtype == np.bool_ and c.shape == (len(m), len(names))
    assert c.any(axis=0).all(), "every foot point touches the ground somewhere"


@pytest.mark.parametrize("name", WALKS)
def test_walks_alternate(mocap, name):
    m = _read(mocap, name, 1800)
    names, c = mlayer.detect_contacts(m)
    start = int(5.5 * m.fps) if name.startswith("ai4a_dog") else 0  # the dog lies first
    toes = [i for i, n in enumerate(names) if i % 2 == 1]  # toe or End Site of each foot
    for i in toes:
        duty = c[start:, i].mean()
        assert 0.25 < duty < 0.85, (names[i], duty)
        assert len(C.contact_intervals(c[start:, i])) >= 3, names[i]
    # left and right lift off at different times: neither foot's contacts equal the other's
    a, b = c[start:, toes[0]], c[start:, toes[1]]
    assert (a != b).mean() > 0.2


def test_thresholds_scale_with_units_and_frame_rate(mocap):
    m = _read(mocap, "cmu_131_01_mj_style_walk.bvh")
    names, c = mlayer.detect_contacts(m)
    big = m.with_frames(root_pos=m.root_pos * 100.0)
    big = mlayer.Motion.from_arrays(m.joint_names, m.parents, m.offsets * 100.0,
                                    m.root_pos * 100.0, m.rot, frame_time=m.frame_time,
                                    channels=m.skeleton.channels)
    names2, c2 = mlayer.detect_contacts(big)
    assert names2 == names and (c2 != c).mean() < 0.01
    half = m[::4]  # 30 fps
    _, c3 = mlayer.detect_contacts(half)
    assert (c3 != c[::4]).mean() < 0.08


def _jumps(m, names):
    p = C.contact_positions(m, names)
    return np.linalg.norm(np.diff(p, axis=0), axis=-1).max()


@pytest.mark.parametrize("name", WALKS)
def test_stylize_keeps_contacts(mocap, name):
    m = _read(mocap, name, 1800)
    names, c = mlayer.detect_contacts(m)
    raw = mlayer.stylize(m, 2.0, keep_contacts=False)
    fixed = mlayer.stylize(m, 2.0)  # keep_contacts=True is the default
    s_orig, s_raw, s_fix = (foot_sliding(x, c, names) for x in (m, raw, fixed))
    assert s_fix <= 0.5 * s_raw, (s_fix, s_raw)
    # no frame where a foot jumps ("jump": a per-frame step of a contact point far above the
    # clip's own largest step): within 1.5 times the uncleaned clip's largest step
    assert _jumps(fixed, names) <= 1.5 * _jumps(raw, names), body_height(m)
    # bone lengths unchanged (not the "bone" from a static root to the joint that carries the
    # body translation, Bandai's joint_Root -> Hips: stylize scales that path)
    from mlayer.layers.layers import body_translation_joint
    p0, p1 = m.positions(), fixed.positions()
    kids = np.array([j for j in range(1, m.n_joints) if j != body_translation_joint(m)])
    par = m.parents[kids]
    np.testing.assert_allclose(np.linalg.norm(p1[:, kids] - p1[:, par], axis=-1),
                               np.linalg.norm(p0[:, kids] - p0[:, par], axis=-1), atol=1e-6)


@pytest.mark.parametrize("name", WALKS)
def test_stylize_contacts_full_acceptance(mocap, name):
    m = _read(mocap, name, 1800)
    names, c = mlayer.detect_contacts(m)
    raw = mlayer.stylize(m, 2.0, keep_contacts=False)
    fixed = mlayer.stylize(m, 2.0)
    assert foot_sliding(fixed, c, names) <= 1.5 * foot_sliding(m, c, names)
    assert jitter(fixed) <= 1.1 * jitter(raw)


def test_fix_contacts_pins_to_mean_without_reference(mocap):
    m = _read(mocap, "lafan1_clip_a.bvh", 600)
    names, c = mlayer.detect_contacts(m)
    raw = mlayer.stylize(m, 2.0, keep_contacts=False)
    fixed = mlayer.fix_contacts(raw, c, names)
    assert foot_sliding(fixed, c, names) < 0.05 * foot_sliding(raw, c, names)


@pytest.mark.parametrize("name", ["lafan1_clip_a.bvh", "ai4a_dog_D1_008_KAN01_002.bvh"])
def test_fix_contacts_follows_the_reference_within_contacts(mocap, name, monkeypatch):
    # with a reference, a contact point moves as the reference's does (its small motion within
    # the contact, shifted by one horizontal offset per contact) and at the reference's height;
    # without the smoothing of the reference's trajectories, exactly
    m = _read(mocap, name, 900)
    names, c = mlayer.detect_contacts(m)
    raw = mlayer.stylize(m, 2.0, keep_contacts=False)
    fixed = mlayer.fix_contacts(raw, c, names, reference=m, ref_smooth=0.0)
    pf, pm = C.contact_positions(fixed, names), C.contact_positions(m, names)
    tol = 1e-3 * body_height(m)
    both = c[1:] & c[:-1]
    step = np.linalg.norm(np.diff(pf, axis=0) - np.diff(pm, axis=0), axis=-1)
    # all but a few frames (a leg that cannot quite reach) exact to 0.1% of the body height
    assert (step[both] < tol).mean() > 0.995 and step[both].max() < 10 * tol
    dy = np.abs(pf[..., 1] - pm[..., 1])[c]
    assert (dy < tol).mean() > 0.995 and dy.max() < 10 * tol
    assert foot_sliding(fixed, c, names) == pytest.approx(foot_sliding(m, c, names), rel=0.02)


def test_fix_contacts_smooths_the_reference(mocap):
    # by default the targets follow the reference's trajectories smoothed over _REF_SMOOTH
    # seconds: compare with a dense solve of (I + lam^2 D2^T D2) x = y
    m = _read(mocap, "lafan1_clip_a.bvh", 300)
    names, c = mlayer.detect_contacts(m)
    raw = mlayer.stylize(m, 2.0, keep_contacts=False)
    fixed = mlayer.fix_contacts(raw, c, names, reference=m)
    n = len(m)
    d2 = np.diff(np.eye(n), n=2, axis=0)
    lam = (0.02 * m.fps) ** 2  # the default ref_smooth of mlr_cleanup_contacts
    ps = np.linalg.solve(np.eye(n) + lam**2 * d2.T @ d2,
                         C.contact_positions(m, names).reshape(n, -1)).reshape(n, -1, 3)
    pf = C.contact_positions(fixed, names)
    both = c[1:] & c[:-1]
    step = np.linalg.norm(np.diff(pf, axis=0) - np.diff(ps, axis=0), axis=-1)[both]
    assert np.median(step) < 1e-6 * body_height(m)  # (2e-5 when following it unsmoothed)
    assert np.abs(pf[..., 1] - ps[..., 1])[c].max() < 1e-2 * body_height(m)


def test_foot_sliding_definition():
    # one joint moving 1 unit/frame along x at 10 fps, in contact on frames 2..5
    n = 8
    root = np.zeros((n, 3))
    root[:, 0] = np.arange(n)
    m = mlayer.Motion.from_arrays(["foot"], [-1], [[0, 0, 0]], root,
                                  np.tile([1.0, 0, 0, 0], (n, 1, 1)), fps=10)
    c = np.zeros((n, 1), bool)
    c[2:6] = True
    assert foot_sliding(m, c, ["foot"]) == pytest.approx(10.0)
    root[:, 1] = np.arange(n) * 5.0  # vertical motion is not sliding
    m2 = m.with_frames(root_pos=root)
    assert foot_sliding(m2, c, ["foot"]) == pytest.approx(10.0)
    assert np.isnan(foot_sliding(m, np.zeros((n, 1), bool), ["foot"]))


def test_no_feet_message():
    m = mlayer.Motion.from_arrays(["root", "a", "b"], [-1, 0, 1], [[0, 0, 0], [0, 1, 0],
                                  [0, 1, 0]], np.zeros((5, 3)), np.tile([1.0, 0, 0, 0], (5, 3, 1)))
    with pytest.raises(mlayer.InvalidArgumentError, match=r"no feet found.*joints=.*root, a, b"):
        mlayer.detect_contacts(m)
    # stylize's default cleanup leaves such skeletons alone
    assert mlayer.guards.cleanup.keep_contacts(m, m) is m


def test_bad_input(mocap):
    m = _read(mocap, "cmu_131_01_mj_style_walk.bvh", 200)
    with pytest.raises(mlayer.InvalidArgumentError, match="no joint named 'Nope'"):
        mlayer.detect_contacts(m, joints=["Nope"])
    with pytest.raises(mlayer.InvalidArgumentError, match="listed twice"):
        mlayer.detect_contacts(m, joints="LeftToe,LeftToe")
    with pytest.raises(mlayer.InvalidArgumentError, match="has no End Site"):
        mlayer.detect_contacts(m, joints=["LeftKnee/End"])
    with pytest.raises(mlayer.InvalidArgumentError, match="at least 3 frames"):
        mlayer.detect_contacts(m[:2])
    names, c = mlayer.detect_contacts(m, joints="LeftAnkle, RightAnkle")
    assert names == ["LeftAnkle", "RightAnkle"]
    with pytest.raises(mlayer.InvalidArgumentError, match="bool array"):
        mlayer.fix_contacts(m, c.astype(int), names)
    with pytest.raises(mlayer.InvalidArgumentError, match="bool array"):
        mlayer.fix_contacts(m, c[:-1], names)
    with pytest.raises(mlayer.InvalidArgumentError, match="reference has"):
        mlayer.fix_contacts(m, c, names, reference=m[:-1])
    with pytest.raises(mlayer.InvalidArgumentError, match="bool array"):
        foot_sliding(m, c[:, :1], names)


@pytest.mark.parametrize("name", WALKS)
@pytest.mark.parametrize("kind", ["resample", "timewarp"])
def test_retiming_keeps_contacts(mocap, name, kind):
    # resample / timewarp pin the feet by default: contacts of the original carried to the new
    # frames, the feet following the original's SLERP retiming (unsmoothed)
    m = _read(mocap, name, 900)
    names, c = mlayer.detect_contacts(m)
    if kind == "resample":
        raw = mlayer.resample(m, fps=0.5 * m.fps, keep_contacts=False)
        fixed = mlayer.resample(m, fps=0.5 * m.fps)
        ref = mlayer.slerp_resample(m, n_frames=len(raw))
        src = np.arange(len(raw)) * (len(m) - 1) / (len(raw) - 1)
    else:
        raw, t = mlayer.timewarp(m, keep_contacts=False, return_map=True)
        fixed = mlayer.timewarp(m)
        ref = mlayer.slerp_resample(m, time_map=t)
        src = np.interp(np.arange(len(raw)), t, np.arange(len(m)))
    assert len(fixed) == len(raw) and fixed.fps == raw.fps
    c2 = c[np.rint(src).astype(int)]
    assert foot_sliding(fixed, c2, names) <= 1.5 * foot_sliding(ref, c2, names)
    assert jitter(fixed) <= 1.1 * jitter(raw)
    assert _jumps(fixed, names) <= 1.5 * _jumps(raw, names)


# ---- the C detection against the numpy implementation it replaced --------------------------
# The numpy code below is the detection as it was before it moved to the C core (Y up), kept as
# an independent reference: the C results must be identical.
import re  # noqa: E402

from mlayer import ik  # noqa: E402

_REF_FOOT = re.compile(r"foot|ankle|paw|hoof", re.IGNORECASE)
_REF_TOE = re.compile(r"toe|ball", re.IGNORECASE)
_REF_HAND = re.compile(r"hand|wrist", re.IGNORECASE)


def _ref_has_ancestor_in(parents, j, group):
    p = int(parents[j])
    while p >= 0:
        if p in group:
            return True
        p = int(parents[p])
    return False


def _ref_descendants(parents, j):
    out, frontier = [], {j}
    for k in range(j + 1, len(parents)):
        if int(parents[k]) in frontier:
            frontier.add(k)
            out.append(k)
    return out


def _ref_path_between(parents, a, k):
    path = []
    while k != a and k >= 0:
        path.append(k)
        k = int(parents[k])
    return path[::-1]


def _ref_end_site_of(sk, j):
    hits = np.flatnonzero(sk.end_site_parents == j)
    return int(hits[0]) if hits.size else -1


def ref_find_feet(motion, positions=None):
    sk = motion.skeleton
    names, parents = sk.joint_names, sk.parents
    found = {j for j, n in enumerate(names) if _REF_FOOT.search(n)}
    ankles = [j for j in sorted(found) if not _ref_has_ancestor_in(parents, j, found)]
    if not ankles:
        raise mlayer.InvalidArgumentError("no feet found")
    hands = [j for j, n in enumerate(names) if _REF_HAND.search(n)]
    hands = [j for j in hands if not _ref_has_ancestor_in(parents, j, set(hands))]
    if hands and motion.n_frames:
        p = motion.positions() if positions is None else positions
        H = float(np.median(p[..., 1].max(axis=1) - p[..., 1].min(axis=1))) or 1.0
        ground = p[..., 1].min(axis=1)
        foot_h = np.median(p[:, ankles, 1] - ground[:, None])
        for j in hands:
            if np.median(p[:, j, 1] - ground) <= foot_h + 0.2 * H:
                ankles.append(j)
    ankles.sort()
    lengths = np.linalg.norm(sk.offsets, axis=1)
    feet = []
    for a in ankles:
        kids = [k for k in sk.children(a) if _REF_TOE.search(names[k])]
        if not kids:
            kids = [k for k in _ref_descendants(parents, a) if _REF_TOE.search(names[k])
                    and all(lengths[x] <= 1e-9 for x in _ref_path_between(parents, a, k)[:-1])]
        if kids:
            toe = names[max(kids, key=lambda k: lengths[k])]
        elif _ref_end_site_of(sk, a) >= 0:
            toe = names[a] + "/End"
        else:
            toe = None
        feet.append((names[a], toe))
    return feet


def ref_contact_positions(motion, names, pos, wrot):
    sk = motion.skeleton
    pts = [C._point(sk, n) for n in names]
    out = np.empty((pos.shape[0], len(pts), 3))
    for c, (j, e) in enumerate(pts):
        out[:, c] = pos[:, j]
        if e >= 0:
            out[:, c] += ik._rotate(wrot[:, j], np.broadcast_to(sk.end_site_offsets[e],
                                                                (pos.shape[0], 3)))
    return out


def ref_moving_min(x, half):
    n = x.shape[0]
    if half <= 0 or n <= 1:
        return x.copy()
    w = 2 * half + 1
    pad = np.concatenate([np.full((half,) + x.shape[1:], np.inf), x,
                          np.full((half + (-(n + 2 * half)) % w,) + x.shape[1:], np.inf)])
    blocks = pad.reshape((-1, w) + x.shape[1:])
    fwd = np.minimum.accumulate(blocks, axis=1).reshape(pad.shape)
    bwd = np.minimum.accumulate(blocks[:, ::-1], axis=1)[:, ::-1].reshape(pad.shape)
    i = np.arange(n)
    return np.minimum(bwd[i], fwd[i + w - 1])


def ref_runs(mask):
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def ref_hysteresis(on, off):
    n = on.shape[0]
    event = np.where(on, 1, np.where(off, 0, -1))
    idx = np.where(event >= 0, np.arange(n)[:, None], -1)
    last = np.maximum.accumulate(idx, axis=0)
    state = np.take_along_axis(event, np.maximum(last, 0), axis=0)
    return (state == 1) & (last >= 0)


def ref_detect_contacts(motion, joints=None, *, speed=0.25, height=0.06, min_duration=0.08):
    N = motion.n_frames
    pos, wrot = motion.forward_kinematics()
    if joints is None:
        names = []
        for a, t in ref_find_feet(motion, pos):
            names += [a] if t is None else [a, t]
    else:
        names = C._resolve_names(motion, joints)
    H = body_height(pos)
    fps = motion.fps
    p = ref_contact_positions(motion, names, pos, wrot)
    k = max(1, int(round(fps / 60.0)))
    v = np.empty(p.shape[:2])
    if N > 2 * k:
        v[k:N - k] = np.linalg.norm(p[2 * k:] - p[:N - 2 * k], axis=-1) / (2 * k / fps)
        v[:k], v[N - k:] = v[k], v[N - k - 1]
    else:
        v[:] = np.linalg.norm(p[-1] - p[0], axis=-1) / ((N - 1) / fps)
    y = p[..., 1]
    floor = ref_moving_min(y, int(round(0.75 * fps)))
    h = y - floor
    on = (v < speed * H) & (h < height * H)
    off = (v > 2.0 * speed * H) | (h > 1.5 * height * H)
    c = ref_hysteresis(on, off)
    gap = int(round(0.05 * fps))
    shortest = max(2, int(round(min_duration * fps)))
    for col in range(c.shape[1]):
        s, e = ref_runs(~c[:, col])
        for a, b in zip(s, e):
            if a > 0 and b < N and b - a <= gap:
                c[a:b, col] = True
        s, e = ref_runs(c[:, col])
        for a, b in zip(s, e):
            if b - a < shortest:
                c[a:b, col] = False
    return names, c


def _z_up(m):
    """The clip turned +90 degrees about X, so that Z is up: (x, y, z) -> (x, -z, y) on every
    translation, q -> R q R^-1 = (w, x, -z, y) on every rotation (exact permutations)."""
    def turn(v):
        v = np.asarray(v, dtype=np.float64)
        return np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1)
    sk = m.skeleton
    sk2 = mlayer.Skeleton(sk.joint_names, sk.parents, turn(sk.offsets), sk.channels,
                          sk.end_site_parents, turn(sk.end_site_offsets.reshape(-1, 3)))
    rot = m.rot
    rot2 = np.stack([rot[..., 0], rot[..., 1], -rot[..., 3], rot[..., 2]], axis=-1)
    trans = None if m.trans is None else turn(m.trans)
    return mlayer.Motion(sk2, m.frame_time, turn(m.root_pos), rot2, trans)


@pytest.mark.parametrize("name", ALL)
def test_c_detection_equals_the_numpy_reference(mocap, name):
    m = _read(mocap, name)
    names, c = mlayer.detect_contacts(m)
    rnames, rc = ref_detect_contacts(m)
    assert names == rnames
    assert C.find_feet(m) == ref_find_feet(m)
    assert c.dtype == np.bool_ and np.array_equal(c, rc), (c != rc).sum()
    # other options, and an override list with an End Site
    kw = dict(speed=0.4, height=0.03, min_duration=0.2)
    _, c2 = mlayer.detect_contacts(m, names[::-1], **kw)
    _, r2 = ref_detect_contacts(m, names[::-1], **kw)
    assert np.array_equal(c2, r2) and not np.array_equal(c2, c[:, ::-1])
    # the same clip with Z up: up="z" gives the Y-up clip's feet and contacts
    z = _z_up(m)
    np.testing.assert_allclose(z.positions()[..., 2], m.positions()[..., 1], atol=1e-9)
    assert C.find_feet(z, up="z") == C.find_feet(m)
    zn, zc = mlayer.detect_contacts(z, up="z")
    assert zn == names and np.array_equal(zc, rc), (zc != rc).sum()
    _, zc2 = mlayer.detect_contacts(z, names[::-1], up=2, **kw)
    assert np.array_equal(zc2, r2)
    # ... and by default (the detected up axis); while Y, sideways on the turned clip, is not
    # the up axis
    assert z.up_axis == "z" and np.array_equal(mlayer.detect_contacts(z)[1], rc)
    if not name.startswith("ai4a_dog"):
        _, zy = mlayer.detect_contacts(z, names, up="y")
        assert not np.array_equal(zy, rc)


def test_contact_positions_equal_the_numpy_rotation(mocap):
    m = _read(mocap, "cmu_10_01_soccer_kick.bvh", 300)
    names = ["rFoot", "rFoot/End", "lFoot/End"]
    pos, wrot = m.forward_kinematics()
    np.testing.assert_allclose(C.contact_positions(m, names),
                               ref_contact_positions(m, names, pos, wrot), rtol=0, atol=1e-12)
    with pytest.raises(mlayer.InvalidArgumentError, match="contact_positions: pos"):
        C.contact_positions(m, names, pos[:-1], wrot)
    with pytest.raises(mlayer.InvalidArgumentError, match="contact_positions: wrot"):
        C.contact_positions(m, names, pos, wrot[..., :3])


def test_bad_input_names_the_argument(mocap):
    m = _read(mocap, "lafan1_clip_a.bvh", 100)
    for bad in ("w", 3, -1, True, 1.0):
        with pytest.raises(mlayer.InvalidArgumentError, match="detect_contacts: up must be"):
            mlayer.detect_contacts(m, up=bad)
        with pytest.raises(mlayer.InvalidArgumentError, match="find_feet: up must be"):
            C.find_feet(m, up=bad)
    for opt in ("speed", "height", "min_duration"):
        for v in (float("nan"), float("inf"), 0.0, -1.0, "x"):
            with pytest.raises(
                    mlayer.InvalidArgumentError,
                    match=rf"detect_contacts: ({opt} must be a number|.*option {opt} = )"):
                mlayer.detect_contacts(m, **{opt: v})
    with pytest.raises(mlayer.InvalidArgumentError, match="motion must be"):
        mlayer.detect_contacts(m.positions())
    with pytest.raises(mlayer.InvalidArgumentError, match="find_feet: positions"):
        C.find_feet(m, m.positions()[:, :-1])
    with pytest.raises(mlayer.InvalidArgumentError, match="joint index 99"):
        mlayer.detect_contacts(m, joints=[99])
    # a flat skeleton along the chosen axis (Y; detected it would be X, the axis it lies on):
    # the C message
    flat = mlayer.Motion.from_arrays(["LeftFoot", "b"], [-1, 0], [[0, 0, 0], [1, 0, 0]],
                                     np.zeros((5, 3)), np.tile([1.0, 0, 0, 0], (5, 2, 1)))
    with pytest.raises(mlayer.InvalidArgumentError, match="no extent along the up axis"):
        mlayer.detect_contacts(flat, up="y")
    names, c = mlayer.detect_contacts(flat, up="x")
    assert names == ["LeftFoot"] and c.all()


def test_feet_found_by_geometry_where_no_name_says_foot(mocap):
    """Issue 38, item 7: a rig whose joints are not named foot/ankle/toe (here LaFAN1 with every
    joint renamed j0, j1, ...) gets its feet from geometry, the leaf joints that stay on the
    ground: the ankles above the toes, and the guards run on them (no warning)."""
    import warnings
    m = _read(mocap, "lafan1_clip_a.bvh", 600)
    names = [f"j{k}" for k in range(m.n_joints)]
    anon = mlayer.Motion.from_arrays(names, m.skeleton.parents, m.skeleton.offsets, m.root_pos,
                                     m.rot, fps=m.fps)
    feet = mlayer.guards.contacts.find_feet(anon)
    assert sorted(a for a, _ in feet) == sorted(
        names[m.joint_names.index(n)] for n in ("LeftFoot", "RightFoot"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", mlayer.MlayerWarning)
        out, rep = mlayer.stylize(anon, 2.0, return_report=True)
    assert rep.contact_frames > 100
