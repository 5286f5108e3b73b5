"""`mlayer rootmotion`: a BVH clip split into an in-place clip and a root track
(mlayer.extract_root_motion).

    mlayer rootmotion IN.bvh -o OUT.bvh --track TRACK.csv [--mode ground|position]
                      [--smooth SECONDS]

OUT.bvh is the motion relative to the track (the body stays near the origin, facing the ground
axis after up); TRACK.csv has one row per frame: frame, time, x, y, z (the track's position on
the ground plane) and heading (radians about the up axis). Both are computed first and written
atomically, both or neither; bad input gives one line on stderr and exit status 1.
"""
from __future__ import annotations

import argparse

import numpy as np

from .._files import atomic_output
from ..io.bvh import read_bvh, write_bvh
from ..model.root_motion import MODES, extract_root_motion
from ._command import BVH_OR_STDOUT, Output, command, output_name, write_bvh_output

CSV = Output((".csv",), "a CSV file")


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="IN.bvh", help="BVH file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh",
                   help="the in-place BVH file; - for the standard output")
    p.add_argument("--track", required=True, metavar="TRACK.csv",
                   help="the root track: frame,time,x,y,z,heading per frame")
    p.add_argument("--mode", default="ground", choices=sorted(MODES),
                   help="ground (default): position and heading; position: position only")
    p.add_argument("--smooth", type=float, default=1.0, metavar="SECONDS",
                   help="smoothing of the track, the period whose amplitude it halves "
                        "(default 1.0; 0: none)")


@command("rootmotion", "split a BVH clip into an in-place clip and a root track (CSV)",
         arguments=_arguments, reads_clips=True, inputs=("input",),
         outputs={"output": BVH_OR_STDOUT, "track": CSV})
def cmd_rootmotion(args: argparse.Namespace) -> int:
    """Run `mlayer rootmotion` (see the module docstring); returns the exit status."""
    m = read_bvh(args.input)
    in_place, track = extract_root_motion(m, mode=args.mode, smooth=args.smooth)
    with atomic_output(args.track) as tmp:
        track.to_csv(tmp)
        write_bvh_output(args, in_place, write=write_bvh)
    step = np.linalg.norm(np.diff(track.positions, axis=0), axis=1)
    turn = float(np.degrees(track.heading[-1] - track.heading[0]))
    print(f"{output_name(args.output)}: {in_place.n_frames} frames in place; {args.track}: "
          f"track of length {step.sum():.4g} ({m.units or 'units'}), heading turned "
          f"{turn:+.0f} degrees ({args.mode}, smooth {args.smooth:g} s)")
    return 0
