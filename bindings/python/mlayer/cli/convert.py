"""`mlayer convert IN OUT`: BVH to glTF 2.0 and back, by the files' extensions.

    mlayer convert walk.bvh walk.glb [--up z] [--units cm] [--no-mesh]
    mlayer convert walk.glb walk.bvh [--animation N] [--fps F] [--up z] [--units cm]

BVH to glTF (``.glb`` binary, ``.gltf`` JSON with the buffer embedded): ``--up`` and ``--units``
say what the BVH is in (default: detected, as for every command); the glTF is Y-up metres.
glTF to BVH: ``--animation`` picks the animation, ``--fps`` resamples it, and ``--up`` and
``--units`` choose the BVH's frame (default: the glTF's, Y-up metres). The output is written
atomically; bad input gives one line on stderr and exit status 1, and no file.
"""
from __future__ import annotations

import argparse
import os

from ..bvh import read_bvh, write_bvh
from ..errors import InvalidArgumentError
from ..gltf import read_gltf, write_gltf
from ._command import Output, command

_GLTF = (".glb", ".gltf")


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="IN", help="a .bvh, .glb or .gltf file")
    p.add_argument("output", metavar="OUT", help="a .glb or .gltf file for a BVH input, a "
                                                 ".bvh file for a glTF input")
    p.add_argument("--animation", type=int, default=0, metavar="N",
                   help="glTF input: which animation (default 0, the first)")
    p.add_argument("--fps", type=float, default=None,
                   help="glTF input: resample to this frame rate (default: the key times)")
    p.add_argument("--no-mesh", action="store_true",
                   help="glTF output: leave out the bones mesh (the skeleton only)")


def _kind(path: str) -> str:
    return os.path.splitext(path)[1].lower()


@command("convert", "convert between BVH and glTF 2.0 (.glb, .gltf) by the files' extensions",
         arguments=_arguments, reads_clips=True, inputs=("input",),
         outputs={"output": Output((".bvh",) + _GLTF, "a BVH or glTF file (.bvh, .glb, "
                                                      ".gltf)")})
def cmd_convert(args: argparse.Namespace) -> int:
    src, dst = _kind(args.input), _kind(args.output)
    if src not in (".bvh",) + _GLTF:
        raise InvalidArgumentError(f"{args.input}: mlayer convert reads .bvh, .glb or .gltf "
                                   "files")
    if (src == ".bvh") == (dst == ".bvh"):
        raise InvalidArgumentError(f"mlayer convert: {args.input} -> {args.output}: converts "
                                   "between BVH and glTF; one side must be .bvh, the other "
                                   ".glb or .gltf")
    up = None if args.up == "auto" else args.up
    if src == ".bvh":
        m = read_bvh(args.input)  # --up, --units, --strict, --trim reach it through main
        write_gltf(m, args.output, mesh=not args.no_mesh)
    else:
        m = read_gltf(args.input, args.animation, fps=args.fps, up=up, units=args.units)
        write_bvh(m, args.output)
    print(f"mlayer convert: {args.input} -> {args.output}: {m.n_frames} frames at "
          f"{m.fps:.6g} fps, {m.n_joints} joints")
    return 0
