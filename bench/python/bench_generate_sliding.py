"""Foot sliding of generated motion (paper 2) against its training clip, measured with the
definitions of bench_plausibility.py, not mlayer's (issue 38, item 8): its own forward kinematics,
the foot points and the floor found on the training clip, and each motion's contact frames by
the bench's height-and-speed rule (contact_frames); sliding is the mean horizontal speed of the
foot points over those frames, in body heights per second. The target: guarded generated
motion at most 1.5x the training clip's.

    python bench/python/bench_generate_sliding.py [--frames 300] [--extra CLIP.bvh ...]

Run from the repository root, with ../shared/data/mocap beside it (the walks and the dog of
bindings/python/tests/manifold/test_generate_guards.py, trained as that test does); --extra
adds clips of your own (the first 1800 frames, a 12 x 12 map, 8 x 8 centres, k from 2 to 8).
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import bench_plausibility as bp
import mlayer

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "bindings" / "python" / "tests" / "manifold"))


def sliding(m, rig) -> float:  # type: ignore[no-untyped-def]
    """The bench's sliding of motion m with the training clip's rig (feet, floor, height)."""
    pts, _ = bp.all_points(m)
    p = pts[:, rig.feet]
    c = bp.contact_frames(p, rig.up, rig.floor, rig.H, float(m.fps))
    return bp.mean_contact_speed(p, c, rig.up, float(m.fps)) / rig.H


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--extra", nargs="*", default=[])
    a = ap.parse_args()
    from test_generate_guards import STARTS, WALKS, _fit
    mocap = HERE.parents[2] / "shared" / "data" / "mocap"
    extra = dict(som=(12, 12), lattice=(8, 8), ks=range(2, 9))
    walks = [(mocap / c, f, o) for c, f, o in WALKS]
    walks += [(pathlib.Path(c).resolve(), 1800, extra) for c in a.extra]
    worst = 0.0
    for path, frames, opts in walks:
        clip = path.name
        try:
            m, model = _fit(path.parent, clip, frames, opts)
        except mlayer.Error as e:  # a clip too short for the map, ...: listed, not fatal
            print(f"{clip}: not measured: {e}")
            continue
        pts, _ = bp.all_points(m)
        rig = bp.make_rig(m, pts)
        train = sliding(m, rig)
        if not train > 0.0:
            print(f"{clip}: not measured: the bench's rule finds no contact frame in it")
            continue
        for sf, seed in STARTS:
            raw = model.generate(a.frames, start_frame=sf, seed=seed, guards=False)
            out = model.generate(a.frames, start_frame=sf, seed=seed)
            r_raw, r_out = sliding(raw, rig) / train, sliding(out, rig) / train
            worst = max(worst, r_out)
            print(f"{clip} start {sf} seed {seed}: training clip {train:.3f} H/s; generated "
                  f"raw {r_raw:.2f}x, guarded {r_out:.2f}x the training clip's")
    print(f"worst guarded: {worst:.2f}x (target 1.5)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
