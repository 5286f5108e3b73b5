"""`mlayer render IN.bvh [MORE.bvh ...] -o clip.gif`: stick figures side by side, one camera."""
from __future__ import annotations

import os
import sys

from ..bvh import read_bvh
from ._command import GIF, command


def progress_bar(label: str, stream=None):
    """A callable(done, total) drawing a one-line progress bar on stderr (when it is a
    terminal; otherwise it prints the label once at the end)."""
    stream = stream or sys.stderr
    tty = stream.isatty()

    def update(done: int, total: int) -> None:
        if tty:
            width = 30
            full = width * done // max(total, 1)
            stream.write(f"\r{label} [{'#' * full}{'.' * (width - full)}] {done}/{total}")
            if done >= total:
                stream.write("\n")
            stream.flush()
        elif done >= total:
            stream.write(f"{label}: {total}/{total}\n")
    return update


def _arguments(p) -> None:
    p.add_argument("inputs", nargs="+", metavar="IN.bvh")
    p.add_argument("-o", "--output", required=True, metavar="OUT.gif")
    p.add_argument("--labels", default=None, help="comma-separated panel captions "
                                                   "(default: the file names)")
    p.add_argument("--fps", type=float, default=30.0, help="GIF frame rate (default 30)")
    p.add_argument("--seconds", type=float, default=None, help="render only the first seconds")
    p.add_argument("--size", default="320x380", help="panel size WxH in pixels")
    p.add_argument("--azimuth", type=float, default=35.0, help="camera azimuth, degrees")
    p.add_argument("--elevation", type=float, default=12.0, help="camera elevation, degrees")


@command("render", "render clips as stick figures side by side into an animated GIF",
         arguments=_arguments, reads_clips=True, inputs=("inputs",), outputs={"output": GIF})
def cmd_render(args) -> int:
    from ..errors import InvalidArgumentError
    from ..render import render_gif
    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise InvalidArgumentError(f"--size expects WxH, got {args.size!r}") from None
    motions = [read_bvh(f) for f in args.inputs]
    labels = (args.labels.split(",") if args.labels
              else [os.path.splitext(os.path.basename(f))[0] for f in args.inputs])
    n = render_gif(motions, args.output, labels=labels, fps=args.fps, panel_size=(w, h),
                   azimuth=args.azimuth, elevation=args.elevation, max_seconds=args.seconds,
                   progress=progress_bar("rendering"))
    print(f"wrote {args.output} ({n} frames at {args.fps:g} fps)")
    return 0
