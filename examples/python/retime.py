"""Retime a clip (paper 1, section 5.3): a new frame rate, sparse keys, slow motion.

    python examples/python/retime.py [CLIP.bvh] [--out DIR]
"""
from __future__ import annotations

import numpy as np

import mlayer
from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    m = mlayer.read_bvh(args.input)

    # 1. Exactly 30 fps: output frame k lies at k / 30 s; the variance says where the LGS is
    #    least sure (between the input's frames it is smaller than at the ends).
    m30, var = mlayer.resample(m, fps=30, return_var=True)
    mlayer.write_bvh(m30, args.out / "walk_30fps.bvh")
    print(f"{m.n_frames} frames at {m.fps:g} fps -> {m30.n_frames} at {m30.fps:g} fps, "
          f"posterior variance {var.min():.3g} .. {var.max():.3g} (x sigma^2)")

    # 2. Keys every 10th frame back to the full frame count: the LGS against SLERP.
    keys = m[::10]
    n = (keys.n_frames - 1) * 10 + 1
    lgs, slerp = mlayer.resample(keys, n_frames=n), mlayer.slerp_resample(keys, n_frames=n)
    h = mlayer.metrics.body_height(m)
    for label, r in (("LGS", lgs), ("SLERP", slerp)):
        err = mlayer.metrics.mpjpe(r, m[:n]) / h
        print(f"keys every 10th frame -> {n} frames by {label}: MPJPE {100 * err:.2f}% of "
              "body height")
    mlayer.write_bvh(lgs, args.out / "from_keys.bvh")

    # 3. Slow motion where the motion is large (the automatic time warp, paper Figure 9).
    slow, tmap = mlayer.timewarp(m, strength=1.5, return_map=True)
    mlayer.write_bvh(slow, args.out / "timewarped.bvh")
    step = np.diff(tmap)
    print(f"time warp: input frames per output frame {step.min():.2f} .. {step.max():.2f}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
