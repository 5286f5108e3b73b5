"""`mlayer convert IN OUT`: between BVH, glTF 2.0 and AMASS, by the files' extensions.

    mlayer convert walk.bvh walk.glb [--up z] [--units cm] [--no-mesh]
    mlayer convert walk.glb walk.bvh [--animation N] [--fps F] [--up z] [--units cm]
    mlayer convert 01_01_poses.npz 01_01.bvh        (AMASS .npz: the SMPL / SMPL-H tree)
    mlayer convert clean.bvh clean.npz              (a motion on the SMPL / SMPL-H tree)

BVH to glTF (``.glb`` binary, ``.gltf`` JSON with the buffer embedded): ``--up`` and ``--units``
say what the BVH is in (default: detected, as for every command); the glTF is Y-up metres.
glTF to BVH: ``--animation`` picks the animation, ``--fps`` resamples it, and ``--up`` and
``--units`` choose the BVH's frame (default: the glTF's, Y-up metres). The output is written
atomically; bad input gives one line on stderr and exit status 1, and no file. AMASS files
(``.npz``) are read with ``mlayer.read_amass`` (Z-up metres, the mean body's offsets) and
written with ``mlayer.write_amass``, which takes only motions on the SMPL or SMPL-H tree.
"""
from __future__ import annotations

import argparse
import os

from ..io.amass import read_amass, write_amass
from ..io.bvh import read_bvh, write_bvh
from ..errors import InvalidArgumentError
from ..io.gltf import read_gltf, write_gltf
from ._command import Output, command

_GLTF = (".glb", ".gltf")
_KINDS = (".bvh",) + _GLTF + (".npz",)


_NAMES = {".bvh": "BVH", "gltf": "glTF", ".npz": "AMASS"}


def _family(ext: str) -> str:
    return "gltf" if ext in _GLTF else ext


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="IN", help="a .bvh, .glb, .gltf or AMASS .npz file")
    p.add_argument("output", metavar="OUT", help="a file of another kind: .bvh, .glb, .gltf "
                                                 "or .npz (AMASS)")
    p.add_argument("--animation", type=int, default=0, metavar="N",
                   help="glTF input: which animation (default 0, the first)")
    p.add_argument("--fps", type=float, default=None,
                   help="glTF input: resample to this frame rate (default: the key times)")
    p.add_argument("--no-mesh", action="store_true",
                   help="glTF output: leave out the bones mesh (the skeleton only)")


def _kind(path: str) -> str:
    return os.path.splitext(path)[1].lower()


@command("convert", "convert between BVH, glTF 2.0 (.glb, .gltf) and AMASS (.npz) by the "
         "files' extensions", arguments=_arguments, reads_clips=True, inputs=("input",),
         outputs={"output": Output(_KINDS, "a BVH, glTF or AMASS file (.bvh, .glb, .gltf, "
                                           ".npz)")})
def cmd_convert(args: argparse.Namespace) -> int:
    src, dst = _kind(args.input), _kind(args.output)
    if src not in _KINDS:
        raise InvalidArgumentError(f"{args.input}: mlayer convert reads .bvh, .glb, .gltf or "
                                   ".npz (AMASS) files")
    if _family(src) == _family(dst):
        raise InvalidArgumentError(f"{args.input} -> {args.output}: both are "
                                   f"{_NAMES[_family(src)]} files; convert changes the format: "
                                   "BVH (.bvh), glTF (.glb, .gltf) or AMASS (.npz)")
    up = None if args.up == "auto" else args.up
    if src == ".bvh":
        m = read_bvh(args.input)  # --up, --units, --strict, --trim reach it through main
    elif src == ".npz":
        m = read_amass(args.input)
    else:
        m = read_gltf(args.input, args.animation, fps=args.fps, up=up, units=args.units)
    if dst in _GLTF:
        write_gltf(m, args.output, mesh=not args.no_mesh)
    elif dst == ".npz":
        write_amass(m, args.output)
    else:
        write_bvh(m, args.output)
    print(f"mlayer convert: {args.input} -> {args.output}: {m.n_frames} frames at "
          f"{m.fps:.6g} fps, {m.n_joints} joints")
    return 0
