"""Plausibility measures of a processed motion against its input (issue 18, item 7).

The older, library-assisted measures: they take the feet, the body height, the contacts and
the limb chains from mlayer (find_feet, body_height, detect_contacts, ik.leg_chain). Used by
render_worst.py and bindings/python/tests/test_wild_corpus.py (and test_limits.py's
swing_twist_excess); checked by test_plausibility.py. bench_plausibility.py no longer uses
them: it measures with definitions of its own (issue 38, item 9), so that the library's
metrics cannot grade themselves.

Definitions (all on world positions from forward kinematics; the output has the input's
frames and skeleton):

- Body height H: :func:`mlayer.guards.metrics.body_height` of the input (median over frames of the
  joints' vertical extent, End Sites excluded). Vertical is the input's
  :attr:`mlayer.Motion.up_axis` (detected, or given to read_bvh), for the height, the floor
  and the penetration depths alike; :func:`up_axis` is this module's own estimate, shown by
  the bench beside it.
- Limb chains: legs from :func:`mlayer.guards.contacts.find_feet` (each ankle, the "foot" joints
  that are not hands) and arms from joints named /hand|wrist/ that are not feet, each turned into
  (upper, middle, end) by :func:`mlayer.guards.ik.leg_chain` (the nearest ancestors at a non-zero
  distance: hip-knee-ankle, shoulder-elbow-wrist).
- Flexion of a knee or elbow: the angle in degrees between the upper-limb vector
  (middle - upper) and the lower-limb vector (end - middle): 0 for a straight limb, 90 for a
  right angle. A fold is a frame where the output's flexion exceeds both the human limit
  (150 degrees) and the input's largest flexion of that joint + 10 degrees.
- Hinge axis: estimated from the input as the mean, over the frames flexed by more than
  20 degrees, of the unit normal cross(upper, lower) expressed in the frame of the joint that
  carries the upper-limb bone (the knee's parent), so it turns with the thigh. Signed flexion:
  atan2(cross(upper, lower) . axis, upper . lower) with that axis carried to world space per
  frame; positive is the input's own bending direction. A reversal is a frame where the
  output's signed flexion is below min(0, the input's smallest signed flexion) - 1 degree (the
  limb bends the other way further than the input ever did; 1 degree absorbs rounding).
- Floor: the 5% quantile of the heights of the input's foot points (ankles and toes of
  find_feet) on their contact frames (:func:`mlayer.detect_contacts`): the level the lowest
  points rest on, the floor the guards document (mlr_cleanup_floor_height), computed here in
  numpy. (The median, used before, mixes ankles, which stand an ankle's height above the
  ground, with toes, so it sits above the ground and counts toes resting on it as below it.)
  Without contacts, the 1st percentile of the lowest foot point per frame. A penetration frame
  has a foot point more than
  0.5 % of H below that floor in the output while the same point was not below
  (floor - 0.5 % H) in the input; the depth reported is the largest such (floor - height).
- Exaggeration kept per body part: RMS over frames and the part's joints of the rotation
  angle between the output and the base layer (2 acos |q_out . q_base|), divided by the same
  for the unguarded synthesis. Parts: legs (the subtrees of the leg chains' upper joints),
  arms (those of the arm chains' upper joints), spine/head (every other joint, the root's
  rotation included).
- Root path deviation: largest distance of an output root position from the input's root
  path (the polyline through its root positions), in body heights.
- Bone lengths: largest relative change of a joint-to-parent distance (bones longer than
  1e-6 H) between output and input over all frames.
- Swing/twist excess: for each joint whose range is "swing-twist" in the limits the guards
  learn from the input (:func:`mlayer.joint_limits`: centre c, bone direction t, bounds swing
  and twist, widened by |alpha| where ``widen``), the output's rotation q is taken relative
  to the centre, r = conj(c) q (w >= 0), and split into a twist about t, 2 atan2(r.v . t, w),
  and the swing of the rest, 2 atan2(|s.v|, |s.w|) with s = r conj(twist); the excess is how
  far either passes its bound, in degrees (0 inside). The guards' soft saturation keeps the
  limits' own synthesis inside; the contact cleanup's IK, which moves hips and ankles after
  the limits so that the pinned feet reach their targets, can take them past. This uses the
  library's learned geometry, but measures the angles here in numpy.
"""
from __future__ import annotations

from typing import Any

import numpy as np

import mlayer
from mlayer.guards import contacts as _contacts
from mlayer import ik as _ik

HUMAN_LIMIT_DEG = 150.0
FOLD_MARGIN_DEG = 10.0
REVERSAL_TOL_DEG = 1.0
HINGE_MIN_FLEX_DEG = 20.0
FLOOR_TOL = 0.005          # of body height

Chain = tuple[int, int, int]


def up_axis(motion: Any) -> str:
    """'X', 'Y' or 'Z', with '-' when up is the negative direction: the dominant component of
    the median over frames of (mean position of the hips - mean position of the feet of
    find_feet; hips from mlayer.guards.ik.leg_chain): the hips are above the feet along the up axis
    in every frame, while the horizontal components
    change sign with the heading. Without feet: the axis of the largest median extent of the
    joints over frames."""
    sk = motion.skeleton
    names = sk.joint_names
    p = motion.positions()
    try:
        feet = [names.index(a) for a, _ in _contacts.find_feet(motion, p)]
    except mlayer.InvalidArgumentError:
        feet = []
    if feet:
        hips = []
        for j in feet:
            try:
                hips.append(_ik.leg_chain(sk, j)[0])
            except mlayer.InvalidArgumentError:
                hips.append(0)
        d = np.median(p[:, hips].mean(axis=1) - p[:, feet].mean(axis=1), axis=0)
        k = int(np.argmax(np.abs(d)))
        return ("" if d[k] > 0 else "-") + "XYZ"[k]
    return "XYZ"[int(np.argmax(np.median(p.max(axis=1) - p.min(axis=1), axis=0)))]


def _topmost(names_idx: list[int], parents: Any) -> list[int]:
    s = set(names_idx)
    out = []
    for j in names_idx:
        p, top = int(parents[j]), True
        while p >= 0:
            if p in s:
                top = False
                break
            p = int(parents[p])
        if top:
            out.append(j)
    return out


def limb_chains(motion: Any) -> dict[str, list[tuple[int, int, int]]]:
    """{'knee': [(hip, knee, ankle), ...], 'elbow': [(shoulder, elbow, wrist), ...]}."""
    sk = motion.skeleton
    names = sk.joint_names
    try:
        feet = [names.index(a) for a, _ in _contacts.find_feet(motion)]
    except mlayer.InvalidArgumentError:
        feet = []
    hands = [j for j, n in enumerate(names) if _contacts.HAND_PATTERN.search(n)]
    hands = [j for j in _topmost(hands, sk.parents) if j not in feet]
    # hand-named "feet" (a quadruped's forelegs, or hands that find_feet took for feet) are
    # elbows
    hands += [j for j in feet if _contacts.HAND_PATTERN.search(names[j])]
    legs = [j for j in feet if not _contacts.HAND_PATTERN.search(names[j])]
    out: dict[str, list[tuple[int, int, int]]] = {"knee": [], "elbow": []}
    for kind, ends in (("knee", legs), ("elbow", sorted(hands))):
        for e in ends:
            try:
                out[kind].append(_ik.leg_chain(sk, e))
            except mlayer.InvalidArgumentError:
                pass
    return out


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    w, x = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(x, v)
    return v + w * t + np.cross(x, t)


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 1e-12, n, 1.0)


def flexion(pos: np.ndarray, chain: Chain) -> np.ndarray:
    """(N,) unsigned flexion in degrees of chain (upper, middle, end) over the frames of pos."""
    a, b, c = chain
    u, w = pos[:, b] - pos[:, a], pos[:, c] - pos[:, b]
    cosang = np.einsum("ij,ij->i", _unit(u), _unit(w))
    return np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))


def hinge_axis_local(pos: np.ndarray, wrot: np.ndarray, parents: Any,
                     chain: Chain) -> np.ndarray | None:
    """Unit hinge axis in the frame of the knee's parent joint, from the input's bent frames
    (None when the limb never bends by more than HINGE_MIN_FLEX_DEG)."""
    a, b, c = chain
    u, w = pos[:, b] - pos[:, a], pos[:, c] - pos[:, b]
    n = np.cross(u, w)
    bent = flexion(pos, chain) > HINGE_MIN_FLEX_DEG
    if not bent.any():
        return None
    qp = wrot[:, int(parents[b])]
    qc = qp * np.array([1.0, -1.0, -1.0, -1.0])
    local = _unit(_rotate(qc[bent], _unit(n[bent])))
    m = local.mean(axis=0)
    return m / np.linalg.norm(m) if np.linalg.norm(m) > 1e-9 else None


def signed_flexion(pos: np.ndarray, wrot: np.ndarray, parents: Any, chain: Chain,
                   axis_local: np.ndarray) -> np.ndarray:
    """(N,) signed flexion in degrees about the hinge axis (positive: the input's bending
    direction)."""
    a, b, c = chain
    u, w = pos[:, b] - pos[:, a], pos[:, c] - pos[:, b]
    ax = _rotate(wrot[:, int(parents[b])], np.broadcast_to(axis_local, u.shape))
    s = np.einsum("ij,ij->i", np.cross(_unit(u), _unit(w)), ax)
    return np.degrees(np.arctan2(s, np.einsum("ij,ij->i", _unit(u), _unit(w))))


def hinge_report(inp: Any, out: Any, chains: dict[str, list[Chain]] | None = None, *,
                 fk_in: Any = None, fk_out: Any = None) -> dict:
    """Folds and reversals of every knee/elbow chain. Returns {'knee': {...}, 'elbow': {...}}
    with per kind: fold_frames, reversal_frames (frames where any chain of that kind folds /
    reverses), worst_fold (frame, joint name, degrees out, degrees in max), worst_reversal
    (frame, joint name, signed degrees out, input min)."""
    chains = limb_chains(inp) if chains is None else chains
    pi, wi = inp.forward_kinematics() if fk_in is None else fk_in
    po, wo = out.forward_kinematics() if fk_out is None else fk_out
    parents = inp.skeleton.parents
    names = inp.skeleton.joint_names
    rep = {}
    for kind, lst in chains.items():
        fold = np.zeros(inp.n_frames, bool)
        rev = np.zeros(inp.n_frames, bool)
        wf, wr = None, None
        for ch in lst:
            fi, fo = flexion(pi, ch), flexion(po, ch)
            lim = max(HUMAN_LIMIT_DEG, fi.max() + FOLD_MARGIN_DEG)
            f = fo > lim
            fold |= f
            if f.any():
                t = int(np.argmax(fo))
                if wf is None or fo[t] > wf[2]:
                    wf = (t, names[ch[1]], float(fo[t]), float(fi.max()))
            ax = hinge_axis_local(pi, wi, parents, ch)
            if ax is None:
                continue
            si, so = (signed_flexion(pi, wi, parents, ch, ax),
                      signed_flexion(po, wo, parents, ch, ax))
            thr = min(0.0, si.min()) - REVERSAL_TOL_DEG
            r = so < thr
            rev |= r
            if r.any():
                t = int(np.argmin(so))
                if wr is None or so[t] < wr[2]:
                    wr = (t, names[ch[1]], float(so[t]), float(si.min()))
        rep[kind] = {"chains": len(lst), "fold_frames": int(fold.sum()),
                     "reversal_frames": int(rev.sum()), "worst_fold": wf, "worst_reversal": wr}
    return rep


def foot_points(inp: Any) -> list[str]:
    """Names of the foot points (ankle, toe or 'Ankle/End') of find_feet ([] without feet)."""
    try:
        feet = _contacts.find_feet(inp)
    except mlayer.InvalidArgumentError:
        return []
    names = []
    for a, t in feet:
        names += [a] if t is None else [a, t]
    return names


def _up_index(motion: Any) -> int:
    """0..2: the axis of motion.up_axis ("x", "y" or "z"; Y for objects without one)."""
    return "xyz".index(str(getattr(motion, "up_axis", "y")).lower())


def floor_level(inp: Any, names: list[str], contacts: Any = None) -> float:
    """The input's floor height along its up axis (see the module docstring)."""
    y = _contacts.contact_positions(inp, names)[..., _up_index(inp)]
    if contacts is not None and contacts.any():
        return float(np.quantile(y[contacts], 0.05))
    return float(np.percentile(y.min(axis=1), 1.0))


def floor_report(inp: Any, out: Any, names: list[str], floor: float, H: float) -> dict:
    """Penetration frames (count), deepest depth in % of H, and the worst (frame, point).

    The depth of a point is how far below the floor it goes beyond the input's own depth at
    that point and frame (issue 38's definition, and ``plausibility_check.py``'s): a foot the
    capture already put 0.4 % of H under the floor and the output 0.6 % is 0.2 % deep.
    """
    if not names:
        return {"frames": 0, "deepest_pct": 0.0, "worst": None}
    k = _up_index(inp)
    yi = _contacts.contact_positions(inp, names)[..., k]
    yo = _contacts.contact_positions(out, names)[..., k]
    tol = FLOOR_TOL * H
    depth = (floor - yo) - np.maximum(0.0, floor - yi)
    pen = depth > tol
    d = float(depth.max()) if np.isfinite(depth.max()) else 0.0
    worst = None
    if pen.any():
        t, c = np.unravel_index(int(np.argmax(depth)), depth.shape)
        worst = (int(t), names[c], 100.0 * float(depth[t, c]) / H)
    return {"frames": int(pen.any(axis=1).sum()), "deepest_pct": 100.0 * max(d, 0.0) / H,
            "worst": worst}


def body_parts(inp: Any, chains: dict[str, list[Chain]] | None = None
               ) -> dict[str, np.ndarray]:
    """Joint indices of legs, arms and spine/head (see the module docstring)."""
    chains = limb_chains(inp) if chains is None else chains
    sk = inp.skeleton
    J = sk.n_joints
    parents = sk.parents

    def subtree(r: int) -> set[int]:
        s = {r}
        for j in range(r + 1, J):
            if int(parents[j]) in s:
                s.add(j)
        return s

    legs, arms = set(), set()
    for a, _, _ in chains["knee"]:
        legs |= subtree(a)
    for a, _, _ in chains["elbow"]:
        arms |= subtree(a) - legs
    rest = set(range(J)) - legs - arms
    return {"legs": np.array(sorted(legs), int), "arms": np.array(sorted(arms), int),
            "spine_head": np.array(sorted(rest), int)}


def rms_angle(rot_a: np.ndarray, rot_b: np.ndarray, joints: np.ndarray) -> float:
    """RMS over frames and joints of the angle (radians) between two rotation arrays."""
    if joints.size == 0:
        return float("nan")
    d = np.abs(np.einsum("nji,nji->nj", rot_a[:, joints], rot_b[:, joints]))
    ang = 2.0 * np.arccos(np.clip(d, 0.0, 1.0))
    return float(np.sqrt(np.mean(ang ** 2)))


def root_path_deviation(root_in: np.ndarray, root_out: np.ndarray, chunk: int = 256) -> float:
    """Largest distance of a root_out point from the polyline through root_in."""
    a, b = root_in[:-1], root_in[1:]
    if len(root_in) < 2:
        return float(np.linalg.norm(root_out - root_in[0], axis=1).max())
    ab = b - a
    L2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    best = np.empty(len(root_out))
    for s in range(0, len(root_out), chunk):
        p = root_out[s:s + chunk, None, :]
        t = np.clip(np.einsum("nki,ki->nk", p - a[None], ab) / L2, 0.0, 1.0)
        q = a[None] + t[..., None] * ab[None]
        best[s:s + chunk] = np.linalg.norm(p - q, axis=-1).min(axis=1)
    return float(best.max())


def bone_length_change(pos_in: np.ndarray, pos_out: np.ndarray, parents: Any,
                       H: float) -> float:
    """Largest relative change of a joint-parent distance over frames and bones."""
    j = np.arange(1, len(parents))
    li = np.linalg.norm(pos_in[:, j] - pos_in[:, parents[j]], axis=-1)
    lo = np.linalg.norm(pos_out[:, j] - pos_out[:, parents[j]], axis=-1)
    ok = li > 1e-6 * H
    if not ok.any():
        return 0.0
    return float((np.abs(lo - li)[ok] / li[ok]).max())


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw],
                    axis=-1)


def swing_twist_excess(limits: Any, rot: np.ndarray, alpha: float = 1.0) -> dict[str, float]:
    """Largest swing/twist excess (degrees) per joint over the ranges of ``limits``.

    ``limits``: a :class:`mlayer.guards.limits.JointLimits` (of the input); ``rot``: frames x
    joints x 4 rotations of a motion on its skeleton; ``alpha``: the synthesis' alpha (the
    ranges marked ``widen`` grow with |alpha|). Returns {joint name: excess} for every
    swing-twist joint with a bone (see the module docstring).
    """
    rot = np.asarray(rot, dtype=float)
    out = {}
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    for j, name in enumerate(limits.joint_names):
        r = limits.range(j)
        g = limits.geometry(j)
        bl = float(np.linalg.norm(g["bone_out"]))
        if r["kind"] != "swing-twist" or bl == 0.0:
            continue
        t = g["bone_out"] / bl
        q = rot[:, j] / np.linalg.norm(rot[:, j], axis=-1, keepdims=True)
        rr = _qmul(np.broadcast_to(g["centre"] * conj, q.shape), q)
        rr = np.where(rr[:, :1] < 0.0, -rr, rr)
        p = rr[:, 1:] @ t
        twist = 2.0 * np.arctan2(p, rr[:, 0])
        twist = (twist + np.pi) % (2.0 * np.pi) - np.pi
        tn = np.maximum(np.hypot(rr[:, 0], p), 1e-300)
        tq = np.stack([rr[:, 0] / tn, p * t[0] / tn, p * t[1] / tn, p * t[2] / tn], axis=-1)
        s = _qmul(rr, tq * conj)
        swing = 2.0 * np.arctan2(np.linalg.norm(s[:, 1:], axis=-1), np.abs(s[:, 0]))
        wide = max(1.0, abs(alpha)) if r["widen"] else 1.0
        smax, tmax = min(np.pi, r["swing"] * wide), min(np.pi, r["twist"] * wide)
        e = np.maximum(np.maximum(swing - smax, 0.0), np.maximum(np.abs(twist) - tmax, 0.0))
        out[name] = float(np.degrees(e.max())) if e.size else 0.0
    return out
