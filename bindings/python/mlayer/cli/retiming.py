"""`mlayer resample` and `mlayer timewarp`: retiming BVH files through the LGS.

    mlayer resample IN.bvh --fps 30 -o OUT.bvh [--report [VAR.png]] [--slerp]
    mlayer resample IN.bvh --frames 40 -o OUT.bvh
    mlayer timewarp IN.bvh --strength 1.5 [--frames N] -o OUT.bvh [--plot TIMEMAP.png]
    mlayer timewarp IN.bvh --map MAP.txt -o OUT.bvh

Both keep foot contacts by default (the feet follow the input's, mlayer.guards.contacts);
--no-contacts skips that. Bad input gives one line on stderr and exit status 1; every output
(BVH, figure) is computed first and written atomically, so a failed run leaves no output file.
"""
from __future__ import annotations

import os

import numpy as np

from .._files import atomic_output
from ..io.bvh import read_bvh, write_bvh
from ..errors import InvalidArgumentError
from ..pipeline.pipeline import stylize
from ..pipeline.retiming import (resample, slerp_resample, timewarp, timewarp_map, timewarp_speed)
from ..plotting.plot import plot_resample_variance, plot_timewarp
from ._command import BVH_OR_STDOUT, FIGURE, Needs, command, output_name, write_bvh_output
from .layers import _contact_option


def _int(text: str) -> int:
    import argparse
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    return v


def _write(args, motion, figure=None, figure_path: str | None = None) -> None:
    """Write the figure (if any) and the BVH (args.output: a file, or '-' for the standard
    output) so that either both appear or neither does."""
    if figure is None:
        write_bvh_output(args, motion, write=write_bvh)
        return
    assert figure_path is not None  # given with the figure
    with atomic_output(figure_path) as tmp:
        figure.savefig(tmp, dpi=110)
        write_bvh_output(args, motion, write=write_bvh)


# ---- mlayer resample -------------------------------------------------------------------------

def variance_summary(var: np.ndarray, fps: float) -> str:
    """The lines `mlayer resample --report` prints about the posterior variance per frame."""
    i_min, i_max = int(np.argmin(var)), int(np.argmax(var))
    med = float(np.median(var))
    # the frames within 5 % of the peak, as intervals, so a periodic pattern is visible
    near = np.flatnonzero(var >= var[i_max] - 0.05 * (var[i_max] - var[i_min]))
    runs = np.split(near, np.flatnonzero(np.diff(near) > 1) + 1)
    spans = [f"{r[0]}" if r[0] == r[-1] else f"{r[0]}-{r[-1]}" for r in runs[:6]]
    more = f" and {len(runs) - 6} more" if len(runs) > 6 else ""
    return "\n".join([
        f"posterior variance per output frame ({var.shape[0]} frames, relative to one "
        "observation's):",
        f"  min    {var[i_min]:.4g} at frame {i_min} ({i_min / fps:.3f} s)",
        f"  median {med:.4g}",
        f"  max    {var[i_max]:.4g} at frame {i_max} ({i_max / fps:.3f} s); max/min "
        f"{var[i_max] / var[i_min]:.3g}",
        f"  within 5 % of the max: frames {', '.join(spans)}{more}",
    ])


def _resample_arguments(p) -> None:
    p.add_argument("input", metavar="IN.bvh", help="BVH file to resample")
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--fps", type=float,
                   help="new frame rate, exactly: output frame k at k / FPS s after the first "
                        "frame, up to the last such time within the input")
    g.add_argument("--frames", type=_int, metavar="N",
                   help="new frame count (the first and last frames keep their times)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh",
                   help="output BVH file; - for the standard output")
    p.add_argument("--slerp", action="store_true",
                   help="the SLERP + linear interpolation baseline instead of the LGS")
    p.add_argument("--lam", type=float, default=None,
                   help="smoothness (default: automatic from the resampling factor)")
    p.add_argument("--style", type=float, metavar="ALPHA",
                   help="also scale the style (mlayer stylize ALPHA) before resampling")
    p.add_argument("--report", nargs="?", const=True, default=None, metavar="PLOT.png",
                   help="print a summary of the posterior variance per output frame, and plot "
                        "it to PLOT.png if given")
    p.add_argument("--allow-extreme", action="store_true",
                   help="accept resampling factors beyond 100x")
    _contact_option(p)


def _style(args):
    """The style argument of resample/timewarp: --style, without its own contact cleanup
    under --no-contacts."""
    if args.style is None or not args.no_contacts:
        return args.style
    return {"alpha": args.style, "keep_contacts": False}


@command("resample", "resample a BVH file to a new frame rate or frame count (LGS)",
         arguments=_resample_arguments, reads_clips=True, inputs=("input",),
         outputs={"output": BVH_OR_STDOUT, "report": FIGURE},
         requires=(Needs("matplotlib", when=lambda a: isinstance(a.report, str),
                         feature="--report PLOT"),))
def cmd_resample(args) -> int:
    if args.report is not None and args.slerp:
        raise InvalidArgumentError("--report needs the LGS: --slerp has no posterior variance")
    m = read_bvh(args.input)
    kw = dict(fps=args.fps, n_frames=args.frames, allow_extreme=args.allow_extreme)
    if args.slerp:
        if args.lam is not None:
            raise InvalidArgumentError("--lam does not apply to --slerp")
        src = m if args.style is None else stylize(m, args.style,
                                                    keep_contacts=not args.no_contacts)
        out, var = slerp_resample(src, **kw), None
    else:
        out, var = resample(m, lam=args.lam, return_var=True, style=_style(args),
                            keep_contacts=not args.no_contacts, **kw)
    method = ("SLERP" if args.slerp else "LGS") + \
        (f", style x{args.style:g}" if args.style is not None else "")
    fig = None
    if args.report is not None:
        assert var is not None  # --report is refused with --slerp above
        print(variance_summary(var, out.fps))
        if isinstance(args.report, str):
            N, n = m.n_frames, out.n_frames
            obs = np.arange(N) * (n - 1) / (N - 1)
            fig = plot_resample_variance(
                var, out.fps, obs, title=f"{os.path.basename(args.input)}: {N} frames at "
                                         f"{m.fps:.6g} fps -> {n} at {out.fps:.6g} fps (LGS)")
    _write(args, out, fig, args.report if isinstance(args.report, str) else None)
    print(f"{output_name(args.output)}: {out.n_frames} frames at {out.fps:.6g} fps ({method}; "
          f"from "
          f"{m.n_frames} frames at {m.fps:.6g} fps)")
    return 0


# ---- mlayer timewarp -------------------------------------------------------------------------

def _load_map(path: str) -> np.ndarray:
    try:
        t = np.loadtxt(path, dtype=np.float64, ndmin=1)
    except ValueError as e:
        raise InvalidArgumentError(f"{path}: not a list of numbers ({e})") from None
    if t.ndim != 1:
        raise InvalidArgumentError(f"{path}: expected one number per line, got shape {t.shape}")
    return t


def _timewarp_arguments(p) -> None:
    p.add_argument("input", metavar="IN.bvh", help="BVH file to time-warp")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh",
                   help="output BVH file; - for the standard output")
    p.add_argument("--strength", type=float, default=1.0,
                   help="0 uniform, 1 dwell time follows the motion magnitude, more exaggerates "
                        "(default 1; at most 10)")
    p.add_argument("--frames", type=_int, metavar="N",
                   help="target length in frames (default: the input's)")
    p.add_argument("--map", metavar="MAP.txt",
                   help="an explicit time map instead: one output frame position per input "
                        "frame, strictly increasing from 0 to N-1")
    p.add_argument("--smooth", type=float, default=0.25, metavar="SECONDS",
                   help="easing length of the automatic map (default 0.25 s)")
    p.add_argument("--style", type=float, metavar="ALPHA",
                   help="also scale the style (mlayer stylize ALPHA) in the same run")
    p.add_argument("--plot", metavar="TIMEMAP.png",
                   help="plot the time map with the motion speed under it (paper Figure 9)")
    p.add_argument("--allow-extreme", action="store_true",
                   help="accept local rate changes beyond 100x")
    _contact_option(p)


@command("timewarp", "slow down large motion and speed up calm motion (automatic time warp)",
         arguments=_timewarp_arguments, reads_clips=True, inputs=("input", "map"),
         outputs={"output": BVH_OR_STDOUT, "plot": FIGURE},
         requires=(Needs("matplotlib", when="plot"),))
def cmd_timewarp(args) -> int:
    m = read_bvh(args.input)
    if args.map is not None:
        t_user = _load_map(args.map)
        out, t = timewarp(m, time_map=t_user, n_frames=args.frames, return_map=True,
                          allow_extreme=args.allow_extreme, style=_style(args),
                          keep_contacts=not args.no_contacts)
        how = f"time map from {args.map}"
    else:
        t = timewarp_map(m, strength=args.strength, n_frames=args.frames,
                         smooth_seconds=args.smooth, allow_extreme=args.allow_extreme)
        out = timewarp(m, time_map=t, allow_extreme=args.allow_extreme, style=_style(args),
                       keep_contacts=not args.no_contacts)
        how = f"strength {args.strength:g}"
    if args.style is not None:
        how += f", style x{args.style:g}"
    fig = None
    if args.plot:
        fig = plot_timewarp(m, out, t, speed=timewarp_speed(m),
                            title=f"{os.path.basename(args.input)}: time warp, {how}; "
                                  f"{m.n_frames} -> {out.n_frames} frames at {out.fps:.6g} fps")
    _write(args, out, fig, args.plot)
    rate = np.diff(t)
    print(f"{output_name(args.output)}: {out.n_frames} frames at {out.fps:.6g} fps ({how}); "
          f"local rate "
          f"{rate.min():.3g} to {rate.max():.3g} output frames per input frame, slowest at "
          f"input frame {int(np.argmax(rate)) + 1} ({(np.argmax(rate) + 1) * m.frame_time:.2f} s)")
    return 0
