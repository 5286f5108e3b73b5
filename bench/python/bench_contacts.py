"""Foot sliding and jitter of stylize(alpha=2) with and without contact cleanup, every clip.

    python bench/python/bench_contacts.py [MOCAP_DIR]

Sliding: mlayer.metrics.foot_sliding over the contacts detected on the original (clip units
per second), and the cleaned result's sliding as a multiple of the original's ("x orig"; the
acceptance bound is 1.5); jitter: mlayer.metrics.jitter on all joints (units per frame^3) and
its change from the uncleaned result (bound: +10%); fix time: fix_contacts alone, one run.
The CMU files converted with an inserted T-pose (every cmu_* clip but cmu_131_01) start at
frame 6, past the T-pose and its interpolated blend frames (see the data README).
"""
import pathlib
import sys
import time

import mlayer
from mlayer.guards.metrics import foot_sliding, jitter

d = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else
                 pathlib.Path(__file__).resolve().parents[3] / "shared/data/mocap")
print(f"{'clip':32} {'slide orig':>10} {'alpha=2':>9} {'+contacts':>9} {'x orig':>6} | "
      f"{'jitter a=2':>10} {'+contacts':>9} {'change':>7} | fix s")
for f in sorted(d.glob("*.bvh")):
    m = mlayer.read_bvh(f)
    if f.name.startswith("cmu_") and not f.name.startswith("cmu_131_"):
        m = m[6:]
    names, c = mlayer.detect_contacts(m)
    raw = mlayer.stylize(m, 2.0, keep_contacts=False)
    t0 = time.perf_counter()
    fixed = mlayer.fix_contacts(raw, c, names, reference=m)
    dt = time.perf_counter() - t0
    so, sr, sf = (foot_sliding(x, c, names) for x in (m, raw, fixed))
    jr, jf = jitter(raw), jitter(fixed)
    print(f"{f.name:32} {so:10.3g} {sr:9.3g} {sf:9.3g} {sf / so:6.2f} | {jr:10.4g} {jf:9.4g} "
          f"{100 * (jf / jr - 1):+6.1f}% | {dt:.3f}")
