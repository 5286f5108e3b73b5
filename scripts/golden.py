"""Golden dump and compare, for changes that must keep mlayer's output.

It runs denoise and stylize at alpha 0.5, 2 and 3 on every clip of ../shared/data/mocap and
keeps the rotations, the root, and the counts of the guards' reports. A change meant to be exact
passes when `compare` prints a max diff of at most 1e-12 and no REPORT line.

    python scripts/golden.py dump BEFORE.npz    (with the old build installed)
    python scripts/golden.py dump AFTER.npz     (with the new build)
    python scripts/golden.py compare BEFORE.npz AFTER.npz
"""

import glob
import os
import sys

import numpy as np

ALPHAS = (0.5, 2.0, 3.0)
TOLERANCE = 1e-12


def run_clip(mlayer, m):
    """(tag, output motion, report) for denoise and each stylize alpha."""
    yield ("den", *mlayer.denoise(m, return_report=True))
    for a in ALPHAS:
        yield (f"st{a:g}", *mlayer.stylize(m, a, return_report=True))


def dump(out):
    import mlayer

    here = os.path.dirname(os.path.abspath(__file__))
    pattern = os.path.join(here, "..", "..", "shared", "data", "mocap", "*.bvh")
    clips = sorted(glob.glob(pattern))
    if not clips:
        sys.exit(f"golden: no clips match {pattern}")
    res = {}
    for path in clips:
        name = os.path.basename(path)[:-4]
        for tag, o, rep in run_clip(mlayer, mlayer.read_bvh(path)):
            key = f"{name}/{tag}"
            res[key + "/rot"] = np.asarray(o.rot)
            res[key + "/root"] = np.asarray(o.root_pos)
            counts = [float(v) for _, v in sorted(rep.limited.items())]
            counts += [float(rep.contact_frames), float(rep.floor_frames), float(rep.floor_raised)]
            res[key + "/rep"] = np.asarray(counts)
            res[key + "/shift"] = np.asarray([rep.root_shift_max, rep.floor_height])
        print(name, file=sys.stderr)
    np.savez(out, **res)


def same_hemisphere(q):
    """Quaternions with w >= 0 (q and -q are the same rotation)."""
    return q * np.where(q[..., :1] < 0, -1.0, 1.0)


def compare(before, after):
    a, b = np.load(before), np.load(after)
    worst = 0.0
    for key in a.files:
        x, y = a[key], b[key]
        if x.shape != y.shape:
            print("SHAPE", key, x.shape, y.shape)
            continue
        if key.endswith("/rot"):
            x, y = same_hemisphere(x), same_hemisphere(y)
        diff = np.where(np.isnan(x) & np.isnan(y), 0.0, np.abs(x - y))
        d = float(np.max(np.where(np.isnan(diff), np.inf, diff))) if x.size else 0.0
        if key.endswith("/rep"):
            if d != 0:
                print("REPORT", key, x, y)
            continue
        worst = max(worst, d)
        if d > TOLERANCE:
            print(f"DIFF {d:.3g}", key)
    print(f"max diff {worst:.3g}")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "dump":
        dump(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        compare(sys.argv[2], sys.argv[3])
    else:
        sys.exit("usage: golden.py dump OUT.npz | golden.py compare BEFORE.npz AFTER.npz")
