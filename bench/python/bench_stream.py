"""Per-frame cost of mlayer.Stream through Python, on one real clip: the push paths (a flat
array, a (root_pos, rot) tuple, a one-frame Motion), stream_motion, and a One Euro filter in
numpy for scale. Each figure is the median (and the fastest) over the repeats of (time of one
pass over the clip) / frames; the clip's frames are prepared before the timer starts.

    python bench/python/bench_stream.py [--clip cmu_131_01_mj_style_walk.bvh] [--lag 10]
                                        [--repeat 21] [--mocap DIR]
"""
from __future__ import annotations

import argparse
import pathlib
import time

import numpy as np

import mlayer
from benchutil import mocap_dir
from mlayer.layers.one_euro import OneEuroFilter
from mlayer.pipeline.stream import motion_channels

HERE = pathlib.Path(__file__).resolve()
DEFAULT_MOCAP = mocap_dir()


def per_frame_us(fn, n, repeat):
    """Median and fastest pass, microseconds per frame (the fastest is the one least disturbed
    by other processes on a shared machine)."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return f"{1e6 * float(np.median(times)) / n:8.2f} {1e6 * min(times) / n:8.2f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default="cmu_131_01_mj_style_walk.bvh")
    ap.add_argument("--lag", type=int, default=10)
    ap.add_argument("--lam", type=float, default=1.0)
    ap.add_argument("--sigma", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=21)
    ap.add_argument("--mocap", default=str(DEFAULT_MOCAP))
    a = ap.parse_args()
    m = mlayer.read_bvh(pathlib.Path(a.mocap) / a.clip)
    N = m.n_frames
    y = motion_channels(m)
    tuples = [(m.root_pos[f], m.rot[f]) for f in range(N)]
    frames = [m[f] for f in range(N)]
    st = mlayer.Stream(m, lam=a.lam, sigma=a.sigma, lag=a.lag)

    def run(items):
        def go():
            st.reset()
            for it in items:
                st.push(it)
            st.flush()
        return go

    def euro():
        f = OneEuroFilter(m.fps, 20.0)
        for row in y:
            f(row)

    print(f"{a.clip}: {N} frames, {m.n_joints} joints, lag {a.lag}, lam {a.lam:g}, "
          f"sigma {a.sigma:g}; {a.repeat} passes, microseconds per frame")
    print("                          median  fastest")
    print(f"  push(flat array)      {per_frame_us(run(list(y)), N, a.repeat)}")
    print(f"  push((root, rot))     {per_frame_us(run(tuples), N, a.repeat)}")
    print(f"  push(Motion frame)    {per_frame_us(run(frames), N, a.repeat)}")
    whole = lambda: mlayer.stream_motion(m, lam=a.lam, sigma=a.sigma, lag=a.lag)  # noqa: E731
    print(f"  stream_motion         {per_frame_us(whole, N, a.repeat)}")
    print(f"  One Euro (numpy)      {per_frame_us(euro, N, a.repeat)}")


if __name__ == "__main__":
    main()
