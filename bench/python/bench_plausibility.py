"""Plausibility of denoise / stylize output, by the bench's own definitions (issue 38, item 9).

    python bench/python/bench_plausibility.py [--corpus DIR ...] [--wild DIR] [--no-shared]
        [--alphas 0.5,2,3] [--clips PATTERN] [--max-frames 3000] [--jobs 1] [--json OUT]

A benchmark that cannot flatter: mlayer only reads the clips (mlayer.read_bvh), makes the
outputs and their unguarded references (mlayer.denoise, mlayer.stylize) and gives the base
layer of the "keep" measure (mlayer.decompose). Everything measured (kinematics, up, body
height, floor, feet, contacts, knees and elbows, every figure) is defined below and computed
here in numpy from the Motion's arrays, so no change to the library's metrics, contact
detection, floor estimate or forward kinematics can change a verdict.

Clips: every .bvh under each --corpus DIR (recursively, hidden folders left out; --wild DIR is
the same option, repeatable), and the shared clips, <repo>/../shared/data/mocap (included by
default when that folder exists; --no-shared leaves them out, --shared asks for them);
--clips keeps those whose name or file name matches a glob. Each clip is cut to its first
--max-frames frames (default 3000; 0 keeps all). --jobs N measures N clips at once (processes).

Cases, per clip: denoise, and stylize at each alpha of --alphas (default 0.5, 2, 3):
    out = mlayer.denoise(m)   |  mlayer.stylize(m, alpha)       (defaults: every guard on)
    ref = mlayer.denoise(m, limits=False, floor=False, keep_contacts=False)
                              |  mlayer.stylize(m, alpha, limits=False, floor=False,
                                                keep_contacts=False)   (the unguarded synthesis)
Each row measures ``out`` against the input ``m`` (and against ``ref`` where said).

Definitions (N frames, fps frames per second; "points" are the joints and the End Sites):

- Forward kinematics (forward_kinematics, end_site_positions): the local translation of the
  root is ``root_pos``, of a joint with position channels (``skeleton.trans_joints``) its
  ``trans`` column, of any other joint its OFFSET; world rotation W_j = W_parent * rot_j
  (unit quaternions w, x, y, z, Hamilton product); world position p_j = p_parent +
  W_parent(t_j); an End Site is at p_parent + W_parent(its OFFSET). test_plausibility.py
  checks this against Motion.positions / Motion.end_site_positions to 1e-9.
- Up u: the axis of ``Motion.up_axis`` ("x", "y" or "z"; the bench's own estimate below when
  the motion has none), pointing + unless the hips are below the feet along it. The bench's
  own estimate: feet = joints named foot/ankle/toe/heel and not hand-like, hips = their
  lowest common ancestor; the axis of the largest |median over frames of (hips - mean of the
  feet)|, its sign; without such names, the axis of the largest median extent of the joints.
  The clip's header line shows it in brackets when it differs from Motion.up_axis
  ("up y[x]"). Height h = p . u.
- Body height H: the median over frames of (max - min of the joints' heights); End Sites
  left out.
- Floor: the 5th percentile over frames of the lowest point's height, in the input.
- Foot points: among the chain ends (every End Site and childless joint, with the joint it
  hangs from and that joint's parent), those within 15 % H above the floor in at least 50 %
  of the input's frames (when none is: those whose median height is within 15 % H of the
  lowest median: every skeleton has a chain end, so there always are some).
- Horizontal speed of a point: the central difference over +-k frames, k = max(1,
  round(0.05 fps)), clamped at the clip's ends, its component along u removed, in units per
  second (over 0.1 s, so that capture noise at 120 fps does not read as motion).
- Contact frames (of each foot point, in the input): its height above the floor is at most
  its rest height + 3 % H (rest height: the 5th percentile over frames of its height above
  the floor, at least 0: about 0 for a toe, the ankle's height for an ankle) and its
  horizontal speed is below 10 % H per second.
- Limbs. The reach of a joint: the longest sum of bone lengths down to a descendant (End
  Sites included); bone length: the median over the input's frames of |p_j - p_parent|. A
  trunk joint has at least two child joints whose bone + reach is at least 20 % H (pelvis,
  chest). A limb is such a child's subtree with no trunk joint in it; its path runs from the
  trunk joint down through the child of largest bone + reach at each joint, the joints closer
  than 1 % H to the previous kept one dropped (zero-length bones). A limb is a leg when it
  holds a foot point, or when its joints' names look like a leg's (leg, thigh, knee, shin,
  calf, ankle, foot, toe, hip) and none like an arm's (arm, hand, wrist, elbow, shoulder,
  clavicle, collar, finger); else an arm when its two bones (below) span at least 25 % H and
  no joint of its path is named spine/chest; limbs below a joint named head/tail/jaw/eye/
  skull/face/nose, or holding a joint named like those or neck, are neither (spine). The
  middle joint (knee, elbow): the path's joint whose two bones (to the previous and the next
  kept joint) have the largest summed length, the first bone (trunk joint to hip or shoulder,
  the girdle) left out; but when exactly one candidate is named like a knee (knee, shin, calf,
  leg; not up/thigh/hip) or an elbow (elbow, forearm, lowerarm, loarm) and its two bones are
  at least 85 % of that longest pair, that one (names help where the geometry is close, as on
  CMU's arms, and are overruled where they are shifted, as on mediapipe's). The chain is
  (upper, middle, end): the kept joints around it. The pelvis: the trunk joint the legs hang
  from nearest the root, else the root.
- Body parts (for keep): legs = the joints of the leg limbs, arms = those of the arm limbs,
  spine = every other joint (root, spine, neck, head, tail, static root).

Columns (one row per case; a header line per clip gives frames, fps, up, H, the numbers of
foot points, knees and elbows, the pelvis; "-" where a measure is not defined):

  pop     foot-acceleration ratio A(out) / max(A(m), A(ref)), A(x) the max over foot points
          and frames t of |p(t+1) - 2 p(t) + p(t-1)|. Target <= 1.5.
  floor%  deepest point below the floor: over every point and frame, max(0, floor - h) in out
          minus the same in m there; the max (0 when none is deeper), in % of H. Target
          <= 0.5.
  flU%    the same for ref (the unguarded synthesis): no target, shows what the guards had
          to fix (or added).
  clean%  (denoise) max over frames and joints of |p(out) - p(ref)|, in % of H: how far the
          guards move a clean clip. Target <= 0.5 on inputs that do not slide: slIn below
          3 % H per second.
  slIn / slOut
          foot sliding: the mean over the input's contact frames (every foot point's own) of
          that point's horizontal speed, in m / in out, in H per second.
  slide   slOut / slIn. No target.
  kF kR eF eR
          knee (elbow) folds and reversals, in frames where any knee (elbow) does. Flexion of
          a chain: the angle between the upper bone (middle - upper) and the lower bone (end -
          middle), 0 when straight. A fold: out flexes more than max(150 deg, the input's
          largest flexion of that chain + 10). Hinge axis of a chain: the mean, over the
          input's frames flexed more than 20 deg, of unit(upper x lower) expressed in the
          frame of the world rotation of the middle joint's parent (which carries the upper
          bone), normalized; none when no frame bends that far (no reversal count then).
          Signed flexion: atan2((upper x lower) . axis, upper . lower) with the axis carried
          to world per frame; positive is the input's own (dominant) bending direction. A
          reversal: out's signed flexion is below min(0, the input's smallest) - 1 deg (bent
          the other way beyond anything the input did). Targets: 0 frames (the bench's own).
  bone%   max over frames and bones of | |p_j - p_parent| in out / the same in m - 1 |, in %.
          Bones: joints at least 1e-6 H from their parent whose distance is rigid in the input
          (range within 0.1 % of its median): a body translation in a joint's position
          channels below a static root (Bandai's Hips) is not a bone. Target <= 1 (the
          bench's own).
  bob     body bob ratio s(out) / s(m), s(x) the standard deviation over frames of the
          pelvis' height minus its centred moving average over 1 s (window: round(fps)
          frames made odd; the ends padded with the edge values). Target: bob / alpha within
          [0.7, 1.3] (stylize), bob within [0.7, 1.3] (denoise); "-" when s(m) < 1e-4 H.
  kpL kpA kpS
          exaggeration kept per body part (legs, arms, spine): R(out) / R(ref), R(x) the RMS
          over frames and the part's joints of the angle 2 acos|q_x . q_base| between the
          local rotations of x and of the base layer (mlayer.decompose(m).base). 1: the
          guards kept all of the synthesis' departure from the base layer. No target.

  flip    joint flips: frames x joints where the output's local rotation turns by more than
          30 degrees from the frame before and by more than 3 times the larger of the input's
          and the unguarded synthesis's turn there, plus 5 degrees (a limit clamped to the
          other bound, a twist snapping a half turn). Target: 0 (the bench's own).

Summary: per target, the clips where it applies, how many meet it in every case, the worst
three (clip, case, value) and every failing (clip, case, value) by clip. Notes per clip:
the reader's warnings, an up axis that differs from the bench's estimate, an input whose
pelvis jumps by more than 0.25 H in one frame (glitches: the ratios against it mean little),
cases where the guarded output equals the unguarded one, no foot points, no knees. Then the
clips mlayer refused (the call and its error), those skipped (fewer than 3 frames) and bench
errors (an exception in the bench's own code: a bug here). --json writes every row (with the
frame and point of the worst pop, floor and hinge values, and the unguarded reference's own
floor, slide, fold and reversal figures under "ref"), the per-clip findings and the summary.
"""
from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import pathlib
import re
import sys
import time
import traceback
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import mlayer

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import corpus  # noqa: E402

# ---- the definitions' constants ---------------------------------------------------------

FLOOR_PERCENTILE = 5.0
FOOT_BAND = 0.15          # of H: foot points are this low above the floor ...
FOOT_SHARE = 0.5          # ... in at least this share of the frames
CONTACT_BAND = 0.03       # of H above a foot point's rest height
CONTACT_REST_PCT = 5.0    # percentile of a foot point's height: its rest height
CONTACT_SPEED = 0.1       # of H per second
SPEED_SPAN_S = 0.05       # speeds are central differences over +- this many seconds
LIMB_MIN_REACH = 0.2      # of H
BONE_MIN = 0.01           # of H: shorter bones are dropped from a limb's path
NAMED_PAIR_MIN = 0.85     # a joint named like a knee/elbow wins when its bones are this long
ARM_MIN_SPAN = 0.25       # of H: the two bones of an arm span at least this
HUMAN_LIMIT_DEG = 150.0
FOLD_MARGIN_DEG = 10.0
REVERSAL_TOL_DEG = 1.0
HINGE_MIN_FLEX_DEG = 20.0
FLIP_MIN_DEG = 30.0       # a joint flip: a turn from the frame before of more than this ...
FLIP_FACTOR = 3.0         # ... and more than this times the input's and the synthesis's turn
FLIP_MARGIN_DEG = 5.0     # ... plus this
BOB_WINDOW_S = 1.0
BOB_MIN = 1e-4            # of H
JUMP_NOTE = 0.25          # of H in one frame: the input's pelvis jumps (noted)
SLIDE_STILL = 0.03        # of H per second: inputs that do not slide (for clean)

TARGETS = {  # key: description (target_value and target_passes say how)
    "pop": "pop <= 1.5",
    "floor": "floor% <= 0.5",
    "clean": "clean% <= 0.5 (denoise, inputs that do not slide)",
    "bob": "bob within 30% of alpha (stylize) / of 1 (denoise)",
    "knee_fold": "knee folds = 0",
    "knee_rev": "knee reversals = 0",
    "elbow_fold": "elbow folds = 0",
    "elbow_rev": "elbow reversals = 0",
    "bone": "bone% <= 1",
    "flip": "joint flips = 0",
}

HEAD_RE = re.compile(r"head|neck|tail|jaw|eye|skull|face|nose", re.I)
HEAD_TRUNK_RE = re.compile(r"head|tail|jaw|eye|skull|face|nose", re.I)
SPINE_NAME_RE = re.compile(r"spine|chest", re.I)
LEG_NAME_RE = re.compile(r"leg|thigh|knee|shin|calf|ankle|foot|toe|hip", re.I)
ARM_NAME_RE = re.compile(r"arm|hand|wrist|elbow|shoulder|clavicle|collar|finger", re.I)
KNEE_NAME_RE = re.compile(r"knee|shin|calf|leg", re.I)
ELBOW_NAME_RE = re.compile(r"elbow|fore.?arm|lower.?arm|lo.?arm", re.I)
UPPER_NAME_RE = re.compile(r"up|thigh|hip", re.I)
FOOT_NAME_RE = re.compile(r"foot|ankle|toe|heel", re.I)
HAND_NAME_RE = re.compile(r"hand|wrist|finger|thumb|index|middle|ring|pinky|carpal", re.I)

# ---- quaternions (w, x, y, z) -------------------------------------------------------------


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b of (..., 4) arrays."""
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def qrot(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v rotated by the unit quaternions q: v + w t + x cross t with t = 2 x cross v."""
    w, x = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(x, v)
    return v + w * t + np.cross(x, t)


def qconj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


# ---- kinematics ---------------------------------------------------------------------------


def forward_kinematics(m: Any) -> tuple[np.ndarray, np.ndarray]:
    """World positions (N, J, 3) and rotations (N, J, 4) of m's joints (module docstring)."""
    sk = m.skeleton
    par = np.asarray(sk.parents, dtype=int)
    J, N = len(par), int(np.asarray(m.rot).shape[0])
    local = np.broadcast_to(np.asarray(sk.offsets, float), (N, J, 3)).copy()
    local[:, 0] = np.asarray(m.root_pos, float)
    tj = np.asarray(sk.trans_joints, dtype=int)
    if tj.size:
        local[:, tj] = np.asarray(m.trans, float)
    rot = np.asarray(m.rot, float)
    pos, wrot = np.empty((N, J, 3)), np.empty((N, J, 4))
    for j in range(J):
        p = int(par[j])
        if p < 0:
            wrot[:, j], pos[:, j] = rot[:, j], local[:, j]
            continue
        if p >= j:
            raise ValueError(f"joint {j}'s parent {p} comes after it")
        wrot[:, j] = qmul(wrot[:, p], rot[:, j])
        pos[:, j] = pos[:, p] + qrot(wrot[:, p], local[:, j])
    return pos, wrot


def end_site_positions(m: Any, pos: np.ndarray, wrot: np.ndarray) -> np.ndarray:
    """(N, E, 3) End Site positions from the joints' world positions and rotations."""
    ep = np.asarray(m.skeleton.end_site_parents, dtype=int)
    if ep.size == 0:
        return np.zeros((pos.shape[0], 0, 3))
    eo = np.asarray(m.skeleton.end_site_offsets, float)
    return pos[:, ep] + qrot(wrot[:, ep], np.broadcast_to(eo, (pos.shape[0],) + eo.shape))


def all_points(m: Any) -> tuple[np.ndarray, np.ndarray]:
    """(N, J + E, 3) joint then End Site positions, and (N, J, 4) world rotations."""
    pos, wrot = forward_kinematics(m)
    return np.concatenate([pos, end_site_positions(m, pos, wrot)], axis=1), wrot


# ---- the rig: up, height, floor, feet, contacts, limbs -------------------------------------


def lowest_common_ancestor(parents: np.ndarray, joints: list[int]) -> int:
    def chain(j: int) -> list[int]:
        out = []
        while j >= 0:
            out.append(j)
            j = int(parents[j])
        return out[::-1]
    paths = [chain(j) for j in joints]
    lca = 0
    for k in range(min(len(p) for p in paths)):
        if len({p[k] for p in paths}) == 1:
            lca = paths[0][k]
        else:
            break
    return lca


def own_up(pos: np.ndarray, names: list[str], parents: np.ndarray) -> tuple[int, int, bool]:
    """(axis 0..2, sign +-1, from the feet?) of the hips-above-feet estimate: the median over
    frames of the hips' offset from the feet. Where that stands the clip upside down but on 15%
    of the frames or more the hips stand straight above the feet (cosine 0.9) along another
    axis, and on none along this one, that axis (a body that stood, then lay down for longer:
    a game's death clip)."""
    feet = [j for j, n in enumerate(names) if FOOT_NAME_RE.search(n)
            and not HAND_NAME_RE.search(n)]
    if feet:
        hips = lowest_common_ancestor(parents, feet)
        per_frame = pos[:, hips] - pos[:, feet].mean(axis=1)
        d = np.median(per_frame, axis=0)
        if hips not in feet and np.abs(d).max() > 0:
            k = int(np.argmax(np.abs(d)))
            if d[k] < 0:
                n = np.linalg.norm(per_frame, axis=1)
                upright = (per_frame > 0.9 * n[:, None]).sum(axis=0)
                others = [a for a in range(3) if a != k and upright[a] >= 0.15 * len(pos)]
                if others and upright[k] == 0:
                    return max(others, key=lambda a: upright[a]), 1, True
            return k, (1 if d[k] > 0 else -1), True
    ext = np.median(pos.max(axis=1) - pos.min(axis=1), axis=0)
    return int(np.argmax(ext)), 1, False


def body_height(h_joints: np.ndarray) -> float:
    """Median over frames of the joints' extent along up."""
    return float(np.median(h_joints.max(axis=1) - h_joints.min(axis=1)))


def floor_level(h_points: np.ndarray) -> float:
    """The FLOOR_PERCENTILE-th percentile over frames of the lowest point's height."""
    return float(np.percentile(h_points.min(axis=1), FLOOR_PERCENTILE))


def horizontal_speed(p: np.ndarray, up: np.ndarray, fps: float) -> np.ndarray:
    """(N, K) horizontal speeds (units per second) of (N, K, 3) positions: the central
    difference over +-k frames, k = max(1, round(SPEED_SPAN_S fps)) (the frame indices clamped
    to the clip at its ends), minus its component along up."""
    N = p.shape[0]
    if N < 2:
        return np.zeros(p.shape[:2])
    k = max(1, int(round(SPEED_SPAN_S * fps)))
    t = np.arange(N)
    a, b = np.minimum(t + k, N - 1), np.maximum(t - k, 0)
    v = (p[a] - p[b]) * (fps / (a - b))[:, None, None]
    v = v - (v @ up)[..., None] * up
    return np.linalg.norm(v, axis=-1)


def contact_frames(p: np.ndarray, up: np.ndarray, floor: float, H: float,
                   fps: float) -> np.ndarray:
    """(N, K) bool: the contact frames of the (N, K, 3) foot points (module docstring)."""
    above = p @ up - floor
    rest = np.maximum(np.percentile(above, CONTACT_REST_PCT, axis=0), 0.0)
    low = above <= rest + CONTACT_BAND * H
    return low & (horizontal_speed(p, up, fps) < CONTACT_SPEED * H)


def chain_ends(parents: np.ndarray, end_site_parents: np.ndarray) -> list[int]:
    """Point indices (joints, then J + End Site index) of the chain ends and the two joints
    above each."""
    J = len(parents)
    has_child = np.zeros(J, bool)
    for j in range(1, J):
        if parents[j] >= 0:
            has_child[parents[j]] = True
    ends = [J + e for e in range(len(end_site_parents))]
    ends += [j for j in range(J) if not has_child[j] and j not in set(end_site_parents.tolist())]
    out = set(ends)
    for e in ends:
        j = int(end_site_parents[e - J]) if e >= J else int(parents[e])
        for _ in range(2):
            if j < 0:
                break
            out.add(j)
            j = int(parents[j])
    return sorted(out)


def foot_points(h_points: np.ndarray, candidates: list[int], floor: float, H: float) -> list[int]:
    """The candidates that are within FOOT_BAND H of the floor in FOOT_SHARE of the frames."""
    if not candidates:
        return []
    above = h_points[:, candidates] - floor
    share = (above <= FOOT_BAND * H).mean(axis=0)
    feet = [c for c, s in zip(candidates, share) if s >= FOOT_SHARE]
    if feet:
        return feet
    med = np.median(above, axis=0)
    return [c for c, v in zip(candidates, med) if v <= med.min() + FOOT_BAND * H]


@dataclass
class Limbs:
    knees: list[tuple[int, int, int]] = field(default_factory=list)
    elbows: list[tuple[int, int, int]] = field(default_factory=list)
    legs: set[int] = field(default_factory=set)
    arms: set[int] = field(default_factory=set)
    pelvis: int = 0


def find_limbs(pos: np.ndarray, parents: np.ndarray, names: list[str], end_site_parents:
               np.ndarray, end_site_len: np.ndarray, feet: list[int], H: float) -> Limbs:
    """Knees, elbows, the legs' and arms' joints and the pelvis (module docstring)."""
    J = len(parents)
    bone = np.zeros(J)
    if J > 1:
        bone[1:] = np.median(np.linalg.norm(pos[:, 1:] - pos[:, parents[1:]], axis=-1), axis=0)
    children: list[list[int]] = [[] for _ in range(J)]
    for j in range(1, J):
        children[int(parents[j])].append(j)
    reach = np.zeros(J)
    for e, p in enumerate(end_site_parents):
        reach[p] = max(reach[p], float(end_site_len[e]))
    for j in range(J - 1, 0, -1):
        p = int(parents[j])
        reach[p] = max(reach[p], bone[j] + reach[j])
    long_child = [[c for c in children[j] if bone[c] + reach[c] >= LIMB_MIN_REACH * H]
                  for j in range(J)]
    trunk = [len(long_child[j]) >= 2 for j in range(J)]

    def subtree(r: int) -> set[int]:
        s, stack = set(), [r]
        while stack:
            j = stack.pop()
            s.add(j)
            stack += children[j]
        return s

    foot_joints = set()
    for f in feet:
        foot_joints.add(f if f < J else int(end_site_parents[f - J]))
    out = Limbs()
    pelvises: list[int] = []
    for b in range(J):
        if not trunk[b]:
            continue
        for c in long_child[b]:
            sub = subtree(c)
            if any(trunk[j] for j in sub):
                continue
            path, j = [b, c], c
            while children[j]:
                j = max(children[j], key=lambda k: bone[k] + reach[k])
                path.append(j)
            kept = [path[0]]
            for j in path[1:]:
                d = np.median(np.linalg.norm(pos[:, j] - pos[:, kept[-1]], axis=-1))
                if d >= BONE_MIN * H:
                    kept.append(j)
            if len(kept) < 4:  # the girdle bone and two more
                continue
            seg = [float(np.median(np.linalg.norm(pos[:, kept[i + 1]] - pos[:, kept[i]],
                                                  axis=-1))) for i in range(len(kept) - 1)]
            is_leg = bool(sub & foot_joints) or (
                any(LEG_NAME_RE.search(names[j]) for j in path[1:])
                and not any(ARM_NAME_RE.search(names[j]) for j in path[1:]))
            # the middle joint: the middle of the longest pair of bones, the girdle (trunk
            # joint -> hip or shoulder, seg[0]) left out; or the one joint named like a knee
            # (an elbow) when its pair is nearly as long
            pair = {i: seg[i - 1] + seg[i] for i in range(2, len(kept) - 1)}
            i = max(pair, key=lambda k: pair[k])
            named = [k for k in pair if (KNEE_NAME_RE if is_leg else ELBOW_NAME_RE).search(
                names[kept[k]]) and not UPPER_NAME_RE.search(names[kept[k]])]
            if len(named) == 1 and pair[named[0]] >= NAMED_PAIR_MIN * pair[i]:
                i = named[0]
            chain = (kept[i - 1], kept[i], kept[i + 1])
            span = seg[i - 1] + seg[i]
            if HEAD_TRUNK_RE.search(names[b]) or any(HEAD_RE.search(names[j])
                                                      for j in path[1:]):
                continue  # a head, a tail, a trunk: part of the spine
            if is_leg:
                out.knees.append(chain)
                out.legs |= sub
                pelvises.append(b)
            elif span >= ARM_MIN_SPAN * H and not any(SPINE_NAME_RE.search(names[j])
                                                       for j in path[1:]):
                out.elbows.append(chain)
                out.arms |= sub
    if pelvises:  # the trunk joint of the legs nearest the root
        def depth(j: int) -> int:
            d = 0
            while parents[j] >= 0:
                j, d = int(parents[j]), d + 1
            return d
        out.pelvis = min(pelvises, key=depth)
    return out


@dataclass
class Rig:
    """What the bench reads off the input once: see the module docstring."""
    up: np.ndarray
    up_label: str
    H: float
    floor: float
    feet: list[int]
    contacts: np.ndarray
    limbs: Limbs
    parts: dict[str, np.ndarray]
    point_names: list[str]


def make_rig(m: Any, points: np.ndarray) -> Rig:
    sk = m.skeleton
    names = sk.joint_names
    parents = np.asarray(sk.parents, dtype=int)
    J = len(parents)
    esp = np.asarray(sk.end_site_parents, dtype=int)
    pos = points[:, :J]
    k_own, s_own, by_feet = own_up(pos, names, parents)
    ua = getattr(m, "up_axis", None)
    k = "xyz".index(str(ua).lower()) if ua is not None and str(ua).lower() in "xyz" else k_own
    sign = s_own if (by_feet and k_own == k) else 1
    up = np.zeros(3)
    up[k] = sign
    label = ("-" if sign < 0 else "") + "xyz"[k]
    own_label = ("-" if s_own < 0 else "") + "xyz"[k_own]
    if own_label != label:
        label += f"[{own_label}]"
    h = points @ up
    H = body_height(h[:, :J])
    if not H > 0:
        raise ValueError("the joints have no extent along up (body height 0)")
    floor = floor_level(h)
    feet = foot_points(h, chain_ends(parents, esp), floor, H)
    contacts = contact_frames(points[:, feet], up, floor, H, m.fps) if feet else \
        np.zeros((points.shape[0], 0), bool)
    limbs = find_limbs(pos, parents, names, esp,
                       np.linalg.norm(np.asarray(sk.end_site_offsets, float), axis=-1)
                       if esp.size else np.zeros(0), feet, H)
    spine = set(range(J)) - limbs.legs - limbs.arms
    parts = {"legs": np.array(sorted(limbs.legs), int),
             "arms": np.array(sorted(limbs.arms - limbs.legs), int),
             "spine": np.array(sorted(spine), int)}
    pnames = names + [f"{names[p]}/End" for p in esp]
    return Rig(up, label, H, floor, feet, contacts, limbs, parts, pnames)


# ---- the measures -------------------------------------------------------------------------


def accel_max(p: np.ndarray) -> tuple[float, int, int]:
    """max over points and frames of |p(t+1) - 2 p(t) + p(t-1)| for (N, K, 3) positions, and
    the (frame, point) where it is (0, -1, -1 with fewer than 3 frames or no point)."""
    if p.shape[0] < 3 or p.shape[1] == 0:
        return 0.0, -1, -1
    a = np.linalg.norm(p[2:] - 2.0 * p[1:-1] + p[:-2], axis=-1)
    t, k = np.unravel_index(int(np.argmax(a)), a.shape)
    return float(a[t, k]), int(t) + 1, int(k)


def pop_ratio(p_out: np.ndarray, p_in: np.ndarray, p_ref: np.ndarray) -> float:
    """A(out) / max(A(in), A(ref)), A = accel_max (nan when both are 0)."""
    den = max(accel_max(p_in)[0], accel_max(p_ref)[0])
    return accel_max(p_out)[0] / den if den > 0 else float("nan")


def floor_depth(h_out: np.ndarray, h_in: np.ndarray, floor: float) -> tuple[float, int, int]:
    """max(0, max over (frame, point) of depth(out) - depth(in)), depth = max(0, floor - h);
    with its (frame, point), (-1, -1) when 0."""
    d = np.maximum(floor - h_out, 0.0) - np.maximum(floor - h_in, 0.0)
    t, k = np.unravel_index(int(np.argmax(d)), d.shape)
    if d[t, k] <= 0:
        return 0.0, -1, -1
    return float(d[t, k]), int(t), int(k)


def mean_contact_speed(p: np.ndarray, contacts: np.ndarray, up: np.ndarray, fps: float) -> float:
    """Mean horizontal speed of the (N, K, 3) points over their contact frames (nan: none)."""
    if not contacts.any():
        return float("nan")
    return float(horizontal_speed(p, up, fps)[contacts].mean())


def flexion(pos: np.ndarray, chain: tuple[int, int, int]) -> np.ndarray:
    """(N,) angle in degrees between the upper and lower bones of chain (0: straight)."""
    a, b, c = chain
    u, w = pos[:, b] - pos[:, a], pos[:, c] - pos[:, b]
    cosang = np.einsum("ij,ij->i", u, w) / np.maximum(
        np.linalg.norm(u, axis=-1) * np.linalg.norm(w, axis=-1), 1e-300)
    return np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 1e-12, n, 1.0)


def hinge_axis(pos: np.ndarray, wrot: np.ndarray, parents: np.ndarray,
               chain: tuple[int, int, int]) -> np.ndarray | None:
    """The chain's hinge axis in the frame of the middle joint's parent (None when the input
    never flexes it more than HINGE_MIN_FLEX_DEG)."""
    a, b, c = chain
    n = np.cross(pos[:, b] - pos[:, a], pos[:, c] - pos[:, b])
    bent = flexion(pos, chain) > HINGE_MIN_FLEX_DEG
    if not bent.any():
        return None
    q = wrot[bent, int(parents[b])]
    mean = qrot(qconj(q), _unit(n[bent])).mean(axis=0)
    nm = np.linalg.norm(mean)
    return mean / nm if nm > 1e-9 else None


def signed_flexion(pos: np.ndarray, wrot: np.ndarray, parents: np.ndarray,
                   chain: tuple[int, int, int], axis: np.ndarray) -> np.ndarray:
    """(N,) flexion in degrees signed about the hinge axis (+: the input's direction)."""
    a, b, c = chain
    u, w = _unit(pos[:, b] - pos[:, a]), _unit(pos[:, c] - pos[:, b])
    ax = qrot(wrot[:, int(parents[b])], np.broadcast_to(axis, u.shape))
    return np.degrees(np.arctan2(np.einsum("ij,ij->i", np.cross(u, w), ax),
                                 np.einsum("ij,ij->i", u, w)))


def hinge_frames(pos_in: np.ndarray, wrot_in: np.ndarray, pos_out: np.ndarray,
                 wrot_out: np.ndarray, parents: np.ndarray,
                 chains: list[tuple[int, int, int]]) -> tuple[int, int, Any, Any]:
    """(fold frames, reversal frames, worst fold, worst reversal) over the chains: worst as
    (frame, middle joint, degrees out, degrees of the input's limit) or None."""
    N = pos_in.shape[0]
    fold, rev = np.zeros(N, bool), np.zeros(N, bool)
    wf: Any = None
    wr: Any = None
    for ch in chains:
        fi, fo = flexion(pos_in, ch), flexion(pos_out, ch)
        lim = max(HUMAN_LIMIT_DEG, float(fi.max()) + FOLD_MARGIN_DEG)
        f = fo > lim
        fold |= f
        if f.any():
            t = int(np.argmax(fo))
            if wf is None or fo[t] - lim > wf[2] - wf[3]:
                wf = (t, ch[1], float(fo[t]), lim)
        ax = hinge_axis(pos_in, wrot_in, parents, ch)
        if ax is None:
            continue
        si = signed_flexion(pos_in, wrot_in, parents, ch, ax)
        so = signed_flexion(pos_out, wrot_out, parents, ch, ax)
        thr = min(0.0, float(si.min())) - REVERSAL_TOL_DEG
        r = so < thr
        rev |= r
        if r.any():
            t = int(np.argmin(so))
            if wr is None or so[t] - thr < wr[2] - wr[3]:
                wr = (t, ch[1], float(so[t]), thr)
    return int(fold.sum()), int(rev.sum()), wf, wr


def bone_change(pos_in: np.ndarray, pos_out: np.ndarray, parents: np.ndarray, H: float) -> float:
    """max over frames and bones of | |bone out| / |bone in| - 1 |. Bones: the joints whose
    distance to their parent is at least 1e-6 H and rigid in the input (its range over the
    frames within 0.1 % of its median): a joint carried by position channels that move (a body
    translation below a static root) is not a bone."""
    if len(parents) < 2:
        return 0.0
    j = np.arange(1, len(parents))
    li = np.linalg.norm(pos_in[:, j] - pos_in[:, parents[j]], axis=-1)
    lo = np.linalg.norm(pos_out[:, j] - pos_out[:, parents[j]], axis=-1)
    med = np.median(li, axis=0)
    rigid = (med > 1e-6 * H) & (np.ptp(li, axis=0) <= 1e-3 * med)
    if not rigid.any():
        return 0.0
    return float(np.abs(lo[:, rigid] / li[:, rigid] - 1.0).max())


def moving_average(y: np.ndarray, window: int) -> np.ndarray:
    """Centred moving average of odd length ``window``, the ends padded with edge values."""
    window = max(1, int(window) | 1)
    h = window // 2
    yp = np.concatenate([np.full(h, y[0]), y, np.full(h, y[-1])])
    c = np.concatenate([[0.0], np.cumsum(yp)])
    return (c[window:] - c[:-window]) / window


def bob(y: np.ndarray, fps: float) -> float:
    """std of y minus its centred moving average over BOB_WINDOW_S seconds."""
    w = int(round(BOB_WINDOW_S * fps)) | 1
    return float(np.std(y - moving_average(y, w)))


def turns(rot: np.ndarray) -> np.ndarray:
    """(N - 1, J) angles in degrees of each joint's local rotation from the frame before."""
    d = np.abs(np.einsum("nji,nji->nj", rot[1:], rot[:-1]))
    return np.degrees(2.0 * np.arccos(np.clip(d, 0.0, 1.0)))


def joint_flips(rot_out: np.ndarray, rot_in: np.ndarray,
                rot_ref: np.ndarray) -> tuple[int, tuple[int, int, float] | None]:
    """(count, worst (frame, joint, degrees) or None) of the joint flips of rot_out (see the
    module docstring): frames x joints turning by more than FLIP_MIN_DEG and more than
    FLIP_FACTOR times the larger of rot_in's and rot_ref's turn plus FLIP_MARGIN_DEG."""
    if rot_out.shape[0] < 2:
        return 0, None
    t_out = turns(rot_out)
    bad = (t_out > FLIP_MIN_DEG) & \
        (t_out > FLIP_FACTOR * np.maximum(turns(rot_in), turns(rot_ref)) + FLIP_MARGIN_DEG)
    if not bad.any():
        return 0, None
    t, j = np.unravel_index(int(np.argmax(np.where(bad, t_out, -1.0))), bad.shape)
    return int(bad.sum()), (int(t) + 1, int(j), float(t_out[t, j]))


def rms_angle(rot_a: np.ndarray, rot_b: np.ndarray, joints: np.ndarray) -> float:
    """RMS over frames and the joints of the angle 2 acos|a . b| (radians)."""
    if joints.size == 0:
        return float("nan")
    d = np.abs(np.einsum("nji,nji->nj", rot_a[:, joints], rot_b[:, joints]))
    return float(np.sqrt(np.mean((2.0 * np.arccos(np.clip(d, 0.0, 1.0))) ** 2)))


def _ratio(a: float, b: float) -> float:
    return a / b if b > 0 and math.isfinite(a) else float("nan")


# ---- one clip -----------------------------------------------------------------------------


def _case_list(alphas: list[float]) -> list[tuple[str, float]]:
    return [("denoise", 1.0)] + [("stylize", a) for a in alphas]


class Refused(Exception):
    """An mlayer call that raised: the clip is listed with the call and the reason."""


class Skipped(Exception):
    """A clip the bench cannot measure (fewer than 3 frames)."""


def _lib(stage: str, fn: Any, *args: Any, **kw: Any) -> Any:
    try:
        return fn(*args, **kw)
    except Exception as e:
        extra = "" if isinstance(e, mlayer.Error) else " (not an mlayer.Error)"
        raise Refused(f"{stage}: {type(e).__name__}: {e}{extra}") from e


def _run(op: str, m: Any, alpha: float, guarded: bool) -> Any:
    kw: dict[str, Any] = {} if guarded else {"limits": False, "floor": False,
                                            "keep_contacts": False}
    stage = (op if op == "denoise" else f"stylize {alpha:g}") + ("" if guarded else
                                                                 " unguarded")
    if op == "denoise":
        return _lib(stage, mlayer.denoise, m, **kw)
    return _lib(stage, mlayer.stylize, m, alpha, **kw)


def measure_clip(m: Any, alphas: list[float], name: str = "") -> dict:
    """The rows of one clip and what the bench found on it (see the module docstring)."""
    if m.n_frames < 3:
        raise Skipped(f"{m.n_frames} frame(s): fewer than 3")
    sk = m.skeleton
    parents = np.asarray(sk.parents, dtype=int)
    J = len(parents)
    fps = float(m.fps)
    pts_in, wrot_in = all_points(m)
    rig = make_rig(m, pts_in)
    H, up, feet = rig.H, rig.up, rig.feet
    h_in = pts_in @ up
    slide_in = mean_contact_speed(pts_in[:, feet], rig.contacts, up, fps) / H if feet else \
        float("nan")
    pel = rig.limbs.pelvis
    bob_in = bob(h_in[:, pel], fps)
    base = _lib("decompose", mlayer.decompose, m).base
    names = rig.point_names
    info = {
        "clip": name, "frames": m.n_frames, "fps": round(fps, 3), "joints": J,
        "end_sites": len(sk.end_site_parents), "up": rig.up_label, "H": H, "floor": rig.floor,
        "feet": [names[f] for f in feet], "contact_share": float(rig.contacts.mean())
        if rig.contacts.size else 0.0,
        "knees": [[names[j] for j in c] for c in rig.limbs.knees],
        "elbows": [[names[j] for j in c] for c in rig.limbs.elbows],
        "pelvis": names[pel], "slide_in": slide_in, "bob_in": bob_in / H,
        "pelvis_jump": float(np.linalg.norm(np.diff(pts_in[:, pel], axis=0), axis=-1).max())
        / H,
    }

    def shared(pts: np.ndarray, wrot: np.ndarray) -> dict[str, Any]:
        """The measures taken on the output and on the unguarded reference alike."""
        r: dict[str, Any] = {}
        d, t, k = floor_depth(pts @ up, h_in, rig.floor)
        r["floor"], r["floor_where"] = 100.0 * d / H, ((t, names[k]) if k >= 0 else None)
        r["slide_out"] = (mean_contact_speed(pts[:, feet], rig.contacts, up, fps) / H
                          if feet else float("nan"))
        for kind, chains in (("knee", rig.limbs.knees), ("elbow", rig.limbs.elbows)):
            nf, nr, wf, wr = hinge_frames(pts_in[:, :J], wrot_in, pts[:, :J], wrot, parents,
                                          chains)
            r[f"{kind}_fold"], r[f"{kind}_rev"] = (nf, nr) if chains else (None, None)
            r[f"{kind}_fold_worst"] = None if wf is None else (wf[0], names[wf[1]]) + wf[2:]
            r[f"{kind}_rev_worst"] = None if wr is None else (wr[0], names[wr[1]]) + wr[2:]
        r["bone"] = 100.0 * bone_change(pts_in[:, :J], pts[:, :J], parents, H)
        r["bob"] = bob(pts[:, pel] @ up, fps) / bob_in if bob_in >= BOB_MIN * H else \
            float("nan")
        return r

    rows = []
    for op, alpha in _case_list(alphas):
        out = _run(op, m, alpha, True)
        ref = _run(op, m, alpha, False)
        if out.n_frames != m.n_frames or ref.n_frames != m.n_frames:
            raise Refused(f"{op}: the frame count changed: {m.n_frames} -> "
                          f"{out.n_frames} / {ref.n_frames} (unguarded)")
        pts_out, wrot_out = all_points(out)
        pts_ref, wrot_ref = all_points(ref)
        row: dict[str, Any] = {"clip": name, "op": op, "alpha": alpha,
                               "case": op if op == "denoise" else f"stylize {alpha:g}"}
        row.update(shared(pts_out, wrot_out))
        row["ref"] = shared(pts_ref, wrot_ref)
        row["slide_in"] = slide_in
        row["slide"] = _ratio(row["slide_out"], slide_in)
        row["same_as_unguarded"] = bool(np.array_equal(pts_out, pts_ref))
        if feet:
            row["pop"] = pop_ratio(pts_out[:, feet], pts_in[:, feet], pts_ref[:, feet])
            _, t, k = accel_max(pts_out[:, feet])
            row["pop_where"] = (t, names[feet[k]]) if k >= 0 else None
            row["ref"]["pop_vs_input"] = _ratio(accel_max(pts_ref[:, feet])[0],
                                                accel_max(pts_in[:, feet])[0])
        else:
            row["pop"], row["pop_where"] = float("nan"), None
        if op == "denoise":
            row["clean"] = 100.0 * float(np.linalg.norm(pts_out[:, :J] - pts_ref[:, :J],
                                                        axis=-1).max()) / H
            row["clean_applies"] = bool(math.isfinite(slide_in) and slide_in < SLIDE_STILL)
        else:
            row["clean"], row["clean_applies"] = float("nan"), False
        for part, js in rig.parts.items():
            row[f"keep_{part}"] = _ratio(rms_angle(out.rot, base.rot, js),
                                         rms_angle(ref.rot, base.rot, js))
        n_flip, worst_flip = joint_flips(np.asarray(out.rot), np.asarray(m.rot),
                                         np.asarray(ref.rot))
        row["flip"] = n_flip
        row["flip_worst"] = None if worst_flip is None else \
            (worst_flip[0], sk.joint_names[worst_flip[1]], worst_flip[2])
        rows.append(row)
    return {"info": info, "rows": rows}


def _worker(job: tuple[str, str, list[float], int]) -> dict:
    name, path, alphas, max_frames = job
    t0 = time.perf_counter()
    res: dict[str, Any]
    try:
        m, notes = _lib("read_bvh", corpus.read_clip, pathlib.Path(path), max_frames)
        res = measure_clip(m, alphas, name)
        res["info"]["notes"] = notes
    except Refused as e:
        res = {"refused": str(e).replace(str(pathlib.Path(path).parent) + "/", "")}
    except Skipped as e:
        res = {"skipped": str(e)}
    except Exception as e:  # a bug of the bench: reported apart, with where it happened
        tb = traceback.extract_tb(e.__traceback__)[-1]
        res = {"error": f"{type(e).__name__}: {e} ({pathlib.Path(tb.filename).name}:"
                        f"{tb.lineno})"}
    res["clip"], res["seconds"] = name, time.perf_counter() - t0
    return res


# ---- targets and the summary ----------------------------------------------------------------


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


def target_value(key: str, row: dict) -> float | None:
    """The row's value for target key, or None where the target does not apply."""
    if key == "clean":
        return row["clean"] if row["op"] == "denoise" and row["clean_applies"] else None
    if key == "bob":
        if not _finite(row["bob"]):
            return None
        want = row["alpha"] if row["op"] == "stylize" else 1.0
        return row["bob"] / want if want else None
    v = row.get(key)
    return v if _finite(v) else None


def target_passes(key: str, v: float) -> bool:
    if key == "pop":
        return v <= 1.5
    if key in ("floor", "clean"):
        return v <= 0.5
    if key == "bob":
        return 0.7 <= v <= 1.3
    if key == "bone":
        return v <= 1.0
    return v == 0


def _shown(key: str, row: dict, v: float) -> str:
    if key == "bob":
        return f"{row['bob']:.2f}" + (f" ({v:.2f} alpha)" if row["op"] == "stylize" else "")
    if key in ("floor", "clean", "bone"):
        return f"{v:.2f}%"
    if key == "pop":
        return f"{v:.2f}"
    return f"{v:g} frames"


def summarize(results: list[dict]) -> dict:
    """Per target: clips where it applies, clips meeting it, failing (clip, case, value)."""
    out = {}
    for key in TARGETS:
        per_clip: dict[str, list[tuple[float, dict]]] = {}
        for r in results:
            for row in r.get("rows", []):
                v = target_value(key, row)
                if v is not None:
                    per_clip.setdefault(r["clip"], []).append((v, row))
        fails = [(clip, row["case"], v, _shown(key, row, v)) for clip, vs in per_clip.items()
                 for v, row in vs if not target_passes(key, v)]
        bad = {c for c, *_ in fails}

        def badness(v: float) -> float:
            if key == "bob":
                return abs(math.log(v)) if v > 0 else math.inf
            return v
        worst = sorted(fails, key=lambda f: -badness(f[2]))
        out[key] = {"target": TARGETS[key], "clips": len(per_clip),
                    "meeting": len(per_clip) - len(bad), "failing": worst}
    return out


# ---- printing ---------------------------------------------------------------------------------

COLS = [("case", "{:<11}", 11), ("pop", "{:.2f}", 5), ("floor", "{:.2f}", 6),
        ("ref.floor", "{:.2f}", 6), ("clean", "{:.2f}", 6), ("slide_in", "{:.3f}", 6),
        ("slide_out", "{:.3f}", 6),
        ("slide", "{:.2f}", 5), ("knee_fold", "{:d}", 4), ("knee_rev", "{:d}", 4),
        ("elbow_fold", "{:d}", 4), ("elbow_rev", "{:d}", 4), ("flip", "{:d}", 4),
        ("bone", "{:.2f}", 5),
        ("bob", "{:.2f}", 5), ("keep_legs", "{:.2f}", 5), ("keep_arms", "{:.2f}", 5),
        ("keep_spine", "{:.2f}", 5)]
HEAD = ["case", "pop", "floor%", "flU%", "clean%", "slIn", "slOut", "slide", "kF", "kR", "eF",
        "eR", "jF", "bone%", "bob", "kpL", "kpA", "kpS"]


def _get(row: dict, key: str) -> Any:
    for k in key.split("."):
        row = row.get(k) if isinstance(row, dict) else None  # type: ignore[assignment]
    return row


def _cell(fmt: str, w: int, v: Any) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-".rjust(w)
    if isinstance(v, str):
        return fmt.format(v)
    return fmt.format(v).rjust(w)


def print_results(results: list[dict], summary: dict, file: Any = sys.stdout) -> None:
    print("  " + " ".join(h.ljust(w) if i == 0 else h.rjust(w)
                          for i, (h, (_, _, w)) in enumerate(zip(HEAD, COLS))), file=file)
    for r in results:
        if "rows" not in r:
            continue
        i = r["info"]
        print(f"{r['clip']}: {i['frames']} frames at {i['fps']:g} fps, up {i['up']}, "
              f"H {i['H']:.4g}, {len(i['feet'])} foot points, {len(i['knees'])} knees, "
              f"{len(i['elbows'])} elbows, pelvis {i['pelvis']}", file=file)
        for row in r["rows"]:
            print("  " + " ".join(_cell(f, w, _get(row, k)) for k, f, w in COLS), file=file)
    print(file=file)
    print("Summary (a clip meets a target when every case where it applies does):", file=file)
    for s in summary.values():
        worst = ", ".join(f"{c} ({case}) {txt}" for c, case, _, txt in s["failing"][:3])
        print(f"  {s['target']:<52} {s['meeting']:>3}/{s['clips']:<3} clips"
              + (f"; worst: {worst}" if worst else ""), file=file)
    print(file=file)
    print("Medians over the clips, per case (no targets for slide and kp*):", file=file)
    cases: dict[str, list[dict]] = {}
    for r in results:
        for row in r.get("rows", []):
            cases.setdefault(row["case"], []).append(row)
    cols = ["pop", "floor", "ref.floor", "slide", "bob", "keep_legs", "keep_arms", "keep_spine"]
    print("  " + "case".ljust(11) + "".join(c.rjust(11) for c in
                                           ["pop", "floor%", "flU%", "slide", "bob/alpha",
                                            "kpL", "kpA", "kpS"]), file=file)
    for case, rows in cases.items():
        cells = []
        for c in cols:
            vals = [_get(row, c) for row in rows]
            if c == "bob":
                vals = [v / row["alpha"] if _finite(v) else v for v, row in zip(vals, rows)]
            vals = [v for v in vals if _finite(v)]
            cells.append(f"{np.median(vals):11.2f}" if vals else "-".rjust(11))
        print("  " + case.ljust(11) + "".join(cells), file=file)
    print(file=file)
    for s in summary.values():
        if s["failing"]:
            print(f"Failing {s['target']}:", file=file)
            byclip: dict[str, list[str]] = {}
            for c, case, _, txt in s["failing"]:
                byclip.setdefault(c, []).append(f"{case} {txt}")
            for c, items in byclip.items():
                print(f"  {c}: " + "; ".join(items), file=file)
    notes = []
    for r in results:
        if "rows" not in r:
            continue
        i = r["info"]
        n = list(i.get("notes", []))
        if "[" in i["up"]:
            n.append(f"up {i['up'].split('[')[0]} (Motion.up_axis), the bench's hips-above-feet "
                     f"estimate {i['up'].split('[')[1].rstrip(']')}")
        if i["pelvis_jump"] > JUMP_NOTE:
            n.append(f"the input's pelvis jumps by up to {i['pelvis_jump']:.3g} H in one frame")
        same = [row["case"] for row in r["rows"] if row["same_as_unguarded"]]
        if same:
            n.append("guarded = unguarded output in " + ", ".join(same))
        if not i["feet"]:
            n.append("no foot points")
        if not i["knees"]:
            n.append("no knees found")
        if n:
            notes.append(f"  {r['clip']}: " + "; ".join(n))
    if notes:
        print("Notes:", *notes, sep="\n", file=file)
    for kind, label in (("refused", "Refused by mlayer"), ("skipped", "Skipped"),
                        ("error", "Bench errors")):
        bad = [r for r in results if kind in r]
        if bad:
            print(f"{label}:", file=file)
            for r in bad:
                print(f"  {r['clip']}: {r[kind]}", file=file)


# ---- the command line -------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--corpus", "--wild", action="append", default=[], metavar="DIR",
                    help="a folder whose .bvh files (recursively) are measured; repeatable")
    ap.add_argument("--shared", action=argparse.BooleanOptionalAction, default=None,
                    help="include ../shared/data/mocap beside the repository (default: when "
                         "it exists)")
    ap.add_argument("--alphas", default="0.5,2,3")
    ap.add_argument("--clips", default="*", help="glob on the clip name or file name")
    ap.add_argument("--json", default=None, help="write the rows, notes and summary here")
    ap.add_argument("--max-frames", type=int, default=3000,
                    help="cut longer clips to their first N frames (0: whole clips)")
    ap.add_argument("--jobs", type=int, default=1, help="clips measured in parallel")
    a = ap.parse_args(argv)
    alphas = [float(x) for x in a.alphas.split(",") if x.strip()]
    dirs = [pathlib.Path(d) for d in a.corpus]
    shared = corpus.shared_dir()
    if a.shared or (a.shared is None and shared.is_dir()):
        dirs.insert(0, shared)
    try:
        clips = corpus.find_clips(dirs, a.clips)
    except FileNotFoundError as e:
        ap.error(str(e))
    print(f"mlayer {mlayer.__version__}: {len(clips)} clips from "
          + ", ".join(str(d) for d in dirs) + "; cases: denoise, stylize at "
          + ", ".join(f"{x:g}" for x in alphas) + f"; at most {a.max_frames or 'all'} frames",
          flush=True)
    jobs = [(c.name, str(c.path), alphas, a.max_frames) for c in clips]
    t0 = time.perf_counter()
    results = []
    if a.jobs > 1 and len(jobs) > 1:
        ctx = multiprocessing.get_context("spawn")
        with ctx.Pool(min(a.jobs, len(jobs))) as pool:
            for r in pool.imap_unordered(_worker, jobs):
                print(f"  {r['clip']} ({r['seconds']:.1f} s)", file=sys.stderr, flush=True)
                results.append(r)
    else:
        for j in jobs:
            r = _worker(j)
            print(f"  {r['clip']} ({r['seconds']:.1f} s)", file=sys.stderr, flush=True)
            results.append(r)
    order = {c.name: i for i, c in enumerate(clips)}
    results.sort(key=lambda r: order[r["clip"]])
    summary = summarize(results)
    print_results(results, summary)
    print(f"\n{len(results)} clips in {time.perf_counter() - t0:.1f} s with {a.jobs} job(s)")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"mlayer": mlayer.__version__, "alphas": alphas,
                       "max_frames": a.max_frames, "results": results, "summary": summary},
                      f, indent=1, default=float)
    return 0


# ---- kept for render_worst.py (the older, library-assisted view of one clip) ------------------

GUARD_KW = {"limits": ("auto", None), "floor": ("auto", None), "keep_contacts": (True, False)}
GUARD_LABEL = {"limits": "limits", "floor": "floor", "keep_contacts": "contacts"}


def accepted_guards(fn: Any) -> list[str]:
    """The guard keywords of GUARD_KW that fn's signature accepts."""
    import inspect
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return []
    return [k for k in GUARD_KW if k in params]


def _kw(guards: list[str], on: set[str]) -> dict:
    return {k: (GUARD_KW[k][0] if k in on else GUARD_KW[k][1]) for k in guards}


def _call(op: str, m: Any, alpha: float, kw: dict) -> tuple[Any, float]:
    t0 = time.perf_counter()
    out = mlayer.denoise(m, **kw) if op == "denoise" else mlayer.stylize(m, alpha, **kw)
    return out, time.perf_counter() - t0


if __name__ == "__main__":
    sys.exit(main())
