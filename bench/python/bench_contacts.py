"""Foot sliding and jitter of stylize(alpha=2) with and without contact cleanup, every clip.

    python bench/python/bench_contacts.py [MOCAP_DIR]

Sliding: mlayer.metrics.foot_sliding over the contacts detected on the original (clip units
per second); jitter: mlayer.metrics.jitter (units per frame^3); fix time: fix_contacts alone.
"""
import pathlib
import sys
import time

import mlayer
from mlayer.metrics import foot_sliding, jitter

d = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else
                 pathlib.Path(__file__).resolve().parents[3] / "shared/data/mocap")
print(f"{'clip':32} {'slide orig':>10} {'alpha=2':>9} {'+contacts':>9} | {'jitter a=2':>10} "
      f"{'+contacts':>9} {'change':>7} | fix s")
for f in sorted(d.glob("*.bvh")):
    m = mlayer.read_bvh(f)
    names, c = mlayer.detect_contacts(m)
    raw = mlayer.stylize(m, 2.0, keep_contacts=False)
    t0 = time.perf_counter()
    fixed = mlayer.fix_contacts(raw, c, names, reference=m)
    dt = time.perf_counter() - t0
    jr, jf = jitter(raw), jitter(fixed)
    print(f"{f.name:32} {foot_sliding(m, c, names):10.3g} {foot_sliding(raw, c, names):9.3g} "
          f"{foot_sliding(fixed, c, names):9.3g} | {jr:10.4g} {jf:9.4g} {100 * (jf / jr - 1):+6.1f}% "
          f"| {dt:.3f}")
