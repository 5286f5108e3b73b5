"""Resampling speed: mlayer.resample (LGS) and mlayer.slerp_resample against scipy (a Slerp per
joint plus np.interp for the root) on a 10-minute 120 fps clip (a real clip played forwards
and backwards until it has 72,000 frames), 120 -> 30 fps, in the same run. Reports medians
and ratios.

    python bench/python/bench_resample.py [--clip cmu_01_01_playground_jumps.bvh]
        [--frames 72000] [--fps 30] [--repeat 5]

The clips folder: $MLR_TEST_MOCAP_DIR, else ../shared/data/mocap beside the repository.
"""
from __future__ import annotations

import argparse

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

import mlayer
from benchutil import median_seconds, mocap_dir

def long_clip(m, n_frames):
    """Frames 0..N-1, N-2..1, 0..N-1, ... (no jumps at the joins) up to n_frames."""
    idx = np.r_[np.arange(len(m)), np.arange(len(m) - 2, 0, -1)]
    idx = np.resize(idx, n_frames)
    return m.with_frames(root_pos=m.root_pos[idx], rot=m.rot[idx], trans=m.trans[idx])


def scipy_resample(m, n_out):
    """The usual numpy/scipy way: a Slerp per joint at the output times, np.interp for the root
    (rotation quaternions to scalar-last and back included)."""
    N, J = m.n_frames, m.n_joints
    t_in = np.arange(N) * (n_out - 1) / (N - 1)
    t_out = np.minimum(np.arange(n_out, dtype=float), t_in[-1])
    rot = np.empty((n_out, J, 4))
    q = m.rot[..., [1, 2, 3, 0]]
    for j in range(J):
        rot[:, j] = Slerp(t_in, Rotation.from_quat(q[:, j]))(t_out).as_quat()[:, [3, 0, 1, 2]]
    root = np.stack([np.interp(t_out, t_in, m.root_pos[:, c]) for c in range(3)], 1)
    return root, rot


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default="cmu_01_01_playground_jumps.bvh")
    ap.add_argument("--frames", type=int, default=72000)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    src = mlayer.read_bvh(mocap_dir() / a.clip)
    m = long_clip(src[1:], a.frames)  # without the converter's T-pose frame
    out = mlayer.resample(m, fps=a.fps)
    n_out = len(out)
    # the baselines agree with each other (same frames, shorter arc)
    root_s, rot_s = scipy_resample(m, n_out)
    sl = mlayer.slerp_resample(m, fps=a.fps)
    assert np.abs(sl.root_pos - root_s).max() < 1e-9
    assert np.abs(np.abs(np.einsum("...i,...i->...", sl.rot, rot_s)) - 1).max() < 1e-9

    t_lgs = median_seconds(lambda: mlayer.resample(m, fps=a.fps), a.repeat)
    t_sl = median_seconds(lambda: mlayer.slerp_resample(m, fps=a.fps), a.repeat)
    t_sp = median_seconds(lambda: scipy_resample(m, n_out), a.repeat)
    print(f"{a.clip}: {len(m)} frames at {m.fps:.6g} fps ({len(m) / m.fps / 60:.1f} min), "
          f"{m.n_joints} joints, {m.trans.shape[1]} extra translations -> {n_out} frames at "
          f"{a.fps:g} fps; medians of {a.repeat} runs")
    print(f"  mlayer.resample (LGS)          {t_lgs * 1e3:8.1f} ms")
    print(f"  mlayer.slerp_resample          {t_sl * 1e3:8.1f} ms")
    print(f"  scipy Slerp per joint + interp {t_sp * 1e3:8.1f} ms")
    print(f"  scipy / mlayer.resample        {t_sp / t_lgs:8.1f}x")


if __name__ == "__main__":
    main()
