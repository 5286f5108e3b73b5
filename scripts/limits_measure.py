"""Measure joint limits on the shared clips: fold / reversal frames of knees and elbows before
-> after limits and the exaggeration kept (RMS of the controllable-layer amplitude after /
before, per body part), for stylize(m, alpha, keep_contacts=False) at alpha 0.5, 2, 3.
Usage: python scripts/limits_measure.py [clip-name-part ...]"""
import sys, glob, time, numpy as np, mlayer
from mlayer.guards import plausibility as pl
from mlayer.guards.limits import apply_limits
import os, pathlib
MOCAP = os.environ.get('MLR_TEST_MOCAP_DIR') or str(pathlib.Path(__file__).resolve().parents[2] / 'shared' / 'data' / 'mocap')
clips = sorted(glob.glob(MOCAP + '/*.bvh'))
if len(sys.argv) > 1: clips = [c for c in clips if any(a in c for a in sys.argv[1:])]
for f in clips:
    m = mlayer.read_bvh(f)
    lim = mlayer.joint_limits(m)
    lay = mlayer.decompose(m)
    base = lay.base.rot
    parts = pl.body_parts(m, lim)
    name = f.split('/')[-1][:22]
    for a in (0.5, 2.0, 3.0):
        s = lay.synthesize(a)
        t0 = time.perf_counter(); out, rep = apply_limits(s, lim, a); dt = time.perf_counter() - t0
        v0 = pl.hinge_violations(m, s, lim); v1 = pl.hinge_violations(m, out, lim)
        kept = pl.exaggeration_kept(base, s.rot, out.rot, parts)
        print(f"{name:22s} a={a:3.1f} fold {v0['fold_frames']:5d}->{v1['fold_frames']:3d} "
              f"rev {v0['reversal_frames']:5d}->{v1['reversal_frames']:3d} /{s.n_frames:5d}  kept "
              + " ".join(f"{k} {v:.3f}" for k, v in kept.items()) + f"  apply {dt*1e3:.1f} ms", flush=True)
