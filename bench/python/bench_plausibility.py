"""Plausibility of denoise / stylize output, with and without the guards (issue 18, item 7).

    python bench/python/bench_plausibility.py [--wild WILD] [--json out.json]
        [--alphas 0.5,2,3] [--clips PATTERN]

For every clip of ../shared/data/mocap (and every .bvh of --wild), for denoise and for
stylize at each alpha, runs the operation unguarded and guarded and prints one row per
(clip, operation, guards). Guards are requested with the planned keywords
``limits="auto", floor="auto", keep_contacts=True`` (see DESIGN.md "Plausibility guards");
only those that ``inspect.signature`` finds on the installed mlayer.stylize / mlayer.denoise
are passed, and the ``guards`` column names exactly those (today: contacts). The unguarded
row passes ``keep_contacts=False`` (and ``limits=None, floor=None`` where accepted).

Columns (definitions in plausibility.py's docstring; H = mlayer.metrics.body_height):
  knee_fold / elb_fold   frames where a knee / elbow folds past max(150 deg, input max + 10)
  knee_rev / elb_rev     frames where it bends the other way beyond the input's own
  floor_fr, floor_max%   frames with a foot point > 0.5 % H below the input's floor (where the
                         input's was not), and the deepest, in % of H
  keep_legs/arms/spine   RMS angle of output vs base layer / the same for the unguarded
                         synthesis (1.00 = all the exaggeration kept)
  slide_in, slide_out    mlayer.metrics.foot_sliding on the input's contacts, in H per second
  dpos%                  (denoise only) max joint displacement guarded vs unguarded, % of H
  bone%                  max relative bone-length change vs the input, %
  root_dev               max distance of the output root from the input root path, in H
  stEx                   largest swing/twist excess over the guards' ranges, degrees (the
                         contact cleanup's IK can take hips and ankles past them)
  t_* (ms)               decompose, synthesize, and each guard stage: the time of the API
                         call with that guard alone minus the unguarded call
Clips that cannot be processed (parse errors, fewer than 3 frames, ...) are listed with the
reason. The up column is the clip's Motion.up_axis, which the library and these measures
take as vertical; clips where plausibility.up_axis (hips above feet) finds another axis
are flagged.
"""
from __future__ import annotations

import argparse
import fnmatch
import inspect
import json
import math
import pathlib
import sys
import time

import numpy as np

import mlayer
from mlayer import contacts as C

import benchutil
import plausibility as P

GUARD_KW = {"limits": ("auto", None), "floor": ("auto", None), "keep_contacts": (True, False)}
GUARD_LABEL = {"limits": "limits", "floor": "floor", "keep_contacts": "contacts"}


def accepted_guards(fn) -> list[str]:
    """The guard keywords of GUARD_KW that fn's signature accepts."""
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return []
    return [k for k in GUARD_KW if k in params]


def _kw(guards, on: set[str]) -> dict:
    return {k: (GUARD_KW[k][0] if k in on else GUARD_KW[k][1]) for k in guards}


def _call(op, m, alpha, kw):
    t0 = time.perf_counter()
    out = mlayer.denoise(m, **kw) if op == "denoise" else mlayer.stylize(m, alpha, **kw)
    return out, time.perf_counter() - t0


def measure_clip(m, alphas, name="") -> list[dict]:
    H = mlayer.metrics.body_height(m)
    up = m.up_axis.upper()
    up_check = P.up_axis(m).lstrip("-")
    chains = P.limb_chains(m)
    parts = P.body_parts(m, chains)
    fk_in = m.forward_kinematics()
    lim = mlayer.joint_limits(m)
    feet = P.foot_points(m)
    cn, cc = C.detect_contacts(m, feet) if feet else ([], None)
    floor = P.floor_level(m, feet, cc) if feet else float("nan")
    slide_in = (mlayer.metrics.foot_sliding(m, cc, cn) / H) if feet else float("nan")

    t0 = time.perf_counter()
    layers = mlayer.decompose(m)
    t_dec = time.perf_counter() - t0
    base = layers.base
    rows = []
    for op, alpha in [("denoise", 1.0)] + [("stylize", a) for a in alphas]:
        fn = mlayer.denoise if op == "denoise" else mlayer.stylize
        guards = accepted_guards(fn)
        t0 = time.perf_counter()
        raw = layers.synthesize(alpha)
        t_syn = time.perf_counter() - t0
        unguarded, t_un = _call(op, m, alpha, _kw(guards, set()))
        stage_t = {}
        for g in guards:
            _, t_g = _call(op, m, alpha, _kw(guards, {g}))
            stage_t[GUARD_LABEL[g]] = max(0.0, t_g - t_un)
        guarded, _ = _call(op, m, alpha, _kw(guards, set(guards)))
        rms_raw = {k: P.rms_angle(raw.rot, base.rot, v) for k, v in parts.items()}
        fk_un = unguarded.forward_kinematics()
        for label, out, fk_out in (("none", unguarded, fk_un),
                                   ("+".join(GUARD_LABEL[g] for g in guards) or "none",
                                    guarded, None)):
            if label == "none" and out is guarded:
                continue
            fk_out = out.forward_kinematics() if fk_out is None else fk_out
            hr = P.hinge_report(m, out, chains, fk_in=fk_in, fk_out=fk_out)
            fl = P.floor_report(m, out, feet, floor, H) if feet else {
                "frames": 0, "deepest_pct": float("nan"), "worst": None}
            keep = {k: (P.rms_angle(out.rot, base.rot, v) / rms_raw[k]
                        if rms_raw[k] > 0 else float("nan")) for k, v in parts.items()}
            row = {
                "clip": name, "frames": m.n_frames, "fps": round(m.fps, 3), "up": up,
                "up_check": up_check,
                "H": H, "op": op if op == "denoise" else f"stylize {alpha:g}",
                "guards": label if out is guarded else "none",
                "guards_requested": "limits+floor+contacts",
                "knee_fold": hr["knee"]["fold_frames"], "elb_fold": hr["elbow"]["fold_frames"],
                "knee_rev": hr["knee"]["reversal_frames"],
                "elb_rev": hr["elbow"]["reversal_frames"],
                "worst_fold": hr["knee"]["worst_fold"] or hr["elbow"]["worst_fold"],
                "worst_reversal": hr["knee"]["worst_reversal"] or hr["elbow"]["worst_reversal"],
                "floor_frames": fl["frames"], "floor_max_pct": fl["deepest_pct"],
                "worst_floor": fl["worst"],
                "keep_legs": keep["legs"], "keep_arms": keep["arms"],
                "keep_spine": keep["spine_head"],
                "slide_in": slide_in,
                "slide_out": (mlayer.metrics.foot_sliding(out, cc, cn) / H) if feet
                else float("nan"),
                "dpos_pct": (100.0 * float(np.linalg.norm(fk_out[0] - fk_un[0], axis=-1).max())
                             / H) if op == "denoise" else float("nan"),
                "bone_pct": 100.0 * P.bone_length_change(fk_in[0], fk_out[0], m.parents, H),
                "root_dev": P.root_path_deviation(fk_in[0][:, 0], fk_out[0][:, 0]) / H,
                "st_excess": max(P.swing_twist_excess(lim, out.rot, alpha).values(),
                                 default=0.0),
                "t_decompose_ms": 1e3 * t_dec, "t_synthesize_ms": 1e3 * t_syn,
                "t_limits_ms": 1e3 * stage_t["limits"] if "limits" in stage_t else None,
                "t_contacts_ms": 1e3 * stage_t["contacts"] if "contacts" in stage_t else None,
                "t_floor_ms": 1e3 * stage_t["floor"] if "floor" in stage_t else None,
            }
            rows.append(row)
    return rows


COLS = [("clip", "{:<30.30}"), ("up", "{:>3}"), ("op", "{:<11}"), ("guards", "{:<8.8}"),
        ("knee_fold", "{:>5}"), ("knee_rev", "{:>5}"), ("elb_fold", "{:>5}"),
        ("elb_rev", "{:>5}"), ("floor_frames", "{:>5}"), ("floor_max_pct", "{:>6.2f}"),
        ("keep_legs", "{:>5.2f}"), ("keep_arms", "{:>5.2f}"), ("keep_spine", "{:>5.2f}"),
        ("slide_in", "{:>6.3f}"), ("slide_out", "{:>6.3f}"), ("dpos_pct", "{:>6.2f}"),
        ("bone_pct", "{:>6.2f}"), ("root_dev", "{:>6.3f}"), ("st_excess", "{:>5.1f}"),
        ("t_decompose_ms", "{:>6.0f}"),
        ("t_synthesize_ms", "{:>5.0f}"), ("t_limits_ms", "{:>5.0f}"),
        ("t_contacts_ms", "{:>5.0f}"), ("t_floor_ms", "{:>5.0f}")]
HEAD = ["clip", "up", "op", "guards", "kFold", "kRev", "eFold", "eRev", "flrFr", "flr%H",
        "kLeg", "kArm", "kSpn", "slIn", "slOut", "dpos%", "bone%", "rootH", "stEx", "tDec",
        "tSyn", "tLim", "tCon", "tFlr"]


def _width(fmt) -> int:
    spec = fmt.split(":")[1].rstrip("}").lstrip("<>").split(".")[0]
    return int(spec.rstrip("sdf"))


def _fmt(fmt, v):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-".rjust(_width(fmt))
    return fmt.format(v)


def print_table(rows, skipped, file=sys.stdout):
    widths = [_width(f) for _, f in COLS]
    print(" ".join(h.rjust(w) if i > 3 else h.ljust(w) for i, (h, w) in
                   enumerate(zip(HEAD, widths))), file=file)
    for r in rows:
        cells = []
        for (k, f), w in zip(COLS, widths):
            v = r[k]
            s = _fmt(f, v) if not isinstance(v, str) else f.format(v)
            cells.append(s.rjust(w) if not isinstance(v, str) else s)
        print(" ".join(cells), file=file)
    for name, why in skipped:
        print(f"skipped {name}: {why}", file=file)
    flagged = sorted({f"{r['clip']} ({r['up']}, hips above feet along {r['up_check']})"
                      for r in rows if r.get("up_check", r["up"]) != r["up"]})
    if flagged:
        print("up axis of the clip differs from the hips-above-feet estimate: "
              + ", ".join(flagged), file=file)


def clip_paths(wild, pattern):
    paths = sorted(benchutil.mocap_dir().glob("*.bvh"))
    if wild:
        paths += sorted(pathlib.Path(wild).glob("*.bvh"))
    return [p for p in paths if fnmatch.fnmatch(p.name, pattern)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wild", default=None, help="a folder of extra .bvh files")
    ap.add_argument("--json", default=None, help="write all rows (and worst frames) here")
    ap.add_argument("--alphas", default="0.5,2,3")
    ap.add_argument("--clips", default="*", help="file-name glob")
    a = ap.parse_args(argv)
    alphas = [float(x) for x in a.alphas.split(",")]
    rows, skipped = [], []
    print(f"mlayer {mlayer.__version__}; guards accepted: stylize "
          f"{accepted_guards(mlayer.stylize)}, denoise {accepted_guards(mlayer.denoise)}",
          flush=True)
    for p in clip_paths(a.wild, a.clips):
        try:
            m = mlayer.read_bvh(p)
            if m.n_frames < 3:
                raise mlayer.InvalidArgumentError(f"{m.n_frames} frame(s): too short to "
                                                  "decompose")
            rows += measure_clip(m, alphas, p.name)
        except mlayer.Error as e:
            skipped.append((p.name, f"{type(e).__name__}: {e}".replace(str(p.parent) + "/", "")))
        print(f"  done {p.name}", file=sys.stderr, flush=True)
    print_table(rows, skipped)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"mlayer": mlayer.__version__, "rows": rows, "skipped": skipped}, f,
                      indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
