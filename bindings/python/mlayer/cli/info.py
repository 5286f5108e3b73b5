"""`mlayer info FILE.bvh`: what a BVH file holds.

Joints, channels, frames, fps, duration, the extent of the world joint positions over all
frames, a body height estimate, and the skeleton tree with each joint's channels. A file that
does not parse gives one line ``mlayer: FILE:LINE: reason`` on stderr and exit status 1.
"""
from __future__ import annotations

import os
from typing import TYPE_CHECKING
import sys

import numpy as np

from ..io.bvh import read_bvh
from ..guards.metrics import body_height
from ..model.units import UNITS, length_unit
from ..model.up_axis import detect_up
from ..errors import Error, ParseError
from ._command import command

if TYPE_CHECKING:
    from ..model.motion import Motion


def _arguments(p) -> None:
    p.add_argument("files", nargs="+", metavar="FILE.bvh", help="BVH file(s) to describe")
    p.add_argument("--no-tree", action="store_true", help="leave out the skeleton tree")


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def describe(m: Motion, path: str | None = None, tree: bool = True) -> str:
    """The text that `mlayer info` prints for motion m."""
    sk = m.skeleton
    J, E, N = sk.n_joints, sk.n_end_sites, m.n_frames
    lines = []
    if path is not None:
        lines.append(f"file      {path} ({os.path.getsize(path):,} bytes)")
    lines.append(f"joints    {J} (+{E} End Sites), root '{sk.joint_names[0]}'")
    counts: dict[int, int] = {}
    for c in sk.channels:
        n = len(c.split())
        counts[n] = counts.get(n, 0) + 1
    per = ", ".join(f"{k} joints x {n}" if k > 1 else f"1 joint x {n}"
                    for n, k in sorted(counts.items(), reverse=True))
    P = sk.trans_joints.shape[0]
    pos_note = f"; position channels on {P} non-root joint(s)" if P else ""
    orders: dict[str, int] = {}
    for o, c in zip(sk.euler_orders, sk.channels):
        if "rotation" in c:
            orders[o] = orders.get(o, 0) + 1
    order_note = ", ".join(f"{o} x {k}" for o, k in sorted(orders.items(), key=lambda t: -t[1]))
    lines.append(f"channels  {sk.n_channels} ({per}){pos_note}; Euler orders {order_note}")
    lines.append(f"frames    {N}")
    lines.append(f"fps       {m.fps:.6g} (Frame Time {m.frame_time:.9g} s)")
    lines.append(f"duration  {m.duration:.3f} s")
    if N:
        p = m.positions()
        lo, hi = p.reshape(-1, 3).min(axis=0), p.reshape(-1, 3).max(axis=0)
        size = hi - lo
        lines.append("extent    " + "  ".join(
            f"{a} [{_fmt(lo[i])}, {_fmt(hi[i])}]" for i, a in enumerate("xyz"))
            + f"  (world joint positions over all frames; size {_fmt(size[0])} x "
              f"{_fmt(size[1])} x {_fmt(size[2])})")
        g = detect_up(m, p)
        up = m.up_axis
        if m._up is not None:
            how = "given"
        elif g.sure:
            how = f"detected from the {g.method}, confidence {g.confidence:.2f}"
        else:
            how = (f"unsure: the {'feet suggest' if g.method == 'feet' else 'floor suggests'} "
                   f"{g.axis.upper()} with confidence "
                   f"{g.confidence:.2f}; Y assumed, pass --up to say" if g.method != "none"
                   else "nothing to go by; Y assumed")
        flip = " (the clip stands upside down along it)" if g.sure and g.sign < 0 and \
            g.axis == up and m._up is None else ""
        lines.append(f"up        {up.upper()} ({how}){flip}")
        h = body_height(p, up)
        unit = length_unit(h)
        given = m._units
        tail = (f", {given} (given): {_fmt(h * UNITS[given])} m)" if given
                else f", which look like {unit})" if unit else ")")
        lines.append(f"height    ~{_fmt(h)} (median over frames of the joints' extent along "
                     f"{up.upper()}; End Sites excluded; file units" + tail)
    if tree:
        lines.append("skeleton")
        depth = sk.depth()
        width = max(2 * int(d) + len(n) for d, n in zip(depth, sk.joint_names))
        ends = np.bincount(sk.end_site_parents, minlength=J) if E else np.zeros(J, int)
        for j, name in enumerate(sk.joint_names):
            label = "  " * int(depth[j]) + name
            ch = sk.channels[j]
            short = " ".join(c[0] + ("pos" if c.endswith("position") else "rot")
                             for c in ch.split()) or "(no channels)"
            extra = "  + End Site" if ends[j] == 1 else \
                (f"  + {ends[j]} End Sites" if ends[j] > 1 else "")
            lines.append(f"  {label:<{width}}  {short:<30} {sk.euler_orders[j]}{extra}".rstrip())
    return "\n".join(lines)


@command("info", "describe BVH files: joints, channels, frames, fps, extent, skeleton tree",
         arguments=_arguments, reads_clips=True, inputs=("files",))
def cmd_info(args) -> int:
    status = 0
    for i, path in enumerate(args.files):
        try:
            m = read_bvh(path)
        except ParseError as e:  # its message starts with "FILE:LINE: "
            print(f"mlayer: {e}", file=sys.stderr)
            status = 1
            continue
        except Error as e:
            print(f"mlayer: {path}: {e}", file=sys.stderr)
            status = 1
            continue
        except OSError as e:
            reason = e.strerror or str(e)
            print(f"mlayer: {path}: {reason}", file=sys.stderr)
            status = 1
            continue
        if i:
            print()
        print(describe(m, path, tree=not args.no_tree))
    return status
