"""`mlayer mirror`: a BVH clip mirrored left/right (mlayer.mirror).

    mlayer mirror IN.bvh -o OUT.bvh [--plane auto|x|y|z] [--pairs A=B,C=D] [--keep-skeleton]

The joint pairs are found by name unless --pairs names them (those override the pairs found
for the joints they name); the plane is normal to the body's left-right axis unless --plane
gives an axis. Bad input (an unknown joint in --pairs, a pair naming one joint twice, a plane
other than auto, x, y, z) gives one line on stderr and exit status 1; the output is written
atomically, so a failed run leaves none.
"""
from __future__ import annotations

import argparse

from ..io.bvh import read_bvh, write_bvh
from ..model.mirroring import mirror, mirror_pairs, mirror_plane, parse_pairs
from ._command import BVH_OR_STDOUT, command, output_name, write_bvh_output


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="IN.bvh", help="BVH file to mirror")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh",
                   help="output BVH file; - for the standard output")
    p.add_argument("--plane", default="auto", metavar="auto|x|y|z",
                   help="the axis normal to the mirror plane (default auto: the body's "
                        "left-right axis, from the paired joints' rest positions)")
    p.add_argument("--pairs", default=None, metavar="A=B,...",
                   help="left/right joint pairs, overriding those found by name for the "
                        "joints they name")
    p.add_argument("--keep-skeleton", action="store_true",
                   help="keep the input's OFFSETs and mirror only the motion (default: the "
                        "exact mirror image, OFFSETs mirrored and swapped too)")


@command("mirror", "mirror a BVH clip left/right across the body's sagittal plane",
         arguments=_arguments, reads_clips=True, inputs=("input",),
         outputs={"output": BVH_OR_STDOUT})
def cmd_mirror(args: argparse.Namespace) -> int:
    """Run `mlayer mirror` (see the module docstring); returns the exit status."""
    pairs = "auto" if args.pairs is None else parse_pairs(args.pairs)
    m = read_bvh(args.input)
    out = mirror(m, plane=args.plane, pairs=pairs, keep_skeleton=args.keep_skeleton)
    found = mirror_pairs(m, pairs)
    plane = mirror_plane(m, pairs) if args.plane.lower() == "auto" else args.plane.lower()
    write_bvh_output(args, out, write=write_bvh)
    shown = ", ".join(f"{a}/{b}" for a, b in found[:4]) + (" ..." if len(found) > 4 else "")
    print(f"{output_name(args.output)}: {out.n_frames} frames mirrored across the {plane} "
          f"plane, {len(found)} joint pairs swapped ({shown})"
          + ("; skeleton kept" if args.keep_skeleton else ""))
    return 0
