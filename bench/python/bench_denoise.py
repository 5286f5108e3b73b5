"""Denoising quality on the real clips: mlayer.denoise against classic filters, in one run.

Each clip of the shared mocap folder gets seeded synthetic noise: every joint rotation is
multiplied by exp(v) with v ~ N(0, (1.5 deg)^2) per axis, the root translation gets
N(0, (0.5% of body height)^2) per axis. Then every method smooths the noisy clip and we
measure, against the clean clip, on world joint positions (forward kinematics):

  MPJPE   mean per-joint position error, in % of body height (units differ between clips)
  jitter  mean |third difference| of the positions per second^3, in body heights / s^3

Methods
  mlayer.denoise   automatic smoothing (GCV per joint), no knowledge of the clean clip
  butter@fc        4th-order Butterworth low-pass run forward and backward (scipy filtfilt) on
                   the hemisphere-aligned quaternion components (renormalized) and the root
                   translation, cutoff fc Hz; "butter-oracle" is the cutoff with the lowest
                   MPJPE for that clip, chosen knowing the clean clip
  savgol@w         Savitzky-Golay (polyorder 3) with a window of w seconds, same channels;
                   "savgol-oracle" likewise
  whittaker        scipy.signal.whittaker_henderson per channel, when the installed scipy has it

Usage: python bench/python/bench_denoise.py [--mocap DIR] [--seed 0] [--clips PATTERN]
The CMU converter's T-pose and blend frames (first 6 frames of the cgspeed files except 131_01)
are dropped before anything else.
"""
from __future__ import annotations

import argparse
import fnmatch
import os
import sys
import time

import numpy as np
import scipy
import scipy.signal as sig

import mlayer
from mlayer import metrics

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_MOCAP = os.path.normpath(os.path.join(HERE, "..", "..", "..", "shared", "data", "mocap"))
TPOSE_FRAMES = {"cmu_01_01": 1, "cmu_10_01": 6, "cmu_60_10": 6, "cmu_02_03": 6}
BUTTER_CUTOFFS = [1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0]
SAVGOL_WINDOWS = [0.1, 0.15, 0.2, 0.3, 0.4, 0.6]


def add_noise(m, rng, deg=1.5, root_frac=0.005):
    height = body_height(m)
    v = rng.normal(scale=np.radians(deg), size=m.rot.shape[:-1] + (3,))
    rot = mlayer.quat.mul(m.rot, mlayer.quat.exp(v))
    root = m.root_pos + rng.normal(scale=root_frac * height, size=m.root_pos.shape)
    return m.with_frames(root_pos=root, rot=rot)


def body_height(m):
    p = m.positions()
    return float(np.median(p[:, :, 1].max(axis=1) - p[:, :, 1].min(axis=1)))


def _channels(m):
    q = mlayer.quat.continuous(m.rot)
    return np.concatenate([m.root_pos, q.reshape(len(q), -1)], axis=1)


def _from_channels(m, ch):
    root = ch[:, :3]
    q = ch[:, 3:].reshape(m.rot.shape)
    return m.with_frames(root_pos=root, rot=mlayer.quat.normalize(q))


def butter(m, fc):
    nyq = 0.5 * m.fps
    if fc >= nyq:
        return None
    b, a = sig.butter(4, fc / nyq)
    return _from_channels(m, sig.filtfilt(b, a, _channels(m), axis=0))


def savgol(m, seconds):
    w = int(round(seconds * m.fps)) | 1
    if w <= 3 or w >= m.n_frames:
        return None
    return _from_channels(m, sig.savgol_filter(_channels(m), w, 3, axis=0))


def whittaker(m):
    wh = getattr(sig, "whittaker_henderson", None)
    if wh is None:
        return None
    ch = _channels(m)
    return _from_channels(m, np.stack([wh(ch[:, c]) for c in range(ch.shape[1])], axis=1))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mocap", default=os.environ.get("MLR_TEST_MOCAP_DIR", DEFAULT_MOCAP))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--clips", default="*.bvh", help="glob on the file names")
    args = ap.parse_args(argv)

    files = sorted(f for f in os.listdir(args.mocap) if fnmatch.fnmatch(f, args.clips)
                   and f.endswith(".bvh"))
    if not files:
        sys.exit(f"bench_denoise: no clips matching {args.clips} in {args.mocap}")
    print(f"# mlayer {mlayer.__version__}, scipy {scipy.__version__}; seed {args.seed}; "
          f"noise 1.5 deg/axis, root 0.5% of body height")
    if not hasattr(sig, "whittaker_henderson"):
        print(f"# scipy.signal.whittaker_henderson: not in scipy {scipy.__version__}, skipped")
    rows = []
    for k, f in enumerate(files):
        m = mlayer.read_bvh(os.path.join(args.mocap, f))
        skip = next((n for key, n in TPOSE_FRAMES.items() if f.startswith(key)), 0)
        clean = m[skip:]
        rng = np.random.default_rng([args.seed, k])
        noisy = add_noise(clean, rng)
        h = body_height(clean)
        pc = clean.positions()

        def score(out):
            return (100.0 * metrics.mpjpe(out.positions(), pc) / h,
                    metrics.jitter(out.positions(), fps=clean.fps) / h)

        res = {"noisy": score(noisy), "clean": (0.0, metrics.jitter(pc, fps=clean.fps) / h)}
        t0 = time.perf_counter()
        den = mlayer.denoise(noisy)
        t_den = time.perf_counter() - t0
        res["mlayer.denoise"] = score(den)
        bs = {fc: score(o) for fc in BUTTER_CUTOFFS if (o := butter(noisy, fc)) is not None}
        best = min(bs, key=lambda fc: bs[fc][0])
        res[f"butter-oracle ({best:g} Hz)"] = bs[best]
        for fc in (2.0, 4.0, 6.0):
            if fc in bs:
                res[f"butter@{fc:g}Hz"] = bs[fc]
        ss = {w: score(o) for w in SAVGOL_WINDOWS if (o := savgol(noisy, w)) is not None}
        if ss:
            bw = min(ss, key=lambda w: ss[w][0])
            res[f"savgol-oracle ({bw:g} s)"] = ss[bw]
        wh = whittaker(noisy)
        if wh is not None:
            res["whittaker"] = score(wh)
        print(f"\n## {f}: {clean.n_frames} frames at {clean.fps:g} fps, {clean.n_joints} joints "
              f"(denoise {1e3 * t_den:.1f} ms in Python)")
        print(f"{'method':28s} {'MPJPE %h':>9s} {'jitter h/s^3':>13s}")
        for name, (e, j) in res.items():
            print(f"{name:28s} {e:9.3f} {j:13.1f}")
        rows.append(res)

    print("\n## mean over clips")
    names = ["noisy", "mlayer.denoise"]
    mean = {n: np.mean([r[n] for r in rows], axis=0) for n in names}
    mean["butter-oracle (per clip)"] = np.mean(
        [next(v for k2, v in r.items() if k2.startswith("butter-oracle")) for r in rows], axis=0)
    mean["savgol-oracle (per clip)"] = np.mean(
        [next(v for k2, v in r.items() if k2.startswith("savgol-oracle")) for r in rows], axis=0)
    for n, (e, j) in mean.items():
        print(f"{n:28s} {e:9.3f} {j:13.1f}")
    e_ml, e_bw = mean["mlayer.denoise"][0], mean["butter-oracle (per clip)"][0]
    print(f"\nmlayer.denoise MPJPE / best-cutoff Butterworth MPJPE = {e_ml / e_bw:.3f} "
          f"({'beats' if e_ml < e_bw else 'does not beat'} the oracle Butterworth)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
