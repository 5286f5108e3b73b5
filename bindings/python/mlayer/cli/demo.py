"""`mlayer demo [-o DIR]`: the main job end to end on the bundled CMU clip (or --clip FILE).

Decomposes the clip into layers, writes the denoised and the exaggerated (alpha = 2) clips as
BVH (feet pinned during the contacts of the original), the layers as a figure and as arrays, a
GIF of original, denoised and exaggerated side by
side, and prints what was chosen and measured.
"""
from __future__ import annotations

import os
import sys
import time

from .. import data
from ..guards.metrics import body_height, foot_sliding, jitter
from ..io.bvh import read_bvh, write_bvh
from ..pipeline.pipeline import Synthesis
from ..plotting.plot import layer_choice, plot_layers
from ..plotting.render import render_gif
from ._command import FOLDER, Needs, command


def _arguments(p) -> None:
    p.add_argument("-o", "--output-dir", default="mlayer-demo", metavar="DIR",
                   help="folder for the results (default ./mlayer-demo)")
    p.add_argument("--clip", default=None, metavar="FILE.bvh",
                   help="run on this clip instead of the bundled CMU 131_01 walk")
    p.add_argument("--alpha", type=float, default=2.0, help="exaggeration (default 2)")
    p.add_argument("--no-gif", action="store_true", help="skip the GIF (the slowest step)")


@command("demo", "decompose, denoise, exaggerate and render the bundled clip into a folder",
         arguments=_arguments, reads_clips=True, inputs=("clip",),
         outputs={"output_dir": FOLDER},
         requires=(Needs("matplotlib", feature="mlayer demo (its layer figure)"),
                   Needs("PIL", when=lambda a: not a.no_gif,
                         feature="mlayer demo (its GIF; --no-gif for none)")))
def cmd_demo(args) -> int:

    clip = args.clip or data.sample_path()
    out = lambda name: os.path.join(args.output_dir, name)  # noqa: E731
    m = read_bvh(clip)
    print(f"clip      {clip}\n          {m.n_frames} frames at {m.fps:g} fps, "
          f"{m.n_joints} joints")

    t0 = time.perf_counter()
    s = Synthesis(m)
    layers = s.layers
    t_dec = time.perf_counter() - t0
    den, _ = s.run(1.0)
    sty_raw = layers.synthesize(args.alpha)
    sty, report = s.run(args.alpha)
    print(f"layers    decomposed in {1e3 * t_dec:.1f} ms (gamma heuristic + GCV per joint)")
    os.makedirs(args.output_dir, exist_ok=True)  # after the decomposition: it may refuse a clip
    write_bvh(den, out("denoised.bvh"))
    write_bvh(sty, out(f"stylized_alpha{args.alpha:g}.bvh"))
    layers.save_npz(out("layers.npz"))
    joint, axis = layer_choice(m, layers)
    plot_layers(m, layers, out("layers.png"), joint=joint, root_axis=axis,
                title=f"{os.path.basename(clip)}: layers")

    h = body_height(m)
    names, contacts = s.contacts()
    print(f"contacts  {', '.join(names)}: {int(contacts.sum())} contact frames, pinned "
          f"after synthesis")
    print(f"guards    alpha {args.alpha:g}: {len(report.limited)} joints softly limited, feet "
          f"raised to the floor on {report.floor_frames} frames")
    print(f"{'motion':28s} {'jitter (heights/s^3)':>21s} {'foot sliding (heights/s)':>25s}")
    rows = (("original", m), ("denoised", den), (f"alpha = {args.alpha:g}, no guards", sty_raw),
            (f"alpha = {args.alpha:g}", sty))
    for name, mm in rows:
        jit = jitter(mm, fps=mm.fps) / h if mm.n_frames >= 4 else float("nan")  # n/a
        print(f"{name:28s} {jit:21.3g} "
              f"{foot_sliding(mm, contacts, names) / h:25.3g}")
    print(f"figure    layers.png shows root {'XYZ'[axis]} and {joint}")
    if not args.no_gif:
        sys.stdout.flush()  # the progress bar (on a terminal) goes to stderr
        render_gif([m, den, sty], out("compare.gif"),
                   labels=["original", "denoised", f"alpha = {args.alpha:g}"])
    print(f"wrote     {', '.join(sorted(os.listdir(args.output_dir)))} in {args.output_dir}/")
    return 0
