"""Golden outputs: denoise and stylize at alpha 0.5, 2 and 3, kept for changes that must keep
mlayer's output.

Two ways to use it.

In the test suite (bindings/python/tests/test_golden.py): `fingerprints` reduces each output
(the rotations, the root, the counts of the guards' report) to a few numbers, and
bindings/python/tests/data/golden.json holds those of the clips in this repository (the
bundled sample, two clips of tests/data/wild) and of the shared clips (../shared/data/mocap,
checked when they are there). A change meant to keep the output keeps the test passing; a
change meant to alter it rewrites the file, in the same commit, with

    python scripts/golden.py reference bindings/python/tests/data/golden.json

By hand, for a full comparison of every value (with the old build installed, then the new):

    python scripts/golden.py dump BEFORE.npz
    python scripts/golden.py dump AFTER.npz
    python scripts/golden.py compare BEFORE.npz AFTER.npz

A change meant to be exact passes when `compare` prints a max diff of at most 1e-12 and no
REPORT line.
"""

import glob
import hashlib
import json
import math
import os
import sys

import numpy as np

ALPHAS = (0.5, 2.0, 3.0)
TOLERANCE = 1e-12
HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
#: clips of this repository, relative to it (the sample is mlayer.data.sample_path())
REPO_CLIPS = ("bindings/python/mlayer/data/cmu_131_01_mj_style_walk.bvh",
              "tests/data/wild/fair1_jumping_zup_first400.bvh",
              "tests/data/wild/pymo_av_8walk_meredith_first600.bvh")
#: number of projections per array, and the seed of their weights
N_PROJECTIONS = 8
SEED = 20240


def shared_dir():
    """../shared/data/mocap beside the repository, or $MLR_TEST_MOCAP_DIR."""
    return os.environ.get("MLR_TEST_MOCAP_DIR") or os.path.join(REPO, "..", "shared", "data",
                                                                  "mocap")


def run_clip(mlayer, m):
    """(tag, output motion, report) for denoise and each stylize alpha."""
    yield ("den", *mlayer.denoise(m, return_report=True))
    for a in ALPHAS:
        yield (f"st{a:g}", *mlayer.stylize(m, a, return_report=True))


def outputs(mlayer, path):
    """{key: array} of one clip: per case its rotations, root, report counts and shift."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mlayer.ParseWarning)  # the wild clips' known deviations
        m = mlayer.read_bvh(path)
    res = {}
    for tag, o, rep in run_clip(mlayer, m):
        res[tag + "/rot"] = np.asarray(o.rot)
        res[tag + "/root"] = np.asarray(o.root_pos)
        counts = [float(v) for _, v in sorted(rep.limited.items())]
        counts += [float(rep.contact_frames), float(rep.floor_frames), float(rep.floor_raised)]
        res[tag + "/rep"] = np.asarray(counts)
        res[tag + "/shift"] = np.asarray([rep.root_shift_max, rep.floor_height])
    return res


def dump(out):
    import mlayer

    pattern = os.path.join(shared_dir(), "*.bvh")
    clips = sorted(glob.glob(pattern))
    if not clips:
        sys.exit(f"golden: no clips match {pattern}")
    res = {}
    for path in clips:
        name = os.path.basename(path)[:-4]
        for key, v in outputs(mlayer, path).items():
            res[f"{name}/{key}"] = v
        print(name, file=sys.stderr)
    np.savez(out, **res)


def same_hemisphere(q):
    """Quaternions with w >= 0 (q and -q are the same rotation)."""
    return q * np.where(q[..., :1] < 0, -1.0, 1.0)


def weights(n, k):
    """Weight k of n values: uniform in [-1, 1) from splitmix64, the same on every machine."""
    i = np.arange(n, dtype=np.uint64) + np.uint64(k * (1 << 40) + 1)
    z = np.uint64(SEED) + i * np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) * 2.0**-52 - 1.0


def fingerprint(key, x):
    """A few numbers that move when any value of x moves.

    Rotations are taken in one hemisphere first. For an array: its shape, the SHA-256 of its
    bytes (equal: bit-identical), its largest magnitude and N_PROJECTIONS projections on
    weights in [-1, 1), each product rounded once and summed exactly (math.fsum), so that
    they depend on the values alone, not on the machine's summation order: a change d of one
    value moves a projection by |d| times its weight. Report counts are kept as they are.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    if key.endswith("/rot"):
        x = same_hemisphere(x)
    fp = {"shape": list(x.shape), "sha256": hashlib.sha256(x.tobytes()).hexdigest()}
    if key.endswith("/rep") or key.endswith("/shift"):
        fp["values"] = x.ravel().tolist()
        return fp
    flat = x.ravel()
    fp["max_abs"] = float(np.max(np.abs(flat))) if flat.size else 0.0
    fp["projections"] = [math.fsum(weights(flat.size, k) * flat) for k in range(N_PROJECTIONS)]
    return fp


def fingerprints(mlayer, path):
    return {key: fingerprint(key, v) for key, v in outputs(mlayer, path).items()}


def compare_fingerprints(ref, new, tolerance):
    """Lines that say where new differs from ref (empty: the same within tolerance).

    Projections and the root shift must agree within tolerance times the array's largest
    magnitude (at least 1); report counts and shapes exactly.
    """
    bad = []
    for key in sorted(set(ref) | set(new)):
        if key not in ref or key not in new:
            bad.append(f"{key}: only in {'the reference' if key in ref else 'this build'}")
            continue
        a, b = ref[key], new[key]
        if a["shape"] != b["shape"]:
            bad.append(f"{key}: shape {a['shape']} -> {b['shape']}")
            continue
        if "values" in a:
            x, y = np.asarray(a["values"]), np.asarray(b["values"])
            if key.endswith("/rep"):
                if not np.array_equal(x, y):
                    bad.append(f"{key}: report counts {x.tolist()} -> {y.tolist()}")
            else:
                d = np.max(np.abs(x - y) / np.maximum(1.0, np.abs(x))) if x.size else 0.0
                if not d <= tolerance:
                    bad.append(f"{key}: {x.tolist()} -> {y.tolist()}")
            continue
        scale = max(1.0, a["max_abs"])
        d = float(np.max(np.abs(np.subtract(a["projections"], b["projections"])))) / scale
        if not d <= tolerance:
            bad.append(f"{key}: projections differ by {d:.3g} of the largest value "
                       f"(tolerance {tolerance:g})")
    return bad


def reference(out):
    """Write the fingerprints of the repository's clips and of the shared ones present."""
    import mlayer

    clips = {rel: os.path.join(REPO, rel) for rel in REPO_CLIPS}
    for path in sorted(glob.glob(os.path.join(shared_dir(), "*.bvh"))):
        clips["shared/" + os.path.basename(path)] = path
    res = {"mlayer": mlayer.__version__, "alphas": list(ALPHAS), "clips": {}}
    for name, path in clips.items():
        res["clips"][name] = fingerprints(mlayer, path)
        print(name, file=sys.stderr)
    with open(out, "w") as f:
        json.dump(res, f, indent=1, sort_keys=True)
        f.write("\n")


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
    elif len(sys.argv) == 3 and sys.argv[1] == "reference":
        reference(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        compare(sys.argv[2], sys.argv[3])
    else:
        sys.exit("usage: golden.py dump OUT.npz | golden.py reference OUT.json | "
                 "golden.py compare BEFORE.npz AFTER.npz")
