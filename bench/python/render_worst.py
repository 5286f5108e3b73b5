"""Render the worst frames of an operation before (unguarded) and after (guarded) as stick
figures (issue 18, item 8).

    python bench/python/render_worst.py CLIP.bvh [--op stylize] [--alpha 3] [-o out.png]

Finds, on the unguarded output, the frame with the largest knee/elbow fold, the one with the
largest reversal (bending the other way) and the one with the deepest floor penetration
(definitions in plausibility.py), and draws each in a side view and a front view, unguarded
then guarded (the guards the installed mlayer accepts, see bench_plausibility.py), with the
floor line, the offending joint in red and the measured angle / depth in the caption. The
Agg backend is used through a local Figure/canvas, so the caller's matplotlib backend is not
changed.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import mlayer

import bench_plausibility as B
import plausibility as P


def _views(up: int):
    """(side, front) as pairs of (horizontal axis, vertical axis) indices."""
    hor = [k for k in range(3) if k != up]
    return (hor[1], up), (hor[0], up)


def _draw(ax, pos, parents, h_ax, v_ax, floor, hl, title, center):
    for j in range(1, len(parents)):
        p = parents[j]
        ax.plot([pos[p, h_ax], pos[j, h_ax]], [pos[p, v_ax], pos[j, v_ax]], "-",
                color="0.25", lw=1.4)
    ax.plot(pos[:, h_ax], pos[:, v_ax], "o", ms=1.8, color="0.25")
    for j in hl:
        ax.plot(pos[j, h_ax], pos[j, v_ax], "o", ms=7, mfc="none", mec="red", mew=1.8)
    ax.axhline(floor, color="tab:brown", lw=1.0, ls="--")
    ax.set_aspect("equal")
    ax.set_xlim(center[0] - 0.65, center[0] + 0.65)
    ax.set_ylim(center[1] - 0.35, center[1] + 1.2)
    ax.set_title(title, fontsize=7)
    ax.set_xticks([])
    ax.set_yticks([])


def worst_frames(m, un, gu, chains, feet, floor, H):
    """[(kind, frame, joint index, caption of unguarded, caption of guarded)]."""
    names = m.joint_names
    out = []
    hr_u = P.hinge_report(m, un, chains)
    P.hinge_report(m, gu, chains)  # checks the guarded motion's chains as the unguarded's
    pi, wi = m.forward_kinematics()
    pu, wu = un.forward_kinematics()
    pg, wg = gu.forward_kinematics()
    for kind in ("knee", "elbow"):
        wf = hr_u[kind]["worst_fold"]
        if wf:
            t, jn = wf[0], wf[1]
            ch = next(c for c in chains[kind] if names[c[1]] == jn)
            out.append(("fold", t, ch[1],
                        f"{jn} flexion {P.flexion(pu, ch)[t]:.0f}° (input max {wf[3]:.0f}°)",
                        f"{P.flexion(pg, ch)[t]:.0f}°"))
        # the worst reversal among frames that are not folds (a fully folded limb has an
        # ill-defined sign)
        best = None
        for ch in chains[kind]:
            ax = P.hinge_axis_local(pi, wi, m.parents, ch)
            if ax is None:
                continue
            si = P.signed_flexion(pi, wi, m.parents, ch, ax)
            su = P.signed_flexion(pu, wu, m.parents, ch, ax)
            thr = min(0.0, si.min()) - P.REVERSAL_TOL_DEG
            ok = (su < thr) & (np.abs(su) < P.HUMAN_LIMIT_DEG)
            if ok.any():
                t = int(np.argmin(np.where(ok, su, np.inf)))
                if best is None or su[t] < best[0]:
                    sg = P.signed_flexion(pg, wg, m.parents, ch, ax)[t]
                    best = (su[t], t, ch, si.min(), sg)
        if best:
            v, t, ch, mn, sg = best
            out.append(("reversal", t, ch[1], f"{names[ch[1]]} bent the other way {v:.0f}° "
                        f"(input min {mn:.0f}°)", f"{sg:.0f}°"))
    fl = P.floor_report(m, un, feet, floor, H)
    if fl["worst"]:
        t, pn, d = fl["worst"]
        yg = mlayer.contacts.contact_positions(gu, [pn])[t, 0, P._up_index(m)]
        jn = pn.split("/")[0]
        out.append(("floor", t, names.index(jn),
                    f"{pn} {d:.1f}% of height below the floor",
                    f"{100 * max(0.0, floor - yg) / H:.1f}%"))
    # the worst of each kind (fold, reversal, floor) only
    best = {}
    for row in out:
        best.setdefault(row[0], row)
    return list(best.values())


def render(path, op="stylize", alpha=3.0, out_png="worst.png", dpi=90):
    m = mlayer.read_bvh(path)
    H = mlayer.metrics.body_height(m)
    chains = P.limb_chains(m)
    feet = P.foot_points(m)
    cn, cc = mlayer.detect_contacts(m, feet) if feet else ([], None)
    up = P._up_index(m)  # the clip's vertical axis (Z-up files draw and measure along Z)
    floor = P.floor_level(m, feet, cc) if feet else float(m.positions()[..., up].min())
    fn = mlayer.denoise if op == "denoise" else mlayer.stylize
    guards = B.accepted_guards(fn)
    un, _ = B._call(op, m, alpha, B._kw(guards, set()))
    gu, _ = B._call(op, m, alpha, B._kw(guards, set(guards)))
    glabel = "+".join(B.GUARD_LABEL[g] for g in guards) or "none"
    rows = worst_frames(m, un, gu, chains, feet, floor, H)
    if not rows:
        print("no fold, reversal or floor penetration found", file=sys.stderr)
        return None
    side, front = _views(up)
    height = 2.45 * len(rows) + 0.6
    fig = Figure(figsize=(7.2, height), dpi=dpi)
    FigureCanvasAgg(fig)
    pu_all, pg_all = un.positions() / H, gu.positions() / H
    f0 = floor / H
    opname = op if op == "denoise" else f"stylize alpha {alpha:g}"
    captions = []
    for r, (_kind, t, j, cap_u, cap_g) in enumerate(rows):
        for c, (pos, lab, cap) in enumerate(((pu_all[t], "unguarded", cap_u),
                                             (pg_all[t], "guarded",
                                              f"same frame: {cap_g}"))):
            for v, (h_ax, v_ax) in enumerate((side, front)):
                ax = fig.add_subplot(len(rows), 4, 4 * r + 2 * c + v + 1)
                center = (0.5 * (pos[:, h_ax].min() + pos[:, h_ax].max()), f0)
                _draw(ax, pos, m.parents, h_ax, v_ax, f0, [j],
                      f"{lab}, {'side' if v == 0 else 'front'}", center)
            captions.append((r, c, (f"frame {t}: " if c == 0 else "") + cap))
    fig.suptitle(f"{path.split('/')[-1]}: {opname}, worst frames, unguarded and guarded\n"
                 f"({glabel}) (red: offending joint; dashed: input floor)", fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.55 / height), h_pad=4.5)
    for r, c, text in captions:
        a0, a1 = fig.axes[4 * r + 2 * c], fig.axes[4 * r + 2 * c + 1]
        p0, p1 = a0.get_position(), a1.get_position()
        # above the panels' titles: 16 points over the panel, whatever the figure's height
        fig.text(0.5 * (p0.x0 + p1.x1), p0.y1 + 16 / 72 / height, text, ha="center",
                 fontsize=7.5, color="darkred" if c == 0 else "darkgreen")
    fig.savefig(out_png, dpi=dpi)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("clip")
    ap.add_argument("--op", default="stylize", choices=["stylize", "denoise"])
    ap.add_argument("--alpha", type=float, default=3.0)
    ap.add_argument("-o", "--out", default="worst.png")
    ap.add_argument("--dpi", type=int, default=90)
    a = ap.parse_args(argv)
    rows = render(a.clip, a.op, a.alpha, a.out, a.dpi)
    for row in rows or []:
        print(f"{row[0]}: frame {row[1]}: {row[3]} -> guarded {row[4]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
