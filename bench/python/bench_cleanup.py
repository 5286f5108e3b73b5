"""Harm and floor of the contact cleanup, every clip (issue 18, items 3 and 4).

    python bench/python/bench_cleanup.py [MOCAP_DIR ...] [--floor]

Harm (item 4): max joint displacement of denoise(m) against denoise(m, keep_contacts=False),
in % of body height (target <= 0.5), and foot sliding (mlayer.metrics.foot_sliding over the
contacts detected on the input) of the input, of denoise without and with the cleanup.
Floor (item 3): stylize(m, a, keep_contacts=False) ("raw") and the cleaned stylize at alpha 2
and 3: frames where a contact point is below min(floor, its input height) by more than 0.5% of
body height, in % of frames, and the deepest, in % of body height. floor: the input's floor
height (mlayer.guards.cleanup.floor_height when present, else the same statistic in numpy: the 5%
quantile of the contact points' heights on their contact frames). The CMU clips converted with
an inserted T-pose (every cmu_* but cmu_131_01) start at frame 6 (see the data README).
"""
import pathlib
import sys
import time

import numpy as np

import mlayer
from mlayer.guards import contacts as C
from mlayer.guards.metrics import body_height, foot_sliding

args = [a for a in sys.argv[1:] if not a.startswith("--")]
dirs = [pathlib.Path(a) for a in args] or [
    pathlib.Path(__file__).resolve().parents[3] / "shared/data/mocap"]
UP = 1


def floor_of(m, names, c):
    try:
        from mlayer.guards.cleanup import floor_height
        return floor_height(m, c, names)
    except ImportError:
        p = C.contact_positions(m, names)[..., UP]
        return float(np.quantile(p[c], 0.05))


def penetration(out, m, names, floor, H):
    po = C.contact_positions(out, names)[..., UP]
    pi = C.contact_positions(m, names)[..., UP]
    below = po < np.minimum(floor, pi) - 0.005 * H
    frames = below.any(axis=1)
    depth = np.where(below, np.minimum(floor, pi) - po, 0.0).max() / H
    return 100 * frames.mean(), 100 * depth


print(f"{'clip':34} {'harm %H':>8} {'slide in':>9} {'den':>8} {'den+fix':>8} | "
      + " | ".join(f"a={a} raw %f/deep  fixed %f/deep" for a in (2, 3)) + " | fix s")
for d in dirs:
    for f in sorted(d.glob("*.bvh")):
        m = mlayer.read_bvh(f)
        if f.name.startswith("cmu_") and not f.name.startswith("cmu_131_"):
            m = m[6:]
        try:
            names, c = mlayer.detect_contacts(m)
        except mlayer.InvalidArgumentError as e:
            print(f"{f.name:34} no contacts: {e}"[:120])
            continue
        pos = m.positions()
        H = body_height(pos)
        floor = floor_of(m, names, c)
        den = mlayer.denoise(m, keep_contacts=False)
        t0 = time.perf_counter()
        fix = mlayer.denoise(m)
        dt = time.perf_counter() - t0
        harm = np.linalg.norm(fix.positions() - den.positions(), axis=-1).max() / H
        sl = [foot_sliding(x, c, names) for x in (m, den, fix)]
        cols = []
        for a in (2.0, 3.0):
            raw = mlayer.stylize(m, a, keep_contacts=False)
            st = mlayer.stylize(m, a)
            pr, dr = penetration(raw, m, names, floor, H)
            pf, df = penetration(st, m, names, floor, H)
            cols.append(f"{pr:5.1f}/{dr:5.2f} {pf:5.1f}/{df:5.2f}")
        print(f"{f.name:34} {100 * harm:8.3f} {sl[0]:9.3g} {sl[1]:8.3g} {sl[2]:8.3g} | "
              + " | ".join(f"{x:>30}" for x in cols) + f" | {dt:.3f}", flush=True)
