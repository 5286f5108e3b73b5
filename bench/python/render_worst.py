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

Two before/after views of issue 38's targets (issue 38, item 10). A build of mlayer measures
in its own process and saves an .npz (`--save`); `--compare` draws two saved files (the first
is "before", the second "after"), since two builds cannot be imported in one process:

    PYTHONPATH=OLD_BUILD python bench/python/render_worst.py CLIP --pop 0.5 --save before.npz
    python bench/python/render_worst.py CLIP --pop 0.5 --save after.npz
    python bench/python/render_worst.py --compare before.npz after.npz -o pops.png

`--pop ALPHA`: foot pops of `stylize(m, ALPHA)`. Foot points are the joints named foot, toe or
ankle; a point's acceleration at frame t is |p(t+1) - 2 p(t) + p(t-1)| and the pop ratio is the
largest over the output's foot points and frames over the larger of the input's and of the
unguarded synthesis's (`limits=False, floor=False, keep_contacts=False`), as in
test_guards_pops.py. The figure is a side view of the legs (looking along the hips' left-right
axis) on 5 consecutive frames around the first file's worst frame, one row per file: the floor,
the toe tips (End Sites), and the worst foot point's trajectory dotted, each panel giving that
point's jump from the previous frame in % of body height.

`--clean` (one or more clips): how far the guards move a clean clip when denoising, the largest
joint distance between `denoise(m)` and the unguarded `denoise(m, limits=False, floor=False,
keep_contacts=False)` in % of body height. The figure overlays the two at the first file's
worst frame, zoomed to the leg of the worst joint, one panel per clip and file.

Without --save, --pop and --clean draw the installed build's measures alone (`-o`).
"""
from __future__ import annotations

import argparse
import re
import sys
import warnings
from typing import Any

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
        yg = mlayer.guards.contacts.contact_positions(gu, [pn])[t, 0, P._up_index(m)]
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


# ---- issue 38, item 10: foot pops and clean clips, before and after ------------------------

FOOT = re.compile(r"(foot|toe|ankle)", re.I)
UNGUARDED = {"limits": False, "floor": False, "keep_contacts": False}
STRIP = 5       # frames drawn around the worst pop
PATH_HALF = 12  # frames of the dotted foot path on each side of the strip's middle frame
GUARDED_C, UNGUARDED_C, OTHER_LEG_C, TRUNK_C = "tab:blue", "tab:orange", "0.35", "0.7"
TIP_C, FLOOR_C, JUMP_C = "tab:green", "saddlebrown", "red"


def foot_joints(m) -> list[int]:
    """The joints named foot, toe or ankle (not 'index'), as in test_guards_pops.py."""
    return [j for j, n in enumerate(m.joint_names) if FOOT.search(n) and "index" not in n.lower()]


def foot_accel(p: np.ndarray) -> np.ndarray:
    """(N - 2, K) |p(t+1) - 2 p(t) + p(t-1)| of (N, K, 3) points; row i is frame i + 1."""
    return np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=-1)


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kw)


def _common(m, path: str) -> dict:
    """What every saved case holds: the clip's skeleton, body height, up axis and floor."""
    H = mlayer.metrics.body_height(m)
    up = P._up_index(m)
    pts = P.foot_points(m)
    cc = mlayer.detect_contacts(m, pts)[1] if pts else None
    floor = P.floor_level(m, pts, cc) if pts else float(m.positions()[..., up].min())
    legs = [list(c) for c in P.limb_chains(m)["knee"]]
    return {"clip": str(path).split("/")[-1], "build": mlayer.__file__,
            "version": mlayer.__version__, "H": H, "up": up, "floor": floor, "fps": m.fps,
            "names": np.array(m.joint_names), "parents": np.asarray(m.parents),
            "es_parents": np.asarray(m.end_site_parents, dtype=int),
            "legs": np.array(legs, dtype=int).reshape(-1, 3)}


def measure_pop(path: str, alpha: float) -> dict:
    """stylize(m, alpha): its positions, foot accelerations and the pop ratio (worst frame)."""
    m = mlayer.read_bvh(str(path))
    feet = foot_joints(m)
    if not feet:
        raise SystemExit(f"{path}: no joint named foot, toe or ankle")
    out = _quiet(mlayer.stylize, m, alpha)
    ref = _quiet(mlayer.stylize, m, alpha, **UNGUARDED)
    acc = foot_accel(out.positions()[:, feet])
    a_in = float(foot_accel(m.positions()[:, feet]).max())
    a_ref = float(foot_accel(ref.positions()[:, feet]).max())
    i, k = np.unravel_index(int(np.argmax(acc)), acc.shape)
    c = _common(m, path)
    c.update(kind="pop", alpha=alpha, feet=np.array(feet), pos=out.positions(),
             es=out.end_site_positions(), accel=acc, a_in=a_in, a_ref=a_ref,
             ratio=float(acc.max()) / max(a_in, a_ref), frame=int(i) + 1, point=feet[k])
    return c


def measure_clean(path: str) -> dict:
    """denoise(m) guarded and unguarded: both, and the joints' distance in % of H."""
    m = mlayer.read_bvh(str(path))
    g = _quiet(mlayer.denoise, m)
    u = _quiet(mlayer.denoise, m, **UNGUARDED)
    c = _common(m, path)
    d = 100.0 * np.linalg.norm(g.positions() - u.positions(), axis=-1) / c["H"]
    t, j = np.unravel_index(int(np.argmax(d)), d.shape)
    c.update(kind="clean", pos=g.positions(), es=g.end_site_positions(), pos_u=u.positions(),
             es_u=u.end_site_positions(), change=d, frame=int(t), joint=int(j))
    return c


def _panel_frame(ax, xlim, ylim, bar_pct):
    """A panel's limits, equal aspect and no ticks; a scale bar of bar_pct % of body height
    (0: none)."""
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    if bar_pct:
        _scale_bar(ax, xlim, ylim, bar_pct)


def measure_floor(path: str, alpha: float) -> dict:
    """stylize(m, alpha): every joint's and End Site's depth below the input's floor beyond the
    input's own there (issue 38's definition), in % of H, and the worst frame and point."""
    m = mlayer.read_bvh(str(path))
    out = _quiet(mlayer.stylize, m, alpha)
    c = _common(m, path)
    up, H = c["up"], c["H"]
    pin = np.concatenate([m.positions(), m.end_site_positions()], axis=1)[..., up]
    pout = np.concatenate([out.positions(), out.end_site_positions()], axis=1)[..., up]
    floor = float(np.percentile(pin.min(axis=1), 5))
    ex = 100.0 * ((np.maximum(0.0, floor - pout) - np.maximum(0.0, floor - pin)) / H)
    t, k = np.unravel_index(int(np.argmax(ex)), ex.shape)
    c.update(kind="floor", alpha=alpha, floor=floor, pos=out.positions(),
             es=out.end_site_positions(), excess=ex, frame=int(t), point=int(k))
    return c


def _point_name(c: dict, k: int) -> str:
    J = len(c["names"])
    return str(c["names"][k]) if k < J else f"{c['names'][int(c['es_parents'][k - J])]}/End"


def _floor_panel(ax, builds, ci, bi, label):
    """The whole skeleton at the worst frame of the first build, side view, with the floor."""
    c0, c = builds[0][ci], builds[bi][ci]
    H, t, k = c0["H"], int(c0["frame"]), int(c0["point"])
    fwd, lat, up = _body_axes(c0, t)
    axes = (fwd, up)
    xy = _proj(c["pos"][t] / H, axes)
    es = _proj(c["es"][t] / H, axes)
    f0 = c0["floor"] / H
    allp = np.concatenate([_proj(b[ci]["pos"][t] / H, axes) for b in builds] +
                          [_proj(b[ci]["es"][t] / H, axes) for b in builds])
    m = 0.05
    xlim, ylim = _fit(allp[:, 0].min() - m, allp[:, 0].max() + m,
                      min(f0, allp[:, 1].min()) - m, allp[:, 1].max() + m, 0.8)
    _floor_drawn(ax, f0, xlim, ylim)
    for j, p in enumerate(c["parents"]):
        if p >= 0:
            ax.plot(*zip(xy[p], xy[j]), color=TRUNK_C, lw=2.2, zorder=4)
    for e, p in enumerate(c["es_parents"]):
        ax.plot(*zip(xy[int(p)], es[e]), color=TRUNK_C, lw=1.2, zorder=4)
    J = len(c["names"])
    pt = xy[k] if k < J else es[k - J]
    ax.plot(*pt, "o", ms=14, mfc="none", mec=JUMP_C, mew=2.2, zorder=12)
    d = float(c["excess"][t, k])
    most = float(c["excess"].max())
    tw, kw = np.unravel_index(int(np.argmax(c["excess"])), c["excess"].shape)
    ax.set_title(f"{label}: {c0['clip']}, stylize {c0['alpha']:g}\nframe {t}, side view",
                 fontsize=11)
    ax.set_xlabel(f"{_point_name(c0, k)} {max(d, 0.0):.1f}% of body height below the floor\n"
                  f"(clip's deepest {max(most, 0.0):.1f}%: {_point_name(c, int(kw))}, frame {tw})",
                  fontsize=11, color="darkred" if d > 0.5 else "darkgreen", weight="bold")
    _panel_frame(ax, xlim, ylim, 10 if bi == 0 and ci == 0 else 0)


def save_cases(cases: list[dict], path: str) -> None:
    arrays: dict[str, Any] = {f"c{i}_{k}": np.asarray(v) for i, c in enumerate(cases)
                              for k, v in c.items()}
    np.savez_compressed(path, **arrays)


def load_cases(path: str) -> list[dict]:
    cases: dict[int, dict] = {}
    with np.load(path) as z:
        for key in z.files:
            i, k = key[1:].split("_", 1)
            v = z[key]
            cases.setdefault(int(i), {})[k] = v.item() if v.ndim == 0 else v
    return [cases[i] for i in sorted(cases)]


def _body_axes(c: dict, t: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, lateral, up) unit vectors at frame t: lateral along the hips (mean over 1 s),
    forward across it, pointing the way the toes do; the clip's axes without two legs."""
    up = np.eye(3)[c["up"]]
    pos, legs = c["pos"], c["legs"]
    hor = [np.eye(3)[k] for k in range(3) if k != c["up"]]
    if len(legs) < 2:
        return hor[1], hor[0], up
    w = slice(max(0, t - int(c["fps"] / 2)), t + int(c["fps"] / 2) + 1)
    lat = (pos[w, legs[0][0]] - pos[w, legs[1][0]]).mean(axis=0)
    lat -= up * (lat @ up)
    if np.linalg.norm(lat) < 1e-9:
        return hor[1], hor[0], up
    lat /= np.linalg.norm(lat)
    fwd = np.cross(up, lat)
    tips = [e for e, p in enumerate(c["es_parents"]) if _leg_of(c, p) >= 0]
    if tips:
        ank = [c["legs"][_leg_of(c, c["es_parents"][e])][2] for e in tips]
        toe = (c["es"][w][:, tips] - pos[w][:, ank]).mean(axis=(0, 1))
        if toe @ fwd < 0:
            fwd, lat = -fwd, -lat
    return fwd, lat, up


def _leg_of(c: dict, j: int) -> int:
    """The index in c["legs"] of the leg holding joint j (its hip or below), -1 if none."""
    hips = list(c["legs"][:, 0])
    while j >= 0:
        if j in hips:
            return hips.index(j)
        j = int(c["parents"][j])
    return -1


def _leg_points(c: dict, hot: int) -> tuple[list[int], list[int]]:
    """The joints of leg hot from its knee down (every joint when hot < 0) and their End
    Sites, in a saved clip c."""
    js = [k for k in range(len(c["parents"])) if hot < 0 or _below(c, k, c["legs"][hot][1])]
    return js, [e for e, p in enumerate(c["es_parents"]) if p in js]


def _below(c: dict, j: int, top: int) -> bool:
    """Joint j is top or below it."""
    while j >= 0 and j != top:
        j = int(c["parents"][j])
    return j == top


def _fit(x0, x1, y0, y1, aspect):
    """Limits grown to a width / height ratio of aspect around the same centre."""
    w, h = x1 - x0, y1 - y0
    if w < aspect * h:
        x0, x1 = 0.5 * (x0 + x1) - 0.5 * aspect * h, 0.5 * (x0 + x1) + 0.5 * aspect * h
    else:
        y0, y1 = 0.5 * (y0 + y1) - 0.5 * w / aspect, 0.5 * (y0 + y1) + 0.5 * w / aspect
    return (x0, x1), (y0, y1)


def _legs_drawn(ax, c, xy, es_xy, hot_leg, color=GUARDED_C, other=OTHER_LEG_C, trunk=TRUNK_C,
                tip=TIP_C, ls="-", lw=2.2, alpha=1.0, z=3):
    """The skeleton in 2D (xy: (J, 2), es_xy: (E, 2)): the hot leg in color, the other legs
    in other, the trunk in trunk; End Sites of the legs (toe tips) as triangles."""
    def col(j):
        leg = _leg_of(c, j)
        return trunk if leg < 0 else (color if leg == hot_leg else other)
    par = c["parents"]
    for j in range(len(par)):
        if par[j] >= 0:
            ax.plot(*zip(xy[par[j]], xy[j]), ls, color=col(j), lw=lw, alpha=alpha,
                    solid_capstyle="round", zorder=z + (col(j) == color))
    for e, p in enumerate(c["es_parents"]):
        ax.plot(*zip(xy[p], es_xy[e]), ls, color=col(p), lw=lw, alpha=alpha, zorder=z,
                solid_capstyle="round")
        if tip and _leg_of(c, p) >= 0:
            ax.plot(*es_xy[e], "^", ms=8, color=tip, mec="k", mew=0.6, zorder=z + 3)
    ax.plot(xy[:, 0], xy[:, 1], "o", ms=2.5, color="0.2", alpha=alpha, zorder=z + 2)


def _floor_drawn(ax, f0, xlim, ylim):
    ax.axhline(f0, color=FLOOR_C, lw=1.6, zorder=1)
    ax.fill_between(xlim, [ylim[0]] * 2, [f0] * 2, color=FLOOR_C, alpha=0.12, lw=0, zorder=0)


def _scale_bar(ax, xlim, ylim, pct=10):
    """A bar of pct % of body height in the panel's upper right (coordinates are in H)."""
    x1 = xlim[1] - 0.04 * (xlim[1] - xlim[0])
    y = ylim[1] - 0.05 * (ylim[1] - ylim[0])
    ax.plot([x1 - pct / 100, x1], [y, y], "-", color="k", lw=2.5, zorder=9)
    ax.text(x1, y - 0.02 * (ylim[1] - ylim[0]), f"{pct}% of body height", ha="right",
            va="top", fontsize=9, zorder=9)


def _proj(p, axes):
    """(..., 3) points on the 2D view whose axes are (horizontal, vertical) unit vectors."""
    return np.stack([p @ axes[0], p @ axes[1]], axis=-1)


def _pop_strip(fig, builds, labels, ci, top, bottom):
    """The rows of one --pop case (one per build) between figure heights top and bottom."""
    c0 = builds[0][ci]
    H, t, pt = c0["H"], int(c0["frame"]), int(c0["point"])
    frames = [t - STRIP // 2 + i for i in range(STRIP)]
    frames = [f - min(0, frames[0]) - max(0, frames[-1] - len(c0["pos"]) + 1) for f in frames]
    fwd, _, up = _body_axes(c0, t)
    hot = _leg_of(c0, pt)
    f0 = c0["floor"] / H
    pn = str(c0["names"][pt])
    lo, hi = max(0, frames[0] - PATH_HALF), min(len(c0["pos"]), frames[-1] + PATH_HALF + 1)
    # one window for every panel: the foot's leg from the knee down, its toe tips, the foot's
    # path and the floor
    pts = []
    for b in builds:
        c = b[ci]
        below, tips = _leg_points(c, hot)
        for f in frames:
            pts += [c["pos"][f, below], c["es"][f, tips]]
        pts.append(c["pos"][lo:hi, pt])
    xy = _proj(np.concatenate(pts) / H, (fwd, up))
    m = 0.04
    xlim, ylim = _fit(xy[:, 0].min() - m, xy[:, 0].max() + m, min(f0, xy[:, 1].min()) - m,
                      xy[:, 1].max() + m, 1.0)
    n = len(builds)
    rh = (top - bottom) / n
    for r, (b, lab) in enumerate(zip(builds, labels)):
        c = b[ci]
        path = _proj(c["pos"][lo:hi, pt] / H, (fwd, up))
        steps = 100 * np.linalg.norm(np.diff(c["pos"][:, pt], axis=0), axis=-1) / H
        typical = float(np.median(steps[lo:hi - 1])) if hi - lo > 1 else 0.0
        amax = float(np.max(c["accel"]))
        worst = int(np.argmax(np.max(c["accel"], axis=1))) + 1
        fig.text(0.01, top - r * rh - 0.005,
                 f"{lab}: largest foot acceleration {100 * amax / H:.1f}% of body height per "
                 f"frame² (frame {worst}) = {c['ratio']:.2f}x the larger of the input's "
                 f"({100 * c['a_in'] / H:.2f}%) and the unguarded synthesis' "
                 f"({100 * c['a_ref'] / H:.2f}%); target 1.5x",
                 fontsize=11, va="top", weight="bold",
                 color="darkred" if c["ratio"] > 1.5 else "darkgreen")
        for k, f in enumerate(frames):
            ax = fig.add_axes((0.01 + k * 0.98 / STRIP, bottom + (n - 1 - r) * rh + 0.01,
                               0.98 / STRIP - 0.008, rh - 0.075))
            _floor_drawn(ax, f0, xlim, ylim)
            ax.plot(path[:, 0], path[:, 1], ":", color="0.15", lw=1.3, zorder=4)
            ax.plot(path[:, 0], path[:, 1], ".", color="0.15", ms=3, zorder=4)
            _legs_drawn(ax, c, _proj(c["pos"][f] / H, (fwd, up)),
                        _proj(c["es"][f] / H, (fwd, up)), hot)
            p1 = _proj(c["pos"][f, pt] / H, (fwd, up))
            p0 = _proj(c["pos"][max(f - 1, 0), pt] / H, (fwd, up))
            s = float(steps[f - 1]) if f > 0 else 0.0
            jump = s > max(1.0, 4 * typical)
            if jump:
                ax.annotate("", xy=p1, xytext=p0, zorder=7, arrowprops={
                    "arrowstyle": "-|>", "color": JUMP_C, "lw": 2.2, "mutation_scale": 16})
            ax.plot(*p1, "o", ms=11, mfc="none", mec=JUMP_C if jump else "k", mew=1.8,
                    zorder=6)
            ax.set_title(f"frame {max(f - 1, 0)} → {f}\n{pn} moved {s:.1f}% of body height",
                         fontsize=11,
                         color=JUMP_C if jump else "k", weight="bold" if jump else "normal")
            ax.set_xlim(*xlim)
            ax.set_ylim(*ylim)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            if k == 0 and r == 0:
                _scale_bar(ax, xlim, ylim)
    return frames, pn


def _clean_panel(ax, builds, ci, bi, label):
    c0, c = builds[0][ci], builds[bi][ci]
    H, t, j = c0["H"], int(c0["frame"]), int(c0["joint"])
    fwd, lat, up = _body_axes(c0, t)
    v = c0["pos"][t, j] - c0["pos_u"][t, j]
    axes, view = ((fwd, up), "side") if np.hypot(v @ fwd, v @ up) >= np.hypot(v @ lat, v @ up) \
        else ((lat, up), "front")
    hot = _leg_of(c0, j)
    f0 = c0["floor"] / H
    # the window: the leg of the joint from the knee down (the whole body for another joint)
    pts = []
    for b in builds:
        cb = b[ci]
        js, es = _leg_points(cb, hot)
        pts += [cb[k][t, js] for k in ("pos", "pos_u")] + [cb[k][t, es] for k in ("es", "es_u")]
    xy = _proj(np.concatenate(pts) / H, axes)
    m = 0.04
    xlim, ylim = _fit(xy[:, 0].min() - m, xy[:, 0].max() + m, min(f0, xy[:, 1].min()) - m,
                      xy[:, 1].max() + m, 0.8)
    _floor_drawn(ax, f0, xlim, ylim)
    _legs_drawn(ax, c, _proj(c["pos_u"][t] / H, axes), _proj(c["es_u"][t] / H, axes), hot,
                color=UNGUARDED_C, other=UNGUARDED_C, trunk=UNGUARDED_C, tip=UNGUARDED_C,
                lw=5.5, alpha=0.55, z=2)
    _legs_drawn(ax, c, _proj(c["pos"][t] / H, axes), _proj(c["es"][t] / H, axes), hot,
                color=GUARDED_C, other=OTHER_LEG_C, trunk=TRUNK_C, lw=1.8, z=6)
    a, b2 = _proj(c["pos_u"][t, j] / H, axes), _proj(c["pos"][t, j] / H, axes)
    ax.plot(*b2, "o", ms=13, mfc="none", mec=JUMP_C, mew=2, zorder=12)
    d = float(c["change"][t, j])
    if d > 0.3:
        ax.annotate("", xy=b2, xytext=a, zorder=12, arrowprops={
            "arrowstyle": "-|>", "color": JUMP_C, "lw": 2, "mutation_scale": 14})
    tw, jw = np.unravel_index(int(np.argmax(c["change"])), c["change"].shape)
    name = str(c0["names"][j])
    ax.set_title(f"{label}: {c0['clip']}\nframe {t}, {view} view", fontsize=11)
    most = (f"clip's largest {float(c['change'].max()):.2f}%: {c['names'][jw]}, frame {tw}"
            if c["change"].max() >= 0.005 else "guarded = unguarded on every frame")
    ax.set_xlabel(f"{name} moved {d:.2f}% of body height\n({most})",
                  fontsize=11, color="darkred" if d > 0.5 else "darkgreen", weight="bold")
    _panel_frame(ax, xlim, ylim, 5 if bi == 0 and ci == 0 else 0)


def _panel_row(builds, labels, panel, dpi):
    """A figure with one panel per clip and build, drawn by panel(ax, builds, ci, bi, label)."""
    n = len(builds) * len(builds[0])
    fig = Figure(figsize=(16, 6.6), dpi=dpi)
    FigureCanvasAgg(fig)
    for ci in range(len(builds[0])):
        for bi, lab in enumerate(labels):
            panel(fig.add_subplot(1, n, ci * len(builds) + bi + 1), builds, ci, bi, lab)
    return fig


def draw_cases(builds: list[list[dict]], labels: list[str], out_png: str, dpi: int = 100):
    """The --pop strip (a row per build) or the --clean panels (a panel per clip and build) of
    builds (lists of cases saved by --save, in the same order) into out_png."""
    kinds = {c["kind"] for b in builds for c in b}
    if len(kinds) != 1 or len({len(b) for b in builds}) != 1:
        raise SystemExit("the files compared hold different kinds or numbers of cases")
    for b in builds[1:]:
        for c0, c in zip(builds[0], b):
            if c["clip"] != c0["clip"] or c["pos"].shape != c0["pos"].shape:
                raise SystemExit(f"{c['clip']} and {c0['clip']}: not the same clip")
    if kinds == {"pop"}:
        c0 = builds[0][0]
        n = len(builds)
        fig = Figure(figsize=(16, 0.7 + 3.85 * n), dpi=dpi)
        FigureCanvasAgg(fig)
        top = 1 - 0.7 / (0.7 + 3.85 * n)
        frames, pn = _pop_strip(fig, builds, labels, 0, top, 0.0)
        fig.suptitle(f"{c0['clip']}, stylize alpha {c0['alpha']:g}: frames {frames[0]}-"
                     f"{frames[-1]} around the worst foot pop, side view of the legs (blue: "
                     f"the leg of {pn}; ▲ toe tips;\nbrown: the input's floor; dotted: {pn}'s "
                     f"path over ±{PATH_HALF} frames, one dot a frame; red arrow: a jump of "
                     f"more than 4x the usual step)", fontsize=12, y=0.995)
    elif kinds == {"floor"}:
        fig = _panel_row(builds, labels, _floor_panel, dpi)
        fig.suptitle("stylize: the deepest point below the input's floor beyond the input's own "
                     "depth, at its worst frame before (red ring; brown: the floor; the target "
                     "is 0.5% of body height)", fontsize=12, y=0.99)
        fig.tight_layout(rect=(0, 0.01, 1, 0.93), w_pad=1.0)
    else:
        fig = _panel_row(builds, labels, _clean_panel, dpi)
        fig.suptitle("denoise: the guards' change to clean clips, at the worst frame before "
                     "(orange, wide: unguarded denoise; blue: guarded; red ring: the joint the "
                     "guards moved most;\n▲ toe tips; brown: the input's floor; the target is "
                     "0.5% of body height)", fontsize=12, y=0.99)
        fig.tight_layout(rect=(0, 0.01, 1, 0.93), w_pad=1.0)
    fig.savefig(out_png, dpi=dpi)
    return fig


def _print_cases(builds, labels):
    for b, lab in zip(builds, labels):
        for c in b:
            H = c["H"]
            if c["kind"] == "pop":
                print(f"{lab}: {c['clip']} stylize {c['alpha']:g}: pop ratio {c['ratio']:.2f} "
                      f"(frame {c['frame']}, {c['names'][c['point']]}: "
                      f"{100 * float(np.max(c['accel'])) / H:.2f}% H; input "
                      f"{100 * c['a_in'] / H:.2f}%, unguarded {100 * c['a_ref'] / H:.2f}%)")
            elif c["kind"] == "floor":
                t, k = np.unravel_index(int(np.argmax(c["excess"])), c["excess"].shape)
                print(f"{lab}: {c['clip']} stylize {c['alpha']:g}: {_point_name(c, int(k))} "
                      f"{max(0.0, float(c['excess'][t, k])):.2f}% H below the floor at frame {t}")
            else:
                t, j = np.unravel_index(int(np.argmax(c["change"])), c["change"].shape)
                print(f"{lab}: {c['clip']} denoise: guards moved {c['names'][j]} "
                      f"{c['change'][t, j]:.2f}% H at frame {t}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("clip", nargs="*", help="BVH clip(s); one for the worst frames and --pop")
    ap.add_argument("--op", default="stylize", choices=["stylize", "denoise"])
    ap.add_argument("--alpha", type=float, default=3.0)
    ap.add_argument("--pop", type=float, metavar="ALPHA",
                    help="foot pops of stylize at ALPHA (frames around the largest)")
    ap.add_argument("--clean", action="store_true",
                    help="denoise guarded against unguarded, at the largest change")
    ap.add_argument("--floor", type=float, metavar="ALPHA",
                    help="stylize at ALPHA: the deepest joint or End Site below the floor")
    ap.add_argument("--save", metavar="NPZ",
                    help="with --pop / --clean / --floor: save, do not draw")
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"),
                    help="draw two files saved by --save")
    ap.add_argument("-o", "--out", default="worst.png")
    ap.add_argument("--dpi", type=int, default=None)
    a = ap.parse_args(argv)
    if a.compare:
        builds = [load_cases(f) for f in a.compare]
        if a.clip or a.pop is not None or a.clean or a.save:
            ap.error("--compare takes two saved files and -o only")
        draw_cases(builds, ["before", "after"], a.out, a.dpi or 100)
        _print_cases(builds, ["before", "after"])
        return 0
    if a.pop is not None or a.clean or a.floor is not None:
        if (a.pop is not None) + a.clean + (a.floor is not None) > 1:
            ap.error("--pop, --clean and --floor are separate figures")
        if not a.clip or (a.pop is not None and len(a.clip) != 1):
            ap.error("--pop takes one clip, --clean and --floor one or more")
        cases = ([measure_pop(a.clip[0], a.pop)] if a.pop is not None
                 else [measure_floor(c, a.floor) for c in a.clip] if a.floor is not None
                 else [measure_clean(c) for c in a.clip])
        if a.save:
            save_cases(cases, a.save)
        else:
            draw_cases([cases], [f"mlayer {mlayer.__version__}"], a.out, a.dpi or 100)
        _print_cases([cases], ["this build"])
        return 0
    if len(a.clip) != 1:
        ap.error("one clip")
    rows = render(a.clip[0], a.op, a.alpha, a.out, a.dpi or 90)
    for row in rows or []:
        print(f"{row[0]}: frame {row[1]}: {row[3]} -> guarded {row[4]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
