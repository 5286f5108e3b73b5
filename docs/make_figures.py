"""Make the figures of the documentation's paper pages from the bundled clip (CMU 131_01).

    python docs/make_figures.py [OUT_DIR]       (default: docs/img)

Each figure is drawn by mlayer itself (its plot functions, or matplotlib over its results), so
the pages show what this version computes. The PNGs are committed (each well under 300 KB);
run this again when a computation they show changes.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import mlayer
from mlayer.plotting import plot as mplot
from mlayer.plotting.plot import plot_elbow, plot_som, plot_transitions


def _angle_deg(q: np.ndarray) -> np.ndarray:
    """Rotation angle of unit quaternions (..., 4), in degrees."""
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(q[..., 0]), 0.0, 1.0)))


def layers_figure(m: mlayer.Motion, out: Path) -> None:
    """Paper 1, Figures 1 and 2: one root channel and one joint through the layers."""
    layers = mlayer.decompose(m)
    mplot.plot_layers(m, layers, out / "layers.png", title="CMU 131_01: layers")


def stylize_figure(m: mlayer.Motion, out: Path) -> None:
    """Paper 1, Figure 1 and section 5.2: base (alpha 0), denoised (1) and exaggerated (2)."""
    up = "xyz".index(m.up_axis)
    knee = m.joint_names.index("LeftKnee") if "LeftKnee" in m.joint_names else 1
    fig = mplot.new_figure("docs.stylize", figsize=(9, 5.5))
    ax = fig.subplots(2, 1, sharex=True)
    t = np.arange(m.n_frames) / m.fps
    ax[0].plot(t, m.root_pos[:, up], color="0.55", lw=2.2, label="original")
    ax[1].plot(t, _angle_deg(m.rot[:, knee]), color="0.55", lw=2.2, label="original")
    for alpha, color in ((0.0, "tab:blue"), (1.0, "tab:green"), (2.0, "tab:red")):
        s = mlayer.stylize(m, alpha)
        ax[0].plot(t, s.root_pos[:, up], color=color, lw=1.0, label=f"alpha {alpha:g}")
        ax[1].plot(t, _angle_deg(s.rot[:, knee]), color=color, lw=1.0, label=f"alpha {alpha:g}")
    ax[0].set_ylabel(f"root height ({m.up_axis})")
    ax[1].set_ylabel(f"{m.joint_names[knee]} angle (deg)")
    ax[1].set_xlabel("time (s)")
    ax[0].legend(loc="best", fontsize=8, ncol=4)
    ax[0].set_title("mlayer.stylize: alpha 0 (base), 1 (denoised), 2 (exaggerated), guards on")
    mplot.save_figure(fig, out / "stylize.png")


def resample_figure(m: mlayer.Motion, out: Path) -> None:
    """Paper 1, Figure 8: sparse keys through the LGS against SLERP."""
    step = 15  # keys at 8 fps
    keys = m[::step]
    lgs = mlayer.resample(keys, n_frames=(keys.n_frames - 1) * step + 1)
    slerp = mlayer.slerp_resample(keys, n_frames=lgs.n_frames)
    j = m.joint_names.index("LeftKnee") if "LeftKnee" in m.joint_names else 1
    fig = mplot.new_figure("docs.resample", figsize=(9, 3.8))
    ax = fig.subplots(1, 1)
    t = np.arange(m.n_frames) / m.fps
    tk = np.arange(lgs.n_frames) * step / (m.fps * (lgs.n_frames - 1) / (keys.n_frames - 1))
    ax.plot(t, _angle_deg(m.rot[:, j]), color="0.7", lw=2.2, label=f"original ({m.fps:g} fps)")
    ax.plot(tk, _angle_deg(slerp.rot[:, j]), color="tab:orange", lw=1.0,
            label="SLERP of the keys")
    ax.plot(tk, _angle_deg(lgs.rot[:, j]), color="tab:blue", lw=1.2,
            label="mlayer.resample (LGS)")
    ax.plot(np.arange(keys.n_frames) * step / m.fps, _angle_deg(keys.rot[:, j]), "ko", ms=3,
            label=f"keys (every {step}th frame)")
    ax.set_xlim(0, 4)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{m.joint_names[j]} angle (deg)")
    ax.legend(loc="best", fontsize=8)
    mplot.save_figure(fig, out / "resample.png")


def timewarp_figure(m: mlayer.Motion, out: Path) -> None:
    """Paper 1, Figure 9: the root height before and after the automatic time warp."""
    warped, tmap = mlayer.timewarp(m, strength=1.5, return_map=True)
    up = "xyz".index(m.up_axis)
    fig = mplot.new_figure("docs.timewarp", figsize=(9, 5.5))
    ax = fig.subplots(2, 1)
    ax[0].plot(np.arange(m.n_frames), m.root_pos[:, up], color="tab:blue", label="original")
    ax[0].plot(np.arange(warped.n_frames), warped.root_pos[:, up], color="tab:red",
               label="time-warped (strength 1.5)")
    ax[0].set_xlabel("frame")
    ax[0].set_ylabel(f"root height ({m.up_axis})")
    ax[0].legend(loc="best", fontsize=8)
    ax[1].plot(np.arange(len(tmap)), tmap, color="k", lw=1.0)
    ax[1].set_xlabel("output frame")
    ax[1].set_ylabel("input frame (time map)")
    mplot.save_figure(fig, out / "timewarp.png")


def _angle_between_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle of the rotation from a to b (unit quaternions (..., 4)), in degrees."""
    d = mlayer.quat.mul(mlayer.quat.conj(a), b)
    return np.degrees(2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0])))


def spin_through_pi(m: mlayer.Motion, joint: str = "LeftShoulder", noise: float = 0.03,
                    seed: int = 0) -> tuple[mlayer.Motion, int, np.ndarray, np.ndarray]:
    """The clip with one joint turning about a fixed axis through pi and back (its angle
    pi + 0.45 pi sin(2 pi 0.4 t)), plus rotation noise of `noise` rad per axis: the clip, the
    joint, its true rotations and the axis."""
    j = m.joint_names.index(joint) if joint in m.joint_names else 1
    t = np.arange(m.n_frames) / m.fps
    theta = np.pi + 0.45 * np.pi * np.sin(2 * np.pi * 0.4 * t)
    axis = np.array([0.0, 0.6, 0.8])
    truth = mlayer.quat.exp(theta[:, None] * axis)
    rng = np.random.default_rng(seed)
    rot = m.rot.copy()
    rot[:, j] = mlayer.quat.mul(truth, mlayer.quat.exp(rng.normal(0, noise, (m.n_frames, 3))))
    return m.with_frames(rot=rot), j, truth, axis


def expmap_figure(m: mlayer.Motion, out: Path) -> dict:
    """Paper 1, Figure 6: the base layer in quaternions against the exponential map, on a joint
    that turns through pi (the same LGS strength, lam_b = 90: about a 2 Hz cutoff at 120 fps)."""
    c, j, truth, axis = spin_through_pi(m)
    layers = mlayer.decompose(c, lam_b=90.0, sigma_b=1.0)
    qb, eb = layers.base.rot[:, j], mlayer.expmap_base(c, layers).rot[:, j]
    err_q, err_e = _angle_between_deg(qb, truth), _angle_between_deg(eb, truth)
    jump = {name: float(_angle_between_deg(q[1:], q[:-1]).max())
            for name, q in (("truth", truth), ("quat", qb), ("expmap", eb))}

    def about_axis(q):  # the signed angle about the spin axis, unwrapped, degrees
        return np.degrees(np.unwrap(2 * np.arctan2(q[:, 1:] @ axis, q[:, 0])))
    t = np.arange(c.n_frames) / c.fps
    fig = mplot.new_figure("docs.expmap", figsize=(9, 5.5))
    ax = fig.subplots(2, 1, sharex=True)
    ax[0].plot(t, about_axis(c.rot[:, j]), color="0.75", lw=2.2, label="noisy input")
    ax[0].plot(t, about_axis(truth), color="tab:blue", lw=1.0, label="ground truth")
    ax[0].plot(t, about_axis(qb), color="tab:green", lw=1.0, label="quaternion base layer")
    ax[0].plot(t, about_axis(eb), color="tab:red", lw=1.0, label="exp-map base layer")
    ax[0].axhline(180, color="k", lw=0.5, ls=":")
    ax[0].set_ylabel(f"{c.joint_names[j]} angle (deg)")
    ax[0].legend(loc="lower right", fontsize=8, ncol=2)
    ax[1].semilogy(t, np.maximum(err_q, 1e-3), color="tab:green", lw=1.0,
                   label=f"quaternion: max {err_q.max():.1f} deg")
    ax[1].semilogy(t, np.maximum(err_e, 1e-3), color="tab:red", lw=1.0,
                   label=f"exp map: max {err_e.max():.1f} deg")
    ax[1].set_ylabel("error to the truth (deg)")
    ax[1].set_xlabel("time (s)")
    ax[1].legend(loc="lower right", fontsize=8)
    ax[0].set_title("base layer of a joint turning through 180 degrees: quaternion vs exp map")
    mplot.save_figure(fig, out / "expmap_base.png")
    return {"max error quaternion (deg)": float(err_q.max()),
            "max error exp map (deg)": float(err_e.max()),
            "max step truth (deg/frame)": jump["truth"],
            "max step quaternion (deg/frame)": jump["quat"],
            "max step exp map (deg/frame)": jump["expmap"]}


#: MultiRes levels matched to the layers at 120 fps (low pass below about 0.5 Hz), and the gains:
#: the finest band (above 15 Hz, the noise) and the low pass kept, the bands between scaled
MULTIRES_LEVELS = 7


def multires_figure(m: mlayer.Motion, out: Path, alpha: float = 2.0) -> dict:
    """Paper 1, Figure 7: the walk exaggerated by the layers (alpha 2, no guards: the raw
    synthesis) and by MultiRes frequency bands at the same gain."""
    from mlayer.guards.metrics import body_height
    h = body_height(m)
    styl = mlayer.decompose(m).synthesize(alpha)
    gains = [1.0] + [alpha] * (MULTIRES_LEVELS - 1) + [1.0]
    mr = mlayer.multires_stylize(m, gains)
    p0, ps, pm = m.positions(), styl.positions(), mr.positions()

    def rms(a, b):
        return float(np.sqrt(((a - b) ** 2).sum(-1).mean()) / h)
    res = {"stylize vs input (body heights, RMS)": rms(ps, p0),
           "MultiRes vs input (body heights, RMS)": rms(pm, p0),
           "MultiRes vs stylize (body heights, RMS)": rms(pm, ps),
           "MultiRes vs stylize (body heights, max)":
               float(np.sqrt(((pm - ps) ** 2).sum(-1)).max() / h)}
    up = "xyz".index(m.up_axis)
    hand = m.joint_names.index("LeftWrist") if "LeftWrist" in m.joint_names else m.n_joints - 1
    t = np.arange(m.n_frames) / m.fps
    fig = mplot.new_figure("docs.multires", figsize=(9, 3.8))
    ax = fig.subplots(1, 1)
    ax.plot(t, p0[:, hand, up] / h, color="0.7", lw=2.2, label="original")
    ax.plot(t, ps[:, hand, up] / h, color="tab:red", lw=1.0, label=f"layers, alpha {alpha:g}")
    ax.plot(t, pm[:, hand, up] / h, color="tab:purple", lw=1.0,
            label=f"MultiRes, gain {alpha:g} on bands 1-{MULTIRES_LEVELS - 1}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{m.joint_names[hand]} height (body heights)")
    ax.set_title(f"exaggerated walk: layers vs MultiRes (RMS difference of the joints "
                 f"{res['MultiRes vs stylize (body heights, RMS)']:.3f} body heights)")
    ax.legend(loc="best", fontsize=8)
    mplot.save_figure(fig, out / "multires_stylize.png")
    return res


ALPHA_KEYS = "0:1,1.5:1,3:3,5:3,6.5:0,8:1"


def alpha_time_figure(m: mlayer.Motion, out: Path) -> dict:
    """Paper 1, section 6.2: alpha over time (an AlphaCurve), the curve and the left knee's
    angle against the constant alphas 1 and 3, guards on."""
    curve = mlayer.AlphaCurve(ALPHA_KEYS)
    knee = m.joint_names.index("LeftKnee") if "LeftKnee" in m.joint_names else 1
    t = np.arange(m.n_frames) / m.fps
    a = curve.sample(m.n_frames, m.fps)
    s = mlayer.Synthesis(m)
    keyed, rep = s.run(curve)
    const = {v: s.run(v)[0] for v in (0.0, 1.0, 3.0)}
    fig = mplot.new_figure("docs.alpha_time", figsize=(9, 5.5))
    ax = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [1, 2]})
    ax[0].plot(t, a, color="tab:purple", lw=1.6)
    ax[0].plot(curve.times, curve.values, "o", color="tab:purple", ms=5)
    ax[0].set_ylabel("alpha(t)")
    ax[0].set_title(f"mlayer.stylize(m, alpha=AlphaCurve('{ALPHA_KEYS}')), guards on")
    ang = {v: _angle_deg(x.rot[:, knee]) for v, x in const.items()}
    ax[1].plot(t, _angle_deg(m.rot[:, knee]), color="0.7", lw=2.2, label="original")
    ax[1].plot(t, ang[1.0], color="tab:green", lw=0.9, ls="--", label="alpha 1")
    ax[1].plot(t, ang[3.0], color="tab:red", lw=0.9, ls="--", label="alpha 3")
    ax[1].plot(t, _angle_deg(keyed.rot[:, knee]), color="tab:purple", lw=1.4,
               label="alpha(t)")
    ax[1].set_ylabel(f"{m.joint_names[knee]} angle (deg)")
    ax[1].set_xlabel("time (s)")
    ax[1].legend(loc="upper right", fontsize=8, ncol=4)
    mplot.save_figure(fig, out / "alpha_time.png")
    # what docs/layers.md quotes: on the stretches where the curve is flat, the keyed result
    # against the constant alpha's (degrees of the knee; the guards act on the whole clip)
    measured = {"limits applied": float(rep.limits_applied)}
    first = t < curve.times[1] + 1e-9
    for guards, syn in (("guards on", s), ("no contact guard", mlayer.Synthesis(
            m, keep_contacts=False)), ("no contact guard, no limits", mlayer.Synthesis(
            m, keep_contacts=False, limits=None))):
        k = _angle_deg(syn.run(curve)[0].rot[:, knee])
        for v, where in ((1.0, a == 1.0), (1.0, (a == 1.0) & first), (3.0, a == 3.0)):
            ref = _angle_deg(syn.run(v)[0].rot[:, knee])
            label = "first stretch" if where.sum() < (a == v).sum() else "every flat frame"
            measured[f"{guards}: knee vs alpha {v:g}, {label} ({where.sum()} frames), max deg"] \
                = float(np.abs(k[where] - ref[where]).max())
    return measured


def primitives_figures(m: mlayer.Motion, out: Path) -> None:
    """Paper 2, Figures 1-3: the SOM manifold, the elbow and the transition matrix."""
    model = mlayer.PrimitiveModel.fit(m, som=(20, 20), epochs=10, lattice=(10, 10), seed=0)
    plot_som(model, out / "som.png", title="SOM of CMU 131_01 with its primitives")
    plot_elbow(model, out / "elbow.png")
    plot_transitions(model, out / "transitions.png")


def main(argv: list[str]) -> int:
    """Write every figure into ``argv[0]`` (default: docs/img beside this script)."""
    out = Path(argv[0]) if argv else Path(__file__).resolve().parent / "img"
    out.mkdir(parents=True, exist_ok=True)
    m = mlayer.data.load_sample()
    for make in (layers_figure, stylize_figure, resample_figure, timewarp_figure,
                 expmap_figure, multires_figure, alpha_time_figure, primitives_figures):
        measured = make(m, out)
        for what, value in (measured or {}).items():  # the figures docs/layers.md quotes
            print(f"{make.__name__}: {what}: {value:.4g}")
    for png in sorted(out.glob("*.png")):
        print(f"{png.name}: {png.stat().st_size // 1024} KB")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
