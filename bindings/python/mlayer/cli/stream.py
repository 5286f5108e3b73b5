"""`mlayer stream IN.bvh --lag 10 [--lam L --sigma S] -o OUT.bvh [--plot compare.png]`.

Streams a clip frame by frame through the fixed-lag LGS smoother (:class:`mlayer.Stream`), as
a live system would, writes the streamed motion and prints its largest gap to the offline solve
(``mlayer.lgs`` on the same channels with the same lam, sigma). ``--plot`` draws one joint
rotation channel over time: the input, the offline solve, the stream and a One Euro filter
(:mod:`mlayer.layers.one_euro`, by default with the LGS's half-power frequency as its cutoff and
beta 0), and below, each one's difference to the offline solve.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING
import sys

import numpy as np

from ..model import quat
from ..io.bvh import read_bvh
from ..errors import InvalidArgumentError
from ..layers.smoothing import lgs
from ..layers.one_euro import one_euro
from ..plotting.plot import plot_stream
from ..pipeline.stream import decay_rate, motion_channels, stream_motion
from ._command import BVH_OR_STDOUT, PNG, Needs, command, output_name, write_bvh_output

if TYPE_CHECKING:
    from ..model.motion import Motion

_COMPONENTS = "wxyz"


def _arguments(p) -> None:
    p.add_argument("input", metavar="IN.bvh", help="the clip to stream")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh",
                   help="where to write the streamed motion (BVH; - for the standard output)")
    p.add_argument("--lag", type=int, default=10, help="output delay in frames (default 10)")
    p.add_argument("--lam", type=float, default=1.0, help="smoothness weight lam (default 1)")
    p.add_argument("--sigma", type=float, default=1.0, help="observation noise sigma (default 1)")
    p.add_argument("--plot", metavar="PNG", help="write a comparison plot (offline, streamed, "
                   "One Euro) of one joint rotation channel")
    p.add_argument("--joint", help="joint of the plot (default: the one whose rotation moves "
                   "most)")
    p.add_argument("--component", choices=list(_COMPONENTS),
                   help="quaternion component of the plot (default: the one that moves most)")
    p.add_argument("--euro-min-cutoff", type=float, metavar="HZ",
                   help="One Euro cutoff at rest (default: the LGS's half-power frequency)")
    p.add_argument("--euro-beta", type=float, default=0.0,
                   help="One Euro speed coefficient (default 0)")


def aligned_channels(motion: Motion) -> np.ndarray:
    """Stream channels (N, 3 + 3P + 4J) with the quaternions made continuous by the predictive
    rule, as the stream aligns them."""
    y = motion_channels(motion)
    q0, J = y.shape[1] - 4 * motion.n_joints, motion.n_joints
    if motion.n_frames:
        y[:, q0:] = quat.continuous(y[:, q0:].reshape(-1, J, 4),
                                    predictive=True).reshape(len(y), -1)
    return y


def _renormalize(x: np.ndarray, J: int) -> np.ndarray:
    q = x[:, x.shape[1] - 4 * J:].reshape(len(x), J, 4)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return x


def offline_channels(motion: Motion, lam: float, sigma: float) -> np.ndarray:
    """The offline solve the stream converges to: mlayer.lgs (order 2) on the aligned channels,
    quaternions renormalized."""
    y = aligned_channels(motion)
    if len(y) == 0:
        return y
    return _renormalize(lgs(y, lam, sigma), motion.n_joints)


def half_power_frequency(lam: float, sigma: float, rate: float) -> float:
    """Frequency (Hz) where the order-2 LGS's gain 1 / (1 + s (2 - 2 cos w)^2) is 1/2, s = lam^2
    sigma^2 (the Nyquist frequency when it does not get there)."""
    s = lam * lam * sigma * sigma
    c = 1.0 - 0.5 / math.sqrt(s) if s > 0 else -2.0
    w = math.acos(c) if c > -1.0 else math.pi
    return w * rate / (2.0 * math.pi)


def _gaps(motion, x: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """Largest gap: translations relative to the clip's size (largest translation range),
    quaternion components absolute."""
    nt = x.shape[1] - 4 * motion.n_joints
    y = motion_channels(motion)[:, :nt]
    size = float((y.max(axis=0) - y.min(axis=0)).max()) if len(y) else 0.0
    gt = float(np.abs(x[:, :nt] - ref[:, :nt]).max()) / size if size > 0 else 0.0
    gq = float(np.abs(x[:, nt:] - ref[:, nt:]).max()) if x.shape[1] > nt else 0.0
    return gt, gq


@command("stream", "stream a clip through the fixed-lag LGS smoother (live filtering), write it "
                   "and compare it with the offline solve",
         arguments=_arguments, reads_clips=True, inputs=("input",),
         outputs={"output": BVH_OR_STDOUT, "plot": PNG},
         requires=(Needs("matplotlib", when="plot"),))
def cmd_stream(args) -> int:
    motion = read_bvh(args.input)
    if motion.n_frames == 0:
        raise InvalidArgumentError(f"{args.input}: the clip has no frames")
    joint = comp = None
    if args.plot:  # check the plot's options before any work
        if args.joint is not None:
            joint = motion.skeleton.index(args.joint)
        if args.component is not None:
            comp = _COMPONENTS.index(args.component)
        if args.euro_min_cutoff is not None and not (math.isfinite(args.euro_min_cutoff)
                                                     and args.euro_min_cutoff > 0):
            raise InvalidArgumentError(f"--euro-min-cutoff must be > 0, got "
                                       f"{args.euro_min_cutoff:g}")
    out = stream_motion(motion, lam=args.lam, sigma=args.sigma, lag=args.lag)
    x = motion_channels(out)
    ref = offline_channels(motion, args.lam, args.sigma)
    gt, gq = _gaps(motion, x, ref)
    print(f"{output_name(args.output)}: {out.n_frames} frames streamed with lag {args.lag} "
          f"(lam {args.lam:g}, "
          f"sigma {args.sigma:g}, decay rate {decay_rate(args.lam, args.sigma):.3f}); largest "
          f"gap to the offline solve: {gt:.3g} of the clip size (translations), {gq:.3g} "
          "(quaternion components)")
    if args.plot:
        y = aligned_channels(motion)
        J, q0 = motion.n_joints, y.shape[1] - 4 * motion.n_joints
        cutoff = args.euro_min_cutoff if args.euro_min_cutoff is not None \
            else half_power_frequency(args.lam, args.sigma, motion.fps)
        euro = _renormalize(one_euro(y, motion.fps, cutoff, args.euro_beta), J)
        moves = np.abs(np.diff(y[:, q0:], axis=0)).sum(axis=0).reshape(J, 4)
        if joint is None:
            joint = int(np.argmax(moves.sum(axis=1)))
        if comp is None:
            comp = int(np.argmax(moves[joint]))
        plot_stream(motion, y, ref, x, euro, args.plot, joint=joint, component=comp,
                    lag=args.lag, lam=args.lam, sigma=args.sigma, cutoff=cutoff,
                    beta=args.euro_beta)
        print(f"{args.plot}: {motion.joint_names[joint]} q.{_COMPONENTS[comp]}", file=sys.stdout)
    write_bvh_output(args, out)  # last: a failure above leaves no output
    return 0
