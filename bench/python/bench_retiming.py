"""Drift of frame-rate round trips: resample a clip F_in -> F_mid -> F_in fps (LGS and SLERP)
and compare output frame k with input frame k (both at time k / F_in when the retiming is
exact). Prints the mean joint position error (MPJPE) in body heights over the first and the
last 10 % of the frames and over the whole clip; an exact retiming shows no growth from start
to end.

    python bench/python/bench_retiming.py [--clip cmu_131_01_mj_style_walk.bvh] [--mid 30]

The clips folder: $MLR_TEST_MOCAP_DIR, else ../shared/data/mocap beside the repository.
"""
from __future__ import annotations

import argparse

import numpy as np

import mlayer
from benchutil import mocap_dir


def round_trip_errors(m, mid, fn):
    """Per-frame MPJPE / body height of fn(fn(m, mid), m.fps) against m (common frames)."""
    back = fn(fn(m, mid), m.fps)
    n = min(len(back), len(m))
    p, q = m[:n].positions(), back[:n].positions()
    h = mlayer.metrics.body_height(m)
    return np.linalg.norm(p - q, axis=2).mean(axis=1) / h, len(back)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default="cmu_131_01_mj_style_walk.bvh")
    ap.add_argument("--mid", type=float, default=30.0)
    a = ap.parse_args()
    m = mlayer.read_bvh(mocap_dir() / a.clip)
    print(f"{a.clip}: {len(m)} frames at {m.fps:.6g} fps -> {a.mid:g} -> {m.fps:.6g} fps")
    for name, fn in (("resample", lambda x, f: mlayer.resample(x, fps=f)),
                     ("slerp_resample", lambda x, f: mlayer.slerp_resample(x, fps=f))):
        e, n_back = round_trip_errors(m, a.mid, fn)
        k = max(1, len(e) // 10)
        print(f"  {name:15s} back to {n_back} frames; MPJPE / body height: first 10 % "
              f"{e[:k].mean():.2e}, last 10 % {e[-k:].mean():.2e}, last frame {e[-1]:.2e}, "
              f"mean {e.mean():.2e}, max {e.max():.2e} (frame {int(e.argmax())})")


if __name__ == "__main__":
    main()
