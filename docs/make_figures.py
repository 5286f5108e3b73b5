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
from mlayer import plot as mplot
from mlayer.cli.primitives import plot_elbow, plot_som, plot_transitions


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
                 primitives_figures):
        make(m, out)
    for png in sorted(out.glob("*.png")):
        print(f"{png.name}: {png.stat().st_size // 1024} KB")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
