"""`mlayer retarget`: a clip put onto another humanoid rig (mlayer.retarget).

    mlayer retarget IN --to TARGET -o OUT [--mapping SRC=TGT,...] [--no-feet]

IN and TARGET are BVH (.bvh), glTF (.glb, .gltf) or AMASS (.npz) files; the target's skeleton
(its OFFSETs, the rest pose) is taken, its frames are not used. OUT is a BVH or glTF file. The
joints are matched by their humanoid roles, found from the names and the tree; --mapping pairs
source joints with target joints by name where those are wrong or missing. The source's foot
contacts are planted on the target (--no-feet: not). Bad input (a rig without hips and two
legs, an unknown joint in --mapping) gives one line on stderr naming the joint and exit status 1;
the output is written atomically, so a failed run leaves none.
"""
from __future__ import annotations

import argparse
import os

from ..errors import InvalidArgumentError
from ..io.bvh import write_bvh
from ..io.gltf import write_gltf
from ..pipeline.retarget import _target_of, parse_map, retarget
from ._command import Output, command, output_name

_GLTF = (".glb", ".gltf")
_READS = (".bvh", ".npz") + _GLTF


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="IN", help="the clip: a .bvh, .glb, .gltf or AMASS .npz file")
    p.add_argument("--to", required=True, metavar="TARGET",
                   help="the target rig: a .bvh, .glb, .gltf or .npz file whose skeleton is "
                        "taken")
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="output file: .bvh, .glb or .gltf")
    p.add_argument("--mapping", default=None, metavar="SRC=TGT,...",
                   help="source joint = target joint pairs overriding the roles found by name "
                        "and tree (the target joint takes the source joint's role)")
    p.add_argument("--no-feet", action="store_true",
                   help="leave the feet as the bones put them (default: the source's contacts "
                        "planted on the target, above the scaled floor)")


def _read(path: str):
    ext = os.path.splitext(path)[1].lower()
    if ext not in _READS:
        raise InvalidArgumentError(f"{path}: mlayer retarget reads .bvh, .glb, .gltf or .npz "
                                   "files")
    return _target_of(path)[1]


@command("retarget", "put a clip onto another humanoid rig (roles matched by name and tree, "
         "rest poses removed, hips scaled by leg length)", arguments=_arguments,
         reads_clips=True, inputs=("input", "to"),
         outputs={"output": Output((".bvh",) + _GLTF, "a BVH or glTF file (.bvh, .glb, .gltf)")})
def cmd_retarget(args: argparse.Namespace) -> int:
    """Run `mlayer retarget` (see the module docstring); returns the exit status."""
    mapping = "auto" if args.mapping is None else parse_map(args.mapping)
    m = _read(args.input)
    target = _read(args.to)
    out = retarget(m, target, mapping=mapping, feet=not args.no_feet)
    if os.path.splitext(args.output)[1].lower() in _GLTF:
        write_gltf(out, args.output)
    else:
        write_bvh(out, args.output)
    print(f"{output_name(args.output)}: {out.n_frames} frames retargeted from {m.n_joints} to "
          f"{out.n_joints} joints")
    return 0
