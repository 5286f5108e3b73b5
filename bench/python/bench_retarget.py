"""Retargeting between rigs: mlayer.retarget against the naive copy of local rotations, on every
pair of eight rigs (CMU, LaFAN1, Bandai from the shared clips; Mixamo, Xsens and Axis Neuron from
a corpus folder given as an argument; SMPL's neutral body and MakeHuman's CC0 rig as targets
only).

    python bench/python/bench_retarget.py --corpus DIR [--mocap DIR] [--frames N]
                                          [--figure docs/img/retarget.png] [--proportions]

Per pair A -> B (A a clip, B another rig's skeleton):
  - round trip: A -> B -> A against A, joint positions of A's joints whose role B has too
    (mlayer.retarget_roles), mean and 95th percentile over frames and joints, in % of A's body
    height (the B leg-length scaling is undone by the way back);
  - bones: mean angle between the world directions of the limb bones (upper and lower legs and
    arms, shoulders) of B and of A (B's world turned into A's by the rest poses' body frames);
  - sliding: mean horizontal speed of the feet (the ankle roles) in A's contact frames
    (mlayer.detect_contacts on A), in leg lengths per second, for A and for A -> B;
  - floor: defined here, not by the code under test: A's floor is the 5th percentile over all
    of A's frames of its lowest foot point (ankle and toe roles and their End Sites) along A's
    up; B's floor is A's scaled by the leg lengths' ratio s about the origin and turned into B's
    world, as mlayer.retarget scales the root translation (the soles' height above the floor is
    the retarget's to get right, so nothing of B's placement enters it). Penetration: the
    deepest point of B's feet below B's floor in % of B's body height, and A's below its own
    in % of A's; hovering: the median height of B's lowest foot point above its floor on A's
    contact frames, less A's own above A's floor, in % of body height;
  - reversals: knee and elbow frames bent more than 15 degrees in both A and B whose bend axes
    (upper bone x lower bone, B's turned into A's world) point opposite ways.
"bones" is mlayer.retarget(feet=False): the bones alone, no contact cleanup. The naive copy:
B's joint of each role takes the local rotation of A's joint of that role (the
best a copy by name can do across rigs that name joints differently), B's hips take A's hips'
world position unchanged, other joints stay at rest.

--proportions prints, for every BVH file of the corpus and the shared clips, the arms' and the
torso's lengths over the legs' that mlr_retarget_roles uses to tell a humanoid from a quadruped
(or the error it gives).
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import warnings

import numpy as np

import mlayer
from benchutil import REPO, mocap_dir

RIGS = [  # (name, folder key, file, first frame, up)
    ("CMU", "mocap", "cmu_131_01_mj_style_walk.bvh", 0),
    ("LaFAN1", "mocap", "lafan1_clip_a.bvh", 0),
    ("Bandai", "mocap", "bandai1_walk_happy_001.bvh", 0),
    ("Mixamo", "corpus", "mixamo_joe_walk_in_circle.bvh", 0),
    ("Xsens", "corpus", "ammr_xsens_s01_trial01.bvh", 0),
    ("AxisNeuron", "corpus", "ammr_neuron_sit_stand3_chr00.bvh", 0),
]
#: targets only: MakeHuman's rig (CC0; its clip is 14 frames) and SMPL's (smpl_skeleton)
MAKEHUMAN = "makehuman_walk1_zup.bvh"
LIMBS = [("LeftUpperLeg", "LeftLowerLeg"), ("LeftLowerLeg", "LeftFoot"),
         ("RightUpperLeg", "RightLowerLeg"), ("RightLowerLeg", "RightFoot"),
         ("LeftShoulder", "LeftUpperArm"), ("LeftUpperArm", "LeftLowerArm"),
         ("LeftLowerArm", "LeftHand"), ("RightShoulder", "RightUpperArm"),
         ("RightUpperArm", "RightLowerArm"), ("RightLowerArm", "RightHand")]
HINGES = [("LeftUpperLeg", "LeftLowerLeg", "LeftFoot"),
          ("RightUpperLeg", "RightLowerLeg", "RightFoot"),
          ("LeftUpperArm", "LeftLowerArm", "LeftHand"),
          ("RightUpperArm", "RightLowerArm", "RightHand")]


def smpl_skeleton() -> mlayer.Skeleton:
    from mlayer.io import smpl
    names, parents, off = smpl.tree(False)
    order = mlayer.model.motion.depth_first_order(parents, names)
    inv = {int(o): k for k, o in enumerate(order)}
    return mlayer.Skeleton([names[o] for o in order],
                           [-1 if parents[o] < 0 else inv[parents[o]] for o in order],
                           np.asarray(off)[order])


def rest_positions(sk) -> np.ndarray:
    pos = np.zeros((sk.n_joints, 3))
    for j in range(1, sk.n_joints):
        pos[j] = pos[sk.parents[j]] + sk.offsets[j]
    return pos


def role_index(sk) -> dict[str, int]:
    return {r: sk.joint_names.index(n) for r, n in mlayer.retarget_roles(sk).items()}


def body_frame(sk) -> np.ndarray:
    r, rp = role_index(sk), rest_positions(sk)
    up = rp[r["Head"]] - rp[r["Hips"]]
    up /= np.linalg.norm(up)
    left = rp[r["LeftUpperLeg"]] - rp[r["RightUpperLeg"]]
    left -= left @ up * up
    left /= np.linalg.norm(left)
    up, left = snap(up), snap(left)
    return np.column_stack([left, up, np.cross(left, up)])


def snap(v: np.ndarray) -> np.ndarray:
    """The signed world axis nearest v."""
    out = np.zeros(3)
    k = int(np.argmax(np.abs(v)))
    out[k] = np.sign(v[k])
    return out


def world_frame(sk, up: str) -> np.ndarray:
    """The world frame of mlr_retarget.h: the rest body frame, or, where the world's up is
    another axis than the rest's, that up with the rest's left where level, else its forward."""
    body = body_frame(sk)
    k = "xyz".index(up)
    if abs(body[k, 1]) > 0.5:
        return body
    u = np.eye(3)[k]
    if abs(body[k, 0]) < 0.5:
        return np.column_stack([body[:, 0], u, np.cross(body[:, 0], u)])
    return np.column_stack([np.cross(u, body[:, 2]), u, body[:, 2]])


def leg_length(sk) -> float:
    r, rp = role_index(sk), rest_positions(sk)
    return float(np.mean([np.linalg.norm(rp[r[f"{s}UpperLeg"]] - rp[r[f"{s}LowerLeg"]])
                          + np.linalg.norm(rp[r[f"{s}LowerLeg"]] - rp[r[f"{s}Foot"]])
                          for s in ("Left", "Right")]))


def naive_copy(a: mlayer.Motion, target) -> mlayer.Motion:
    sk = target.skeleton if isinstance(target, mlayer.Motion) else target
    ra, rb = role_index(a.skeleton), role_index(sk)
    N = a.n_frames
    rot = np.zeros((N, sk.n_joints, 4))
    rot[..., 0] = 1.0
    for role, j in rb.items():
        if role in ra:
            rot[:, j] = a.rot[:, ra[role]]
    trans = np.tile(sk.offsets[sk.trans_joints], (N, 1, 1))
    hips = a.positions()[:, ra["Hips"]]
    root = np.tile(sk.offsets[0], (N, 1))
    hb = rb["Hips"]
    if hb == 0:
        root = hips.copy()
    elif hb in sk.trans_joints.tolist():
        trans[:, sk.trans_joints.tolist().index(hb)] = hips  # root at rest, unrotated
    else:
        root = root + hips - rest_positions(sk)[hb] - sk.offsets[0]
    out = mlayer.Motion(sk, a.frame_time, root, rot, trans)
    out.up_axis = target.up_axis if isinstance(target, mlayer.Motion) else "y"
    return out


def foot_points(m: mlayer.Motion, pos: np.ndarray) -> np.ndarray:
    """(N, K, 3) the feet: ankle and toe roles and their End Sites."""
    sk, r = m.skeleton, role_index(m.skeleton)
    joints = [r[k] for k in ("LeftFoot", "RightFoot", "LeftToes", "RightToes") if k in r]
    pts = [pos[:, j] for j in joints]
    wrot = m.world_rotations()
    for e, j in enumerate(sk.end_site_parents.tolist()):
        if j in joints:
            off = np.concatenate([np.zeros((len(pos), 1)), np.tile(sk.end_site_offsets[e],
                                                                   (len(pos), 1))], axis=1)
            q = wrot[:, j]
            pts.append(pos[:, j] + mlayer.quat.mul(mlayer.quat.mul(q, off),
                                                   mlayer.quat.conj(q))[:, 1:])
    return np.stack(pts, axis=1)


def hinge_normals(m: mlayer.Motion, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 4, 3) the bend normals (upper bone x lower bone) of the knees and elbows and (N, 4)
    their bend angles in degrees (zero where the rig lacks the joints)."""
    r = role_index(m.skeleton)
    normals, angles = [], []
    for a, b, c in HINGES:
        if not all(k in r for k in (a, b, c)):
            normals.append(np.zeros((len(pos), 3))), angles.append(np.zeros(len(pos)))
            continue
        d1, d2 = pos[:, r[b]] - pos[:, r[a]], pos[:, r[c]] - pos[:, r[b]]
        normals.append(np.cross(d1, d2))
        cos = np.einsum("ij,ij->i", d1, d2) / np.linalg.norm(d1, axis=1) \
            / np.linalg.norm(d2, axis=1)
        angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.stack(normals, 1), np.stack(angles, 1)


def measure(a: mlayer.Motion, target, method) -> dict[str, float]:
    b = method(a, target)
    back = method(b, a)
    sk_b = b.skeleton
    pa, pb, pback = a.positions(), b.positions(), back.positions()
    ra, rb = role_index(a.skeleton), role_index(sk_b)
    h_a = mlayer.metrics.body_height(a)
    upk = "xyz".index(a.up_axis)
    G = world_frame(a.skeleton, a.up_axis) @ world_frame(sk_b, b.up_axis).T  # B world -> A
    # round trip over A's joints whose role B has (a chain: B has one of its kind)
    kinds = {k.rstrip("0123456789") for k in rb}
    keep = [j for k, j in ra.items() if k in rb or (k[-1].isdigit() and k.rstrip("0123456789")
                                                     in kinds)]
    err = np.linalg.norm(pback[:, keep] - pa[:, keep], axis=-1) / h_a * 100
    # bone directions
    angles = []
    for x, y in LIMBS:
        if all(k in ra and k in rb for k in (x, y)):
            da = pa[:, ra[y]] - pa[:, ra[x]]
            db = (pb[:, rb[y]] - pb[:, rb[x]]) @ G.T
            cos = np.einsum("ij,ij->i", da, db) / np.linalg.norm(da, axis=1) \
                / np.linalg.norm(db, axis=1)
            angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    # contacts of A: its ankle roles
    names, contacts = mlayer.detect_contacts(a)
    feet = [ra["LeftFoot"], ra["RightFoot"]]
    cmask = np.zeros((a.n_frames, 2), dtype=bool)
    for c, n in enumerate(names):
        base = n.split("/")[0]
        if base in a.joint_names:
            j = a.joint_names.index(base)
            for s, fj in enumerate(feet):
                if j == fj or a.skeleton.parents[j] == fj:
                    cmask[:, s] |= contacts[:, c]
    fps = a.fps

    def sliding(pos, idx, leg, up_axis):
        horiz = [k for k in range(3) if k != up_axis]
        p = pos[:, idx][:, :, horiz]
        v = np.linalg.norm(np.diff(p, axis=0), axis=-1) * fps / leg
        both = cmask[1:] & cmask[:-1]
        return float(v[both].mean()) if both.any() else float("nan")

    leg_a, leg_b = leg_length(a.skeleton), leg_length(sk_b)
    up_b = int(np.argmax(np.abs(G.T[:, upk])))  # B's axis that A's up maps to
    slide_a = sliding(pa, feet, leg_a, upk)
    slide_b = sliding(pb, [rb["LeftFoot"], rb["RightFoot"]], leg_b, up_b)
    # floor: A's own (the 5th percentile of its lowest foot point over all its frames), scaled
    fa = foot_points(a, pa)[..., upk].min(axis=1)
    in_contact = cmask.any(axis=1)
    floor_a = float(np.percentile(fa, 5))
    s = leg_b / leg_a
    sign_b = np.sign(G.T[up_b, upk])
    fb = sign_b * foot_points(b, pb)[..., up_b].min(axis=1)
    h_b = mlayer.metrics.body_height(b, up="xyz"[up_b])
    pen = float(np.max(np.maximum(s * floor_a - fb, 0.0))) / h_b * 100
    pen_a = float(np.max(np.maximum(floor_a - fa, 0.0))) / h_a * 100
    # hovering: how far B's lowest foot point is above the scaled floor on A's contact frames
    # (median), less A's own above its floor
    frames = in_contact if in_contact.any() else np.ones(len(fa), dtype=bool)
    hover = float(np.median(fb[frames] - s * floor_a)) / h_b * 100 \
        - float(np.median(fa[frames] - floor_a)) / h_a * 100
    # hinge reversals: bent more than 15 degrees in both, about opposite axes
    na, aa = hinge_normals(a, pa)
    nb, ab = hinge_normals(b, pb @ G.T)
    bent = (aa > 15) & (ab > 15)
    rev = int(np.sum(bent & (np.einsum("ijk,ijk->ij", na, nb) < 0)))
    return {"rt_mean": float(err.mean()), "rt_p95": float(np.percentile(err, 95)),
            "bone_deg": float(np.mean(angles)), "slide_a": slide_a, "slide_b": slide_b,
            "pen_a": pen_a, "pen_b": pen, "hover": hover, "reversals": rev, "b": b}


def figure(path: pathlib.Path, a: mlayer.Motion, ours: mlayer.Motion, naive: mlayer.Motion,
           title: str, rig: str) -> None:
    """Side views (forward to the right, up) of 6 frames, one row per motion, each frame's hips
    at its own place along the row (joints above the hips, a static root, not drawn)."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=(10, 6.6))
    frames = np.linspace(0, a.n_frames - 1, 6).astype(int)
    for row, (m, name) in enumerate([(a, "source (CMU rig)"),
                                     (ours, f"mlayer.retarget ({rig} rig)"),
                                     (naive, f"naive copy of local rotations ({rig} rig)")]):
        ax = fig.add_subplot(3, 1, row + 1)
        r = role_index(m.skeleton)
        q = m.positions() @ world_frame(m.skeleton, m.up_axis)  # (left, up, forward)
        hips = r["Hips"]
        q[..., 1] -= np.median(q[:, :, 1].min(axis=1))  # the feet's usual level at 0
        height = np.percentile(q[:, :, 1].max(axis=1), 90)
        par = m.skeleton.parents
        above = {j for j in range(m.n_joints) if j != hips and _descends(m.skeleton, hips, j)}
        for k, f in enumerate(frames):
            x0 = k * 1.1 * height - q[f, hips, 2]
            for j in range(1, m.n_joints):
                if j in above or par[j] in above:
                    continue
                ax.plot([q[f, j, 2] + x0, q[f, par[j], 2] + x0], [q[f, j, 1], q[f, par[j], 1]],
                        color=f"C{row}", lw=1.4)
            ax.text(k * 1.1 * height, -0.12 * height, f"frame {f}", ha="center", fontsize=7)
        ax.axhline(0, color="0.6", lw=0.6)
        ax.set_aspect("equal")
        ax.set_title(name, fontsize=9)
        ax.set_xticks([]), ax.set_yticks([])
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def _descends(sk, j: int, a: int) -> bool:
    """Whether joint j is a or below it."""
    while j >= 0:
        if j == a:
            return True
        j = sk.parents[j]
    return False


def proportions(files: list[pathlib.Path]) -> int:
    """The arms (upper + lower arm) and the torso (hips to the upper arms' middle) over the legs
    (upper + lower leg), rest lengths, of each rig mlayer.retarget_roles accepts; the error of
    the others. Then the range over the accepted rigs."""
    arms, torsos = [], []
    for path in files:
        try:
            sk = mlayer.read_bvh(path).skeleton
            r, rp = role_index(sk), rest_positions(sk)
        except mlayer.Error as e:
            print(f"{path.name:45s} refused: {str(e).splitlines()[0][:150]}")
            continue

        def d(x, y):
            return float(np.linalg.norm(rp[r[x]] - rp[r[y]]))
        leg = np.mean([d(f"{s}UpperLeg", f"{s}LowerLeg") + d(f"{s}LowerLeg", f"{s}Foot")
                       for s in ("Left", "Right")])
        arm = np.mean([d(f"{s}UpperArm", f"{s}LowerArm") + d(f"{s}LowerArm", f"{s}Hand")
                       for s in ("Left", "Right")])
        mid = 0.5 * (rp[r["LeftUpperArm"]] + rp[r["RightUpperArm"]])
        torso = float(np.linalg.norm(mid - rp[r["Hips"]]))
        arms.append(arm / leg), torsos.append(torso / leg)
        print(f"{path.name:45s} arms/legs {arm / leg:.2f}  torso/legs {torso / leg:.2f}")
    if arms:
        print(f"# accepted: {len(arms)} files; arms/legs {min(arms):.2f} to {max(arms):.2f}, "
              f"torso/legs {min(torsos):.2f} to {max(torsos):.2f}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--corpus", type=pathlib.Path, required=True,
                    help="folder with the Mixamo, Xsens and Axis Neuron clips")
    ap.add_argument("--mocap", type=pathlib.Path, default=mocap_dir(),
                    help="the shared clips (default: ../shared/data/mocap)")
    ap.add_argument("--frames", type=int, default=600, help="frames of each clip (default 600)")
    ap.add_argument("--figure", type=pathlib.Path, default=None,
                    help="write the side-by-side figure (CMU -> Bandai) here")
    ap.add_argument("--proportions", action="store_true",
                    help="print the arms' and torso's lengths over the legs' of every rig")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    if args.proportions:
        return proportions(sorted(args.corpus.glob("*.bvh")) + sorted(args.mocap.glob("*.bvh")))
    clips = {}
    for name, key, file, first in RIGS:
        folder = args.mocap if key == "mocap" else args.corpus
        path = folder / file
        if not path.exists():
            print(f"# {name}: {path} not found, left out", file=sys.stderr)
            continue
        clips[name] = mlayer.read_bvh(path)[first:first + args.frames]
    # the targets as motions, so that their world up (Motion.up_axis) is known: LaFAN1's and
    # Bandai's bind poses lie along x; SMPL's template is Y-up
    targets: dict = dict(clips)
    targets["SMPL"] = smpl_skeleton()
    if (args.corpus / MAKEHUMAN).exists():
        targets["MakeHuman"] = mlayer.read_bvh(args.corpus / MAKEHUMAN)
    cols = ("rt_mean", "rt_p95", "bone_deg", "slide_a", "slide_b", "pen_a", "pen_b", "hover",
            "reversals")
    print("method  A -> B  " + "  ".join(cols))
    rows: dict[str, list] = {"retarget": [], "bones": [], "naive": []}

    def ours(m, target):
        return mlayer.retarget(m, target, target_up=None if isinstance(target, mlayer.Motion)
                               else "y")

    def bones_only(m, target):
        return mlayer.retarget(m, target, feet=False,
                               target_up=None if isinstance(target, mlayer.Motion) else "y")
    for an, a in clips.items():
        for bn, sk in targets.items():
            if an == bn:
                continue
            for meth, fn in (("retarget", ours), ("bones", bones_only),
                             ("naive", naive_copy)):
                r = measure(a, sk, fn)
                rows[meth].append(r)
                print(f"{meth:8s} {an}->{bn}  " + "  ".join(
                    f"{r[c]:.3g}" if isinstance(r[c], float) else str(r[c]) for c in cols))
    for meth, rs in rows.items():
        arr = {c: np.array([r[c] for r in rs], dtype=float) for c in cols}
        print(f"# {meth}: {len(rs)} pairs; round trip mean {np.nanmean(arr['rt_mean']):.3g}% "
              f"(worst pair {np.nanmax(arr['rt_mean']):.3g}%), p95 worst "
              f"{np.nanmax(arr['rt_p95']):.3g}%; bones {np.nanmean(arr['bone_deg']):.3g} deg "
              f"(worst {np.nanmax(arr['bone_deg']):.3g}); sliding above the source's in "
              f"{int(np.sum(arr['slide_b'] > arr['slide_a'] * 1.0001))} pairs "
              f"(worst ratio {np.nanmax(arr['slide_b'] / arr['slide_a']):.3g}); penetration "
              f"worst {np.nanmax(arr['pen_b']):.3g}% (pairs above 0.5%: "
              f"{int(np.sum(arr['pen_b'] > 0.5))}); hovering median "
              f"{np.nanmedian(arr['hover']):.3g}% (range {np.nanmin(arr['hover']):.3g} to "
              f"{np.nanmax(arr['hover']):.3g}); reversal frames "
              f"{int(np.nansum(arr['reversals']))}")
    if args.figure and "CMU" in clips and "MakeHuman" in targets:
        # the figure's rigs must be free to redistribute: CMU's data and MakeHuman's CC0 rig
        a = clips["CMU"]
        figure(args.figure, a, mlayer.retarget(a, targets["MakeHuman"]),
               naive_copy(a, targets["MakeHuman"]),
               "CMU 131_01 walk onto the MakeHuman rig (CC0): source, mlayer.retarget, naive copy",
               "MakeHuman")
        shown = args.figure.relative_to(REPO) if args.figure.is_absolute() else args.figure
        print(f"# figure: {shown}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
