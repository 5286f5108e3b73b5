"""Layer commands: `mlayer denoise`, `mlayer stylize`, `mlayer layers`.

    mlayer denoise IN.bvh -o OUT.bvh [--lam-c L --sigma-c S] [--gamma G]
    mlayer stylize IN.bvh --alpha 2 [--joint 'Left*=3' ...] -o OUT.bvh

denoise and stylize pin the feet during the contacts detected on the input
(mlayer.guards.contacts);
--no-contacts skips that.
    mlayer layers IN.bvh --plot layers.png [--npz layers.npz] [--joint NAME]

Each prints what it chose (the smoothing found by the gamma heuristic and by GCV) and the
jitter before and after, and writes its outputs atomically.
"""
from __future__ import annotations

import argparse
import math
from collections.abc import Iterable
import sys

import numpy as np

from ..errors import InvalidArgumentError
from ..io.bvh import read_bvh
from ..layers.alpha_curve import AlphaCurve
from ..layers.layers import decompose
from ..pipeline.pipeline import Clip
from ..plotting.plot import layer_choice, plot_layers
from ._command import BVH_OR_STDOUT, FIGURE, NPZ, Needs, command, output_name, write_bvh_output


def _contact_option(p) -> None:
    p.add_argument("--no-keep-contacts", "--no-contacts", dest="no_contacts", action="store_true",
                   help="do not pin the feet during the contacts detected on the input")
    p.add_argument("--no-limits", action="store_true",
                   help="do not apply joint limits (applied by default when some alpha > 1)")
    p.add_argument("--no-floor", action="store_true",
                   help="let the feet go below the floor of the input's contacts")


def _layer_options(p) -> None:
    p.add_argument("--gamma", type=float, default=math.pi / 2,
                   help="largest displacement angle of the base layer, radians, in [pi/2, pi) "
                        "(default pi/2)")
    p.add_argument("--lam-c", type=float, default=None,
                   help="control-layer lambda (default: chosen per joint by GCV)")
    p.add_argument("--sigma-c", type=float, default=None,
                   help="control-layer sigma (default: chosen per joint by GCV)")
    p.add_argument("--no-robust", action="store_true",
                   help="do not look for outlier frames (glitches, flips) to down-weight")


def frame_ranges(frames: Iterable[int]) -> str:
    """[0, 1, 2, 3, 4, 9] -> '0-4, 9'."""
    out: list[list[int]] = []
    frames = [int(f) for f in frames]
    for f in frames:
        if out and f == out[-1][1] + 1:
            out[-1][1] = f
        else:
            out.append([f, f])
    return ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in out)


def _outlier_note(layers) -> None:
    """One line on stderr when the robust decomposition down-weighted frames."""
    bad = layers.outlier_frames
    if bad.size:
        shown = frame_ranges(bad[:200]) + (", ..." if bad.size > 200 else "")
        print(f"mlayer: {bad.size} outlier frame{'s' if bad.size != 1 else ''} down-weighted "
              f"(frames {shown})", file=sys.stderr)


def _synthesis_options(args) -> dict:
    """The options of mlayer.pipeline.pipeline.Clip.synthesis that the command line gives."""
    return dict(limits=None if getattr(args, "no_limits", False) else "auto",
                floor=None if getattr(args, "no_floor", False) else "auto",
                keep_contacts=not getattr(args, "no_contacts", False),
                gamma=args.gamma, lam_c=args.lam_c, sigma_c=args.sigma_c,
                robust=not args.no_robust)


def _decompose(args, motion):
    return decompose(motion, gamma=args.gamma, lam_c=args.lam_c, sigma_c=args.sigma_c,
                     robust=not args.no_robust)


def _guard_summary(report) -> None:
    """One line per guard that did something (mlayer.pipeline.pipeline.GuardReport)."""
    if report.limited:
        worst = sorted(report.limited.items(), key=lambda kv: -kv[1])[:4]
        print(f"  joint limits: {len(report.limited)} joints limited ("
              + ", ".join(f"{n} {k} frames" for n, k in worst)
              + (", ..." if len(report.limited) > 4 else "") + ")")
    if report.contact_frames:
        print(f"  contacts: feet pinned on {report.contact_frames} frames")
    if report.floor_frames:
        print(f"  floor at {report.floor_height:.4g}: feet raised on {report.floor_frames} frames")


def parse_joint_alphas(items: Iterable[str] | None) -> dict[str, float | AlphaCurve]:
    """['Left*=3', 'Head=0.5', 'Right*=0:1,2:3'] -> {'Left*': 3.0, 'Head': 0.5,
    'Right*': AlphaCurve(...)} (a value with ':' is a curve of TIME:ALPHA keys)."""
    out: dict[str, float | AlphaCurve] = {}
    for it in items or ():
        name, sep, value = it.rpartition("=")
        if not sep or not name:
            raise InvalidArgumentError(f"--joint expects PATTERN=ALPHA or "
                                       f"PATTERN=TIME:ALPHA,..., got {it!r}")
        if ":" in value:
            try:
                out[name] = AlphaCurve.parse(value)
            except InvalidArgumentError as e:
                raise InvalidArgumentError(f"--joint {it!r}: {e}") from None
            continue
        try:
            out[name] = float(value)
        except ValueError:
            raise InvalidArgumentError(f"--joint {it!r}: {value!r} is not a number") from None
    return out


def parse_alpha_keys(text: str) -> AlphaCurve:
    """--alpha-keys "0:1,2.5:3,4:1" -> its AlphaCurve (a one-line error naming the key)."""
    try:
        return AlphaCurve.parse(text)
    except InvalidArgumentError as e:
        raise InvalidArgumentError(f"--alpha-keys {text!r}: {e}") from None


def _jitter_line(clip, after) -> str:
    """The jitter before and after in body heights / s^3; 'n/a' for clips under 4 frames, no
    percentage for a static clip (jitter 0)."""
    if clip.motion.n_frames < 4 or after.n_frames < 4:
        return "  jitter n/a (fewer than 4 frames)"
    jb, ja = clip.jitter(), clip.jitter(after)
    change = f" ({100 * (ja / jb - 1):+.1f}%)" if jb > 0 else " (the input does not move)"
    return f"  jitter {jb:.3g} -> {ja:.3g} body heights / s^3{change}"


def _summary(name, clip, after, layers=None) -> None:
    before = clip.motion
    jitter_line = _jitter_line(clip, after)
    print(f"{name}: {before.n_frames} frames at {before.fps:g} fps, {before.n_joints} joints")
    if layers is not None:
        lam_c = np.asarray(layers.lam_c)
        print(f"  control smoothing (GCV per joint unless given): lam_c median "
              f"{np.median(lam_c):.3g}, range [{lam_c.min():.3g}, {lam_c.max():.3g}]")
        s_b = np.asarray(layers.base_s)
        print(f"  base smoothing (gamma heuristic per joint): s median {np.median(s_b):.3g}, "
              f"range [{s_b.min():.3g}, {s_b.max():.3g}]")
    print(jitter_line)


def _arguments_denoise(p) -> None:
    p.add_argument("input", metavar="IN.bvh")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh",
                   help="the output BVH file; - for the standard output")
    _layer_options(p)
    _contact_option(p)


@command("denoise", "smooth a clip: the base and controllable layers, without the residual",
         arguments=_arguments_denoise, reads_clips=True, inputs=("input",),
         outputs={"output": BVH_OR_STDOUT})
def cmd_denoise(args) -> int:
    clip = Clip.read(args.input)
    s = clip.synthesis(**_synthesis_options(args))
    out, report = s.run(1.0)
    _summary(args.input, clip, out, s.layers)
    write_bvh_output(args, out)
    _guard_summary(report)
    print(f"  wrote {output_name(args.output)}")
    _outlier_note(s.layers)
    return 0


class _StoreGiven(argparse.Action):
    """Store the value and note that it was given (``args.<dest>_given``)."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        setattr(namespace, self.dest, values)
        setattr(namespace, f"{self.dest}_given", True)


def _arguments_stylize(p) -> None:
    p.add_argument("input", metavar="IN.bvh")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh",
                   help="the output BVH file; - for the standard output")
    p.add_argument("--alpha", type=float, default=2.0, action=_StoreGiven,
                   help="scale of the controllable layer for every joint (default 2: "
                        "exaggerate; 0 gives the base layer, 1 the denoised clip)")
    p.add_argument("--alpha-keys", metavar="T:A,T:A,...", default=None,
                   help="alpha over time instead of --alpha: keys of time in seconds from the "
                        "first frame and alpha, eased smoothly from key to key (quintic "
                        "smoothstep), e.g. '0:1,2.5:3,4:1'; the guards run as for the "
                        "largest |alpha|")
    p.add_argument("--joint", action="append", metavar="PATTERN=ALPHA",
                   help="alpha for the joints matching a name or glob, e.g. 'Left*=3', or "
                        "their keys over time, e.g. 'Left*=0:1,2:3' (repeatable; later "
                        "patterns win)")
    _layer_options(p)
    _contact_option(p)


@command("stylize", "exaggerate or flatten a clip's style by scaling its controllable layer",
         arguments=_arguments_stylize, reads_clips=True, inputs=("input",),
         outputs={"output": BVH_OR_STDOUT})
def cmd_stylize(args) -> int:
    if getattr(args, "alpha_given", False) and args.alpha_keys is not None:
        raise InvalidArgumentError("--alpha and --alpha-keys: give one of them")
    alpha: float | AlphaCurve
    if args.alpha_keys is not None:
        alpha = parse_alpha_keys(args.alpha_keys)
    else:
        if not math.isfinite(args.alpha):
            raise InvalidArgumentError(f"--alpha must be finite, got {args.alpha}")
        alpha = float(args.alpha)
    joints = parse_joint_alphas(args.joint)
    clip = Clip.read(args.input)
    s = clip.synthesis(**_synthesis_options(args))
    out, report = s.run(alpha, joints or None)
    _summary(args.input, clip, out, s.layers)
    write_bvh_output(args, out)
    _guard_summary(report)

    def text(a: float | AlphaCurve) -> str:
        return f"{a:g}" if isinstance(a, float) else f"keys {a} (peak {a.peak:g})"
    print(f"  alpha {text(alpha)}" + "".join(f", {k}={text(v)}" for k, v in joints.items()))
    print(f"  wrote {output_name(args.output)}")
    _outlier_note(s.layers)
    return 0


def _arguments_layers(p) -> None:
    p.add_argument("input", metavar="IN.bvh")
    p.add_argument("--plot", metavar="FIG.png", help="figure of the layers (png, svg, pdf)")
    p.add_argument("--npz", metavar="LAYERS.npz", help="all layers and parameters as numpy arrays")
    p.add_argument("--joint", default=None, help="joint shown in the figure (default: the one "
                                                 "whose controllable layer moves most)")
    _layer_options(p)


@command("layers", "decompose a clip into base, controllable and residual layers",
         arguments=_arguments_layers, reads_clips=True, inputs=("input",),
         outputs={"plot": FIGURE, "npz": NPZ}, requires=(Needs("matplotlib", when="plot"),))
def cmd_layers(args) -> int:
    if not args.plot and not args.npz:
        print("mlayer layers: nothing to write; give --plot and/or --npz (showing the "
              "chosen parameters only)", file=sys.stderr)
    m = read_bvh(args.input)
    layers = _decompose(args, m)
    names = m.joint_names
    print(f"{args.input}: {m.n_frames} frames at {m.fps:g} fps")
    print(f"{'group':24s} {'base s':>10s} {'max angle':>10s} {'lam_c':>8s} {'sigma_c':>8s} "
          f"{'dof':>8s}")
    groups = ["(root translation)"] + list(names)
    for g, name in enumerate(groups):
        ang = layers.base_max_angle[g]
        ang_txt = f"{math.degrees(ang):9.1f}d" if g else f"{ang:10.3g}"
        print(f"{name:24s} {layers.base_s[g]:10.3g} {ang_txt} {layers.lam_c[g]:8.3g} "
              f"{layers.sigma_c[g]:8.3g} {layers.control_dof[g]:8.1f}")
    if args.plot:  # the figure's joint is checked before anything is written
        joint, axis = layer_choice(m, layers, args.joint)
    if args.npz:
        layers.save_npz(args.npz)
        print(f"wrote {args.npz}")
    if args.plot:
        plot_layers(m, layers, args.plot, joint=joint, root_axis=axis,
                    title=f"{args.input}: layers")
        print(f"wrote {args.plot} (root {'XYZ'[axis]}, joint {joint})")
    _outlier_note(layers)
    return 0
