"""Rotation outliers (issue 38, item 4): joints flipped for a few frames, found and removed.

For each clean clip, flips are injected (a joint's local quaternion turned by 90, 135 or 180
degrees about a random axis, for 1, 3, 5 or 10 frames, on 1-3 joints at once: knees, hips,
spine, arms) and ``mlayer.denoise`` of the glitched clip is compared with ``mlayer.denoise`` of
the clean one on joint positions, in % of body height: the largest displacement during the
flip and from 0.5 s after it (and before 0.5 s ahead of it). A sign change q -> -q on the same
frames is no flip at all: it must change nothing and find nothing.

Usage: python bench/python/bench_rot_outliers.py [--quick] [--clips a,b] [--clean]
  --clean: only count the outlier frames found on the clean clips (false positives).
"""
from __future__ import annotations

import argparse
import os
import math
import sys
import time
import zlib
from pathlib import Path

import numpy as np

import mlayer
from mlayer import metrics

# the shared clips beside the repository ($MLR_TEST_MOCAP_DIR overrides), and the gathered
# corpus of bench/python/corpus_clips.tsv ($MLR_TEST_CORPUS_DIR, default: a folder "corpus"
# beside the repository)
_REPO = Path(__file__).resolve().parents[2]
MOCAP = Path(os.environ.get("MLR_TEST_MOCAP_DIR", _REPO.parent / "shared" / "data" / "mocap"))
CORPUS = Path(os.environ.get("MLR_TEST_CORPUS_DIR", _REPO.parent / "corpus"))

CLIPS = {  # name: (path, first frame, frames or None)
    "lafan": (MOCAP / "lafan1_clip_a.bvh", 0, 1500),
    "mixamo": (CORPUS / "mixamo_joe_walk_in_circle.bvh", 0, None),
    "xsens": (CORPUS / "ammr_xsens_s01_trial01.bvh", 0, None),
    "cmu131": (MOCAP / "cmu_131_01_mj_style_walk.bvh", 0, None),
    "bandai": (MOCAP / "bandai1_walk_happy_001.bvh", 0, None),
    "dog": (MOCAP / "ai4a_dog_D1_008_KAN01_002.bvh", 0, None),
}

ROLES = {  # role: name fragments, first match wins (case-insensitive)
    "knee": ("leftleg", "leftknee", "lowerleg_l", "rightleg", "rightknee"),
    "hip": ("leftupleg", "lefthip", "upperleg_l", "rightupleg", "righthip"),
    "spine": ("spine1", "spine", "chest2", "chest"),
    "arm": ("leftforearm", "leftelbow", "lowerarm_l", "rightarm", "rightshoulder", "upperarm_r"),
}


def role_joint(m: mlayer.Motion, role: str, used: set[int]) -> int:
    names = [n.lower().split(":")[-1] for n in m.joint_names]
    for frag in ROLES[role]:
        for j, n in enumerate(names):
            if j > 0 and j not in used and n == frag:
                return j
    for frag in ROLES[role]:
        for j, n in enumerate(names):
            if j > 0 and j not in used and frag in n:
                return j
    raise LookupError(f"no {role} joint in {m.joint_names}")


def load(name: str) -> mlayer.Motion:
    path, a, n = CLIPS[name]
    m = mlayer.read_bvh(path)
    return m[a:a + n] if n else m[a:]


def inject(m: mlayer.Motion, at: int, length: int, joints: list[int], angle_deg: float,
           rng: np.random.Generator, negate: bool = False) -> mlayer.Motion:
    rot = m.rot.copy()
    for j in joints:
        ax = rng.normal(size=3)
        ax /= np.linalg.norm(ax)
        for i in range(at, at + length):
            if negate:
                rot[i, j] = -rot[i, j]
            else:
                turn = mlayer.quat.exp(math.radians(angle_deg) * ax)
                rot[i, j] = mlayer.quat.mul(rot[i, j], turn)
    return m.with_frames(rot=rot)


def measure(clean_pos: np.ndarray, den: mlayer.Motion, at: int, length: int, fps: float,
            h: float) -> tuple[float, float]:
    err = np.linalg.norm(den.positions() - clean_pos, axis=-1).max(axis=1) / h * 100.0
    during = float(err[at:at + length].max())
    w = int(math.ceil(0.5 * fps))
    far = np.ones(len(err), bool)
    far[max(0, at - w):at + length + w] = False
    return during, float(err[far].max()) if far.any() else 0.0


def run_cases(names: list[str], quick: bool) -> list[dict]:
    rows = []
    combos = [["knee", "hip", "arm"], ["spine"], ["knee", "arm"], ["hip", "spine", "arm"]]
    angles = [180.0] if quick else [180.0, 135.0, 90.0]
    lengths = [5] if quick else [1, 3, 5, 10]
    for name in names:
        m = load(name)
        h = metrics.body_height(m)
        t0 = time.perf_counter()
        clean = mlayer.denoise(m)
        clean_pos = clean.positions()
        t_den = time.perf_counter() - t0
        n_clean = int(mlayer.decompose(m).outliers[:, 1:].any(axis=1).sum())
        print(f"# {name}: {m.n_frames} frames at {m.fps:.1f} fps, {m.n_joints} joints, "
              f"h {h:.3g}, denoise {t_den:.2f} s, outlier frames on the clean clip {n_clean}",
              flush=True)
        rng = np.random.default_rng(zlib.crc32(name.encode()))
        k = 0
        cases = [(a, ln, False) for a in angles for ln in lengths] + [(0.0, 5, True)]
        for angle, length, neg in cases:
            roles = combos[k % len(combos)] if not (angle == 180.0 and length == 5) \
                else ["knee", "hip", "arm"]
            k += 1
            used: set[int] = set()
            joints = []
            for r in roles:
                j = role_joint(m, r, used)
                used.add(j)
                joints.append(j)
            at = int(rng.integers(int(0.3 * m.n_frames), int(0.7 * m.n_frames)))
            g = inject(m, at, length, joints, angle, rng, negate=neg)
            den = mlayer.denoise(g)
            during, far = measure(clean_pos, den, at, length, m.fps, h)
            out = mlayer.decompose(g).outliers
            hit = sum(int(out[at:at + length, 1 + j].sum()) for j in joints)
            fl = out[:, 1:].copy()
            for j in joints:
                fl[at:at + length, j] = False
            extra = int(fl.any(axis=1).sum())
            want = 0 if neg else length * len(joints)
            ok = during < 2.0 and far < 0.25 and (hit == want if not neg else hit == 0)
            row = dict(clip=name, angle=angle, length=length, neg=neg,
                       joints="+".join(m.joint_names[j].split(":")[-1] for j in joints),
                       at=at, during=during, far=far, found=hit, want=want, extra=extra, ok=ok)
            rows.append(row)
            print(f"{name:7s} {'neg' if neg else f'{angle:4.0f}'} x{length:2d} "
                  f"{row['joints']:36s} at {at:5d}: during {during:7.2f}%  after {far:6.3f}%  "
                  f"found {hit:2d}/{want:2d} other {extra:3d}  {'ok' if ok else 'FAIL'}",
                  flush=True)
    return rows


def clean_counts() -> None:
    import csv
    paths = sorted(MOCAP.glob("*.bvh"))
    with open(CORPUS / "MANIFEST.tsv") as f:
        for r in csv.DictReader(f, delimiter="\t"):
            if r["split"] == "tune":
                paths.append(CORPUS / r["file"])
    total = 0
    for p in paths:
        try:
            m = mlayer.read_bvh(p)
            if m.n_frames < 3:
                continue
            lay = mlayer.decompose(m)
        except Exception as e:  # noqa: BLE001
            print(f"{p.name:55s} error {e}")
            continue
        o = lay.outliers
        nj = int(o[:, 1:].any(axis=1).sum())
        nr = int(o[:, 0].sum())
        total += nj
        per = {m.joint_names[j]: int(o[:, 1 + j].sum()) for j in range(m.n_joints)
               if o[:, 1 + j].any()}
        top = sorted(per.items(), key=lambda kv: -kv[1])[:4]
        print(f"{p.name:55s} {m.n_frames:6d} fr {m.fps:6.1f} fps: joint outlier frames {nj:5d}"
              f"  root {nr:4d}  {top}", flush=True)
    print(f"total joint outlier frames {total}")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--clean", action="store_true")
    ap.add_argument("--clips", default=",".join(CLIPS))
    a = ap.parse_args()
    print(f"# mlayer from {mlayer.__file__}")
    if a.clean:
        clean_counts()
        return 0
    rows = run_cases(a.clips.split(","), a.quick)
    bad = [r for r in rows if not r["ok"]]
    print(f"# {len(rows) - len(bad)}/{len(rows)} cases hold")
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
