"""`mlayer render IN.bvh [MORE.bvh ...] -o clip.gif|clip.mp4|strip.png`: stick figures side by
side, one camera.

The output's extension says what is written (mlayer.plotting.render.render): ``.gif`` an animated
GIF, ``.mp4`` an H.264 video (needs imageio-ffmpeg: ``pip install 'mlayer[video]'``), ``.png`` a
strip of --strip-frames frames (time left to right, one row per clip); other extensions are refused
before any work. Pillow (``mlayer[render]``) is needed for all three.
"""
from __future__ import annotations

import os

from ..errors import InvalidArgumentError
from ..io.bvh import read_bvh
from ..plotting.render import render
from ._command import Needs, Output, command

#: what `mlayer render -o` accepts
RENDER = Output((".gif", ".mp4", ".png"), "an animated GIF, an MP4 video or a PNG strip")


def _is_mp4(args) -> bool:
    return os.path.splitext(args.output)[1].lower() == ".mp4"


def _arguments(p) -> None:
    p.add_argument("inputs", nargs="+", metavar="IN.bvh")
    p.add_argument("-o", "--output", required=True, metavar="OUT.gif|OUT.mp4|OUT.png",
                   help="the render: .gif (animated GIF), .mp4 (video, needs imageio-ffmpeg) "
                        "or .png (a strip of frames)")
    p.add_argument("--labels", default=None, help="comma-separated panel captions "
                                                   "(default: the file names)")
    p.add_argument("--fps", type=float, default=30.0, help="frame rate (default 30)")
    p.add_argument("--seconds", type=float, default=None, help="render only the first seconds")
    p.add_argument("--size", default="320x380", help="panel size WxH in pixels")
    p.add_argument("--azimuth", type=float, default=35.0, help="camera azimuth, degrees")
    p.add_argument("--elevation", type=float, default=12.0, help="camera elevation, degrees")
    p.add_argument("--strip-frames", type=int, default=8, metavar="N",
                   help=".png: the frames of the strip, evenly spaced in time (default 8)")


@command("render", "render clips as stick figures side by side: an animated GIF, an MP4 video "
                   "or a PNG strip, by the output's extension",
         arguments=_arguments, reads_clips=True, inputs=("inputs",), outputs={"output": RENDER},
         requires=(Needs("PIL", feature="mlayer render"),
                   Needs("imageio_ffmpeg", when=_is_mp4, feature="mlayer render -o FILE.mp4")))
def cmd_render(args) -> int:
    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise InvalidArgumentError(f"--size expects WxH, got {args.size!r}") from None
    if args.strip_frames < 1:
        raise InvalidArgumentError(f"--strip-frames must be >= 1, got {args.strip_frames}")
    motions = [read_bvh(f) for f in args.inputs]
    labels = (args.labels.split(",") if args.labels
              else [os.path.splitext(os.path.basename(f))[0] for f in args.inputs])
    n = render(motions, args.output, labels=labels, fps=args.fps, panel_size=(w, h),
               azimuth=args.azimuth, elevation=args.elevation, max_seconds=args.seconds,
               strip_frames=args.strip_frames)
    what = "frames in the strip" if args.output.lower().endswith(".png") else \
        f"frames at {args.fps:g} fps"
    print(f"wrote {args.output} ({n} {what})")
    return 0
