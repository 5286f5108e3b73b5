"""`mlayer primitives` and `mlayer generate`: learn a motion manifold with primitives from clips,
then synthesize new motion from it (paper 2).

    mlayer primitives CLIPS... -o model.npz [--k auto|K] [--som RxC] [--pca] [--epochs 20]
                               [--lattice RxC] [--kernel thin_plate|gaussian] [--plots PREFIX]

The SOM and GRBF lattices default to sizes that scale with the training frames (30x30 and 15x15
from 900 frames on; see mlayer.primitives.default_lattices); clips in other units than the
first (body heights a factor of 2 or more apart) are scaled to its size, with a warning.
    mlayer generate model.npz --frames 300 [--start-frame T] [--noise S] [--seed N]
                              [--most-likely] [--no-guards] -o new.bvh

`primitives` writes, next to the model (or at --plots PREFIX): PREFIX_som.png (the lattice with
the first clip's trajectory and the primitive centres, like paper Figure 1), PREFIX_elbow.png
(inertia against k, when --k auto) and PREFIX_transitions.png (the transition matrix, like
Figure 3). `generate` applies the guards of the training clips (their contacts, joint limits
and floor; `--no-guards`: the raw mapping) and says what they did. Progress goes to stderr.
Bad input: one line on stderr and exit status 1.
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from .._files import atomic_output
from ..bvh import read_bvh, write_bvh
from ..errors import InvalidArgumentError
from ._command import BVH, NPZ, PREFIX, command


def _size(text: str) -> tuple[int, int]:
    try:
        a, b = text.lower().split("x")
        r, c = int(a), int(b)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected ROWSxCOLS such as 30x30, got {text!r}") \
            from None
    if r < 1 or c < 1:
        raise argparse.ArgumentTypeError(f"a lattice needs at least 1x1, got {text!r}")
    return r, c


def _k(text: str):
    if text == "auto":
        return "auto"
    try:
        k = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--k must be 'auto' or an integer, got {text!r}") \
            from None
    if k < 1:
        raise argparse.ArgumentTypeError(f"--k must be >= 1, got {k}")
    return k


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: str) -> None:
    plt = _pyplot()
    try:
        with atomic_output(path) as tmp:
            fig.savefig(tmp, dpi=110)
    finally:
        plt.close(fig)


def plot_som(model, path: str, clip: int = 0, title: str | None = None) -> None:
    """The manifold with one clip's trajectory (paper Figure 1) and the primitive centres."""
    plt = _pyplot()
    a = int(model.clip_starts[clip])
    b = int(model.clip_starts[clip + 1]) if clip + 1 < len(model.clip_starts) \
        else model.points.shape[0]
    p = model.points[a:b]
    fig, ax = plt.subplots(figsize=(5.5, 5.2))
    if model.manifold == "som":
        rows, cols, _ = model.som_codebook.shape
        # U-matrix shading: mean distance of each unit to its lattice neighbours
        w = model.som_codebook
        u = np.zeros((rows, cols))
        cnt = np.zeros((rows, cols))
        for dr, dc in ((0, 1), (1, 0)):
            d = np.linalg.norm(w[dr:, dc:] - w[:rows - dr, :cols - dc], axis=-1)
            u[dr:, dc:] += d
            cnt[dr:, dc:] += 1
            u[:rows - dr, :cols - dc] += d
            cnt[:rows - dr, :cols - dc] += 1
        ax.imshow(u / np.maximum(cnt, 1), cmap="Greys", origin="lower",
                  extent=(-0.5, cols - 0.5, -0.5, rows - 0.5))
        ax.set_xlabel("lattice column")
        ax.set_ylabel("lattice row")
    else:
        ax.set_xlabel("PC 1")
        ax.set_ylabel("PC 2")
    ax.plot(p[:, 1], p[:, 0], "-", color="tab:blue", lw=0.8, alpha=0.8,
            label=f"clip {clip} trajectory ({b - a} frames)")
    ax.plot(p[0, 1], p[0, 0], "o", color="tab:green", label="first frame")
    c = model.centers
    ax.scatter(c[:, 1], c[:, 0], s=60, c=np.arange(c.shape[0]), cmap="tab20",
               edgecolors="k", zorder=3, label="primitive centres")
    for i, (r, q) in enumerate(c):
        ax.annotate(str(i), (q, r), xytext=(4, 4), textcoords="offset points", fontsize=8)
    ax.set_title(title or f"motion manifold ({model.manifold})")
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    _save(fig, path)


def plot_elbow(model, path: str) -> None:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(model.elbow_ks, model.elbow_inertia, "o-")
    k = model.centers.shape[0]
    i = int(np.flatnonzero(model.elbow_ks == k)[0])
    ax.plot([k], [model.elbow_inertia[i]], "o", ms=12, mfc="none", color="tab:red",
            label=f"elbow: k = {k}")
    ax.set_xlabel("k")
    ax.set_ylabel("k-means inertia")
    ax.legend()
    fig.tight_layout()
    _save(fig, path)


def plot_transitions(model, path: str) -> None:
    """The transition matrix (paper Figure 3): bright = likely; the most likely next distinct
    primitive of each row (equation 5) is marked."""
    plt = _pyplot()
    P = model.markov.P
    k = P.shape[0]
    fig, ax = plt.subplots(figsize=(5.2, 4.5))
    im = ax.imshow(P, cmap="gray", vmin=0, vmax=1)
    nxt = [model.markov.most_likely_next(j) for j in range(k)]
    ax.plot(nxt, range(k), "x", color="tab:red", label="most likely next (eq. 5)")
    ax.set_xlabel("next primitive")
    ax.set_ylabel("current primitive")
    ax.set_xticks(range(k))
    ax.set_yticks(range(k))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=8)
    fig.colorbar(im, ax=ax, label="P(next | current)")
    fig.tight_layout()
    _save(fig, path)


def _primitives_args(p) -> None:
    p.add_argument("clips", nargs="+", metavar="CLIP.bvh", help="clips of one skeleton")
    p.add_argument("-o", "--output", required=True, help="model file (.npz)")
    p.add_argument("--k", type=_k, default="auto", help="primitives: 'auto' (elbow) or K")
    p.add_argument("--som", type=_size, default=None,
                   help="SOM lattice ROWSxCOLS (default: SxS, S = min(30, sqrt(frames)))")
    p.add_argument("--pca", action="store_true", help="PCA manifold instead of a SOM")
    p.add_argument("--epochs", type=int, default=20, help="SOM batch epochs (default 20)")
    p.add_argument("--lattice", type=_size, default=None,
                   help="GRBF centres ROWSxCOLS (default: GxG, G = min(15, sqrt(frames / 4)), "
                        "at most the SOM's)")
    p.add_argument("--kernel", choices=("thin_plate", "gaussian"), default="thin_plate")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--plots", metavar="PREFIX", default=None,
                   help="figure path prefix (default: the model path without .npz; '' for none)")


@command("primitives", "learn a motion manifold, primitives and their Markov model from clips",
         arguments=_primitives_args, reads_clips=True, inputs=("clips",),
         outputs={"output": NPZ, "plots": PREFIX})
def cmd_primitives(args) -> int:
    from ..primitives import PrimitiveModel
    # the default prefix (the model path without .npz) is in the model's folder, checked
    prefix = args.plots if args.plots is not None else os.path.splitext(args.output)[0]
    clips = []
    for path in args.clips:
        print(f"primitives: reading {path}", file=sys.stderr, flush=True)
        clips.append(read_bvh(path))
    sk = clips[0].skeleton
    for path, m in zip(args.clips[1:], clips[1:]):
        if not np.array_equal(m.skeleton.parents, sk.parents):
            raise InvalidArgumentError(f"{path}: another skeleton than {args.clips[0]}")
    model = PrimitiveModel.fit(clips, k=args.k, manifold="pca" if args.pca else "som",
                               som=args.som, epochs=args.epochs, lattice=args.lattice,
                               kernel=args.kernel, seed=args.seed, progress=True)
    model.save(args.output)
    print(f"primitives: wrote {args.output} (k = {model.centers.shape[0]}, "
          f"{model.points.shape[0]} frames)")
    if prefix:
        plot_som(model, prefix + "_som.png")
        outs = [prefix + "_som.png"]
        if model.elbow_ks.size:
            plot_elbow(model, prefix + "_elbow.png")
            outs.append(prefix + "_elbow.png")
        plot_transitions(model, prefix + "_transitions.png")
        outs.append(prefix + "_transitions.png")
        print("primitives: plots " + ", ".join(outs))
    return 0


def _generate_args(p) -> None:
    p.add_argument("model", help="model written by `mlayer primitives`")
    p.add_argument("--frames", type=int, default=300)
    p.add_argument("--start-frame", type=int, default=None,
                   help="training frame to start from (default: a seeded random frame)")
    p.add_argument("--noise", type=float, default=0.0,
                   help="scale of the perturbation of the transition matrix")
    p.add_argument("--most-likely", action="store_true",
                   help="follow the most likely next primitive (eq. 5) instead of sampling")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-guards", action="store_true",
                   help="the raw mapping: no joint limits, contact cleanup or floor")
    p.add_argument("-o", "--output", required=True, help="output BVH")


@command("generate", "synthesize a new motion from a primitives model",
         arguments=_generate_args, reads_clips=False, inputs=("model",),
         outputs={"output": BVH})
def cmd_generate(args) -> int:
    from ..primitives import PrimitiveModel
    if args.frames < 2:
        raise InvalidArgumentError(f"--frames must be >= 2, got {args.frames}")
    model = PrimitiveModel.load(args.model)
    motion, info = model.generate(args.frames, start_frame=args.start_frame, noise=args.noise,
                                  seed=args.seed, most_likely=args.most_likely,
                                  guards=not args.no_guards, return_info=True)
    write_bvh(motion, args.output)
    seq = " ".join(str(int(s)) for s in info["primitives"])
    print(f"generate: wrote {args.output} ({motion.n_frames} frames at {motion.fps:g} fps; "
          f"primitives {seq})")
    r = info["guards"]
    if r is not None:
        lim = ", ".join(f"{n} {k}" for n, k in r.limited.items()) or "none"
        print(f"generate: guards: contacts of the training frames pinned on {r.contact_frames} "
              f"frames, floor {r.floor_height:.4g} ({r.floor_frames} frames raised to it, "
              f"{r.floor_raised} with the whole body), joints limited (frames): {lim}")
    return 0
