"""AMASS import speed: mlayer.read_amass against the numpy glue users write today.

    python bench/python/bench_amass.py [--frames 10000] [--repeat 7]

The clip is synthetic (AMASS is licensed, not redistributable) but of AMASS's layout and a
realistic size: an SMPL-H .npz with ``poses`` (F, 156), ``trans``, ``mocap_framerate``,
``betas``, ``gender``, written uncompressed as AMASS's files are, F = 10,000 frames (83 s at
120 fps) by default. Both sides start from the file and end with a mlayer.Motion on the
52-joint SMPL-H tree with the same joints, offsets and frames:

- ``read_amass``: mlayer.read_amass(path) (validation of every key, C rotation vectors to
  quaternions, the SMPL order reordered to depth-first in one place);
- ``numpy glue``: np.load, scipy ``Rotation.from_rotvec`` on all F x 52 vectors, scalar-last
  to scalar-first, the depth-first joint order computed by hand and the rotations reordered,
  then ``Motion.from_arrays`` (what a user needed before read_amass: Motion did not take the
  SMPL order).

The two take turns (--repeat rounds of one call each), so that the slow spells of a shared
machine fall on both. Prints the median of the repeats for each, frames/s, the ratio
glue / read_amass, and checks that the two motions agree; the np.load row is the part of
both that reads the archive (zip CRC and copy), the rest is the conversion.
"""
from __future__ import annotations

import argparse
import pathlib
import tempfile

import numpy as np
from scipy.spatial.transform import Rotation

import mlayer
from mlayer.io import smpl
from benchutil import median_seconds


def write_clip(path: pathlib.Path, frames: int, seed: int = 1) -> None:
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / 120.0
    poses = 0.3 * np.sin(2 * np.pi * (t[:, None] * rng.uniform(0.3, 2.0, 156)
                                      + rng.uniform(0, 1, 156)))
    poses[:, :3] = Rotation.from_euler("x", 90, degrees=True).as_rotvec()
    trans = np.stack([0.1 * np.sin(t), 1.2 * t, 0.9 + 0.02 * np.sin(4 * t)], axis=1)
    with open(path, "wb") as f:
        np.savez(f, poses=poses, trans=trans, mocap_framerate=np.array(120.0),
                 betas=np.zeros(16), gender=np.array("neutral"))


def numpy_glue(path) -> mlayer.Motion:
    """The import a user writes without read_amass (SMPL-H, the published parents)."""
    names, parents, offsets = smpl.SMPLH_NAMES, smpl.SMPLH_PARENTS, smpl.SMPLH_OFFSETS
    with np.load(path) as z:
        poses, trans = z["poses"], z["trans"]
        fps = float(z["mocap_framerate"])
    F, J = poses.shape[0], len(names)
    q = Rotation.from_rotvec(poses.reshape(-1, 3)).as_quat().reshape(F, J, 4)
    q = q[..., [3, 0, 1, 2]]  # scipy is scalar-last, mlayer scalar-first
    # depth-first order: Motion wanted each parent to be the previous joint or its ancestor
    children: list[list[int]] = [[] for _ in range(J)]
    for j, p in enumerate(parents):
        if p >= 0:
            children[p].append(j)
    order, stack = [], [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(children[j]))
    new = {old: k for k, old in enumerate(order)}
    dfs_parents = [new[parents[j]] if parents[j] >= 0 else -1 for j in order]
    return mlayer.Motion.from_arrays([names[j] for j in order], dfs_parents,
                                     np.asarray(offsets)[order], trans + offsets[0],
                                     np.ascontiguousarray(q[:, order]), fps=fps)


def load_only(path) -> None:
    """The part both pay: reading poses and trans out of the archive."""
    with np.load(path) as z:
        z["poses"], z["trans"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / "clip_poses.npz"
        write_clip(path, args.frames)
        size = path.stat().st_size
        a, b = mlayer.read_amass(path), numpy_glue(path)
        assert a.joint_names == b.joint_names
        dots = np.abs(np.einsum("fjk,fjk->fj", a.rot, b.rot))
        err = float(np.abs(np.linalg.norm(a.positions() - b.positions(), axis=-1)).max())
        print(f"clip: {args.frames} frames x 52 joints (SMPL-H), {size / 1e6:.1f} MB; "
              f"the two motions agree: max |1 - |q_a . q_b|| {np.abs(1 - dots).max():.1e}, "
              f"max position difference {err:.1e} m")
        sides = (("read_amass", lambda: mlayer.read_amass(path)),
                 ("numpy glue (scipy)", lambda: numpy_glue(path)),
                 ("np.load alone", lambda: load_only(path)))
        times: dict[str, list[float]] = {label: [] for label, _ in sides}
        for _label, fn in sides:
            fn()  # warm up (imports, page cache)
        for _ in range(args.repeat):  # in turns, so that a slow spell falls on both
            for label, fn in sides:
                times[label].append(median_seconds(fn, 1))
        rows = [(label, float(np.median(times[label]))) for label, _ in sides]
        for label, s in rows:
            print(f"{label:20s} {s * 1e3:9.2f} ms  {args.frames / s / 1e6:7.2f} M frames/s")
        print(f"ratio glue / read_amass: {rows[1][1] / rows[0][1]:.2f}")


if __name__ == "__main__":
    main()
