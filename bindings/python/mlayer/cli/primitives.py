"""`mlayer primitives` and `mlayer generate`: learn a motion manifold with primitives from clips,
then synthesize new motion from it (paper 2).

    mlayer primitives CLIPS... -o model.npz [--k auto|K] [--ks 2..20]
                               [--criterion elbow|silhouette|bic] [--cluster kmeans|fcm|gmm]
                               [--cluster-on manifold|features]
                               [--order 1|2|3|auto] [--min-count M] [--som RxC] [--pca]
                               [--epochs 20] [--lattice RxC] [--kernel thin_plate|gaussian]
                               [--plots PREFIX] [--runtime FILE.mlrgen]

The SOM and GRBF lattices default to sizes that scale with the training frames (30x30 and 15x15
from 900 frames on; see mlayer.manifold.primitives.default_lattices); clips in other units than the
first (body heights a factor of 2 or more apart) are scaled to its size, with a warning.
    mlayer generate model.npz --frames 300 [--start-frame T] [--noise S] [--seed N]
                              [--most-likely | --second-likely] [--allow-unseen]
                              [--through "x1,y1;x2,y2;..." | --keys CLIP:FRAME,...]
                              [--no-guards] -o new.bvh

`primitives` prints, for the candidate ks, the k-means inertia (elbow), the silhouette and the
GMM BIC side by side with the k each picks, and the held-out log-likelihood of the Markov jump
model of orders 1 to 3 (5-fold blocked cross-validation, mlayer.manifold.markov.heldout_loglik), so
that --k / --criterion and --order can be chosen. k, --ks and the lattices are checked against
the frames and the SOM's units before the SOM trains (a --ks beyond them is an error; the
default 2..20 is cut to them, with a note), and the line of the k says where it came from
(given by --k, or picked by the criterion). `generate --through` takes points on the map in the
coordinates of PREFIX_som.png (x the lattice column, y the row; PCA: x = PC 2, y = PC 1);
`--keys` key frames CLIP:FRAME, CLIP a training clip's file name or index (or another BVH
file of the model's skeleton), FRAME its frame (0-based, after any --trim at training).

`primitives` writes, next to the model (or at --plots PREFIX): PREFIX_som.png (the lattice with
the first clip's trajectory and the primitive centres, like paper Figure 1), PREFIX_elbow.png
(inertia, silhouette and BIC against k) and PREFIX_transitions.png (the transition matrix, like
Figure 3). `generate` applies the guards of the training clips (their contacts, joint limits
and floor; `--no-guards`: the raw mapping) and says what they did. Progress goes to stderr.
Bad input: one line on stderr and exit status 1.
"""
from __future__ import annotations

from typing import Any

import argparse
import os
import sys

import numpy as np

from ..errors import InvalidArgumentError
from ..io.bvh import read_bvh
from ..manifold.primitives import PrimitiveModel, RUNTIME_FORMAT, join_skeletons
from ..plotting.plot import plot_elbow, plot_som, plot_transitions
from ._command import (BVH_OR_STDOUT, MLRGEN, NPZ, Needs, PREFIX, add_rename_option, command,
                       output_name, parse_rename, write_bvh_output)


#: what needs matplotlib in the message without it
_FEATURE = "mlayer primitives --plots (on by default; --plots '' for none)"


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


def _ks(text: str) -> range:
    try:
        a, b = text.split("..")
        lo, hi = int(a), int(b)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LO..HI such as 2..20, got {text!r}") \
            from None
    if not 1 <= lo <= hi:
        raise argparse.ArgumentTypeError(f"expected 1 <= LO <= HI, got {text!r}")
    return range(lo, hi + 1)


def _order(text: str):
    """--order: 'auto' or an integer; its range is checked by the library (one line)."""
    if text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise InvalidArgumentError(f"--order must be 1, 2, 3 or auto, got {text!r}") from None


def parse_through(text: str) -> np.ndarray:
    """--through "x1,y1;x2,y2;...": points (K, 2) as (row, column) = (y, x)."""
    pts = []
    for i, part in enumerate(p for p in text.split(";") if p.strip()):
        try:
            x, y = (float(v) for v in part.split(","))
        except ValueError:
            raise InvalidArgumentError(f"--through: point {i} {part.strip()!r} is not x,y") \
                from None
        pts.append((y, x))
    if not pts:
        raise InvalidArgumentError(f"--through: no points in {text!r}; give x1,y1;x2,y2;...")
    return np.array(pts)


def parse_keys(text: str, model: PrimitiveModel,
               rename: dict[str, str] | None = None) -> list[tuple[Any, int]]:
    """--keys CLIP:FRAME,...: (clip, frame) pairs for PrimitiveModel.generate(keys=...); CLIP a
    training clip's name or index, or a BVH file of the model's skeleton, joint names and tree
    (read here; renamed by ``rename``, mlayer.manifold.primitives.join_skeletons)."""
    keys: list[tuple[Any, int]] = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        clip, sep, frame = part.rpartition(":")
        try:
            f = int(frame)
        except ValueError:
            f = None
        if not sep or not clip or f is None:
            raise InvalidArgumentError(f"--keys: {part!r} is not CLIP:FRAME")
        names = list(model.clip_names)
        if clip in names or os.path.basename(clip) in names:
            keys.append((clip if clip in names else os.path.basename(clip), f))
        elif clip.isdigit():
            keys.append((int(clip), f))
        elif os.path.isfile(clip):
            m = read_bvh(clip)
            try:
                m = join_skeletons([m], rename=rename, names=[clip],
                                   reference=model.skeleton, reference_name="the model")[0]
            except InvalidArgumentError as e:  # "clip 0 (...): another skeleton: joint 2 ..."
                raise InvalidArgumentError(f"--keys: {clip} has another skeleton than the "
                                           f"model: {str(e).split('another skeleton: ')[-1]}") \
                    from None
            keys.append((m, f))
        else:
            raise InvalidArgumentError(f"--keys: no training clip {clip!r} (the model's clips: "
                                       f"{', '.join(names)}, or their index) and no such file")
    if not keys:
        raise InvalidArgumentError(f"--keys: no key frames in {text!r}")
    return keys


def _primitives_args(p) -> None:
    p.add_argument("clips", nargs="+", metavar="CLIP.bvh", help="clips of one skeleton")
    p.add_argument("-o", "--output", required=True, help="model file (.npz)")
    p.add_argument("--k", type=_k, default="auto",
                   help="primitives: 'auto' (the pick of --criterion) or K")
    p.add_argument("--ks", type=_ks, default=None, metavar="LO..HI",
                   help="candidate ks for the criteria, at most the frames and the SOM's units "
                        "(default with --k auto: 2..20, cut to them with a note; with --k K: "
                        "none)")
    p.add_argument("--criterion", choices=("elbow", "silhouette", "bic"), default="elbow",
                   help="what picks k when --k auto (default elbow)")
    p.add_argument("--cluster", choices=("kmeans", "fcm", "gmm"), default="kmeans",
                   help="what labels the frames: k-means, fuzzy c-means or a Gaussian mixture")
    p.add_argument("--cluster-on", choices=("manifold", "features"), default="manifold",
                   help="what is clustered: the map's 2-D points (the paper's) or the pose "
                        "features")
    p.add_argument("--order", default="1", metavar="1|2|3|auto",
                   help="order of the Markov jump model (auto: best held-out likelihood)")
    p.add_argument("--min-count", type=int, default=1,
                   help="back off to a shorter context seen fewer times than this (default 1: "
                        "fixed order; larger: variable length)")
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
    p.add_argument("--runtime", metavar="FILE.mlrgen", default=None,
                   help="also write the model for generation at run time, without Python (the "
                        "C core's mlr_generate.h; docs/model-format.md)")
    add_rename_option(p)


@command("primitives", "learn a motion manifold, primitives and their Markov model from clips",
         arguments=_primitives_args, reads_clips=True, inputs=("clips",),
         outputs={"output": NPZ, "plots": PREFIX, "runtime": MLRGEN},
         requires=(Needs("matplotlib", when=lambda a: a.plots is None or a.plots != "",
                         feature=_FEATURE),))
def cmd_primitives(args) -> int:
    # the default prefix (the model path without .npz) is in the model's folder, checked
    prefix = args.plots if args.plots is not None else os.path.splitext(args.output)[0]
    rename = parse_rename(args.rename)
    clips = []
    for path in args.clips:
        print(f"primitives: reading {path}", file=sys.stderr, flush=True)
        clips.append(read_bvh(path))
    # names and tree before any work (fit checks again, by the names in the model)
    clips = join_skeletons(clips, rename=rename, names=args.clips)
    model = PrimitiveModel.fit(clips, k=args.k, ks=args.ks, criterion=args.criterion,
                               cluster=args.cluster, cluster_on=args.cluster_on,
                               order=_order(args.order),
                               min_count=args.min_count,
                               manifold="pca" if args.pca else "som", som=args.som,
                               epochs=args.epochs, lattice=args.lattice, kernel=args.kernel,
                               seed=args.seed,
                               names=_clip_names(args.clips))
    model.save(args.output)
    print_criteria(model)
    print(f"primitives: wrote {args.output} (k = {model.centers.shape[0]}, "
          f"{model.points.shape[0]} frames)")
    if args.runtime:
        model.save_runtime(args.runtime)
        print(f"primitives: wrote {args.runtime} (the runtime model, format "
              f"{RUNTIME_FORMAT})")
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


def _clip_names(paths) -> list:
    """The clips' names in the model: their file names, the paths where file names repeat."""
    base = [os.path.basename(p) for p in paths]
    return base if len(set(base)) == len(base) else list(paths)


def print_criteria(model: PrimitiveModel) -> None:
    """The k criteria side by side and the held-out log-likelihood of each Markov order."""
    c = model.criteria
    k = model.centers.shape[0]
    if c is not None:
        print("primitives: how many (k-means inertia: elbow; silhouette: larger is better; "
              "GMM BIC: smaller is better)")
        print("      k     inertia  silhouette         BIC")
        for i, q in enumerate(c.ks):
            marks = [n for n in ("elbow", "silhouette", "bic") if c.picks[n] == q]
            print(f"  {int(q):5d} {c.inertia[i]:11.4g} {c.silhouette[i]:11.4f} "
                  f"{c.bic[i]:11.5g}  {' '.join('<- ' + m for m in marks)}")
    src = model.k_source
    how = {"given": ", given by --k", None: ""}.get(src, f", picked by {src}")
    print(f"primitives: k = {k} (cluster {model.cluster}{how})")
    ll = model.order_loglik
    if ll:
        n = next(iter(ll.values()))[1]
        print(f"primitives: Markov jump model, held-out log-likelihood per jump (5-fold blocked "
              f"cross-validation, {n} jumps, min count {model.markov.min_count}):")
        for o in sorted(ll):
            mark = "  <- used" if o == model.markov.order else ""
            print(f"  order {o}: {ll[o][0]:.4f} nats{mark}")


def _generate_args(p) -> None:
    p.add_argument("model", help="model written by `mlayer primitives`")
    p.add_argument("--frames", type=int, default=300)
    p.add_argument("--start-frame", type=int, default=None,
                   help="training frame to start from (default: a seeded random frame)")
    p.add_argument("--noise", type=float, default=0.0,
                   help="perturbation of the Markov chain: each row redrawn from a Dirichlet "
                        "centred on it with concentration 1/S (0: the learned chain)")
    p.add_argument("--most-likely", action="store_true",
                   help="follow the most likely next primitive (eq. 5) instead of sampling")
    p.add_argument("--second-likely", action="store_true",
                   help="follow the second most likely next primitive (paper Figure 3 c)")
    p.add_argument("--allow-unseen", action="store_true",
                   help="let the noise open transitions the data never showed (a prior mass "
                        "of 0.02 per row)")
    p.add_argument("--through", default=None, metavar="x1,y1;x2,y2;...",
                   help="a spline through these points of the map (x the lattice column, y the "
                        "row, as in PREFIX_som.png)")
    p.add_argument("--keys", default=None, metavar="CLIP:FRAME,...",
                   help="a path through these key frames (CLIP a training clip's file name or "
                        "index, or a BVH file of the model's skeleton)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-guards", action="store_true",
                   help="the raw mapping: no joint limits, contact cleanup or floor")
    p.add_argument("-o", "--output", required=True, help="output BVH; - for the standard output")
    add_rename_option(p)


@command("generate", "synthesize a new motion from a primitives model",
         arguments=_generate_args, reads_clips=False, inputs=("model",),
         outputs={"output": BVH_OR_STDOUT})
def cmd_generate(args) -> int:
    if args.frames < 3:
        raise InvalidArgumentError(f"--frames must be >= 3, got {args.frames}")
    if args.through is not None and args.keys is not None:
        raise InvalidArgumentError("--through and --keys exclude each other")
    if args.most_likely and args.second_likely:
        raise InvalidArgumentError("--most-likely and --second-likely exclude each other")
    if args.through is not None or args.keys is not None:
        given = [f for f, v in (("--start-frame", args.start_frame is not None),
                                ("--most-likely", args.most_likely),
                                ("--second-likely", args.second_likely),
                                ("--noise", args.noise != 0), ("--allow-unseen",
                                                               args.allow_unseen)) if v]
        if given:
            raise InvalidArgumentError(f"{given[0]} applies to the primitives' path, not to "
                                       f"{'--through' if args.through is not None else '--keys'}")
    through = parse_through(args.through) if args.through is not None else None
    model = PrimitiveModel.load(args.model)
    keys = parse_keys(args.keys, model, parse_rename(args.rename)) if args.keys is not None \
        else None
    motion, info = model.generate(args.frames, start_frame=args.start_frame, noise=args.noise,
                                  seed=args.seed, most_likely=args.most_likely,
                                  second_likely=args.second_likely,
                                  allow_unseen=args.allow_unseen, through=through, keys=keys,
                                  guards=not args.no_guards, return_info=True)
    write_bvh_output(args, motion)
    seq = " ".join(str(int(s)) for s in info["primitives"])
    print(f"generate: wrote {output_name(args.output)} ({motion.n_frames} frames at "
          f"{motion.fps:g} fps; "
          f"primitives {seq})")
    r = info["guards"]
    if r is not None:
        lim = ", ".join(f"{n} {k}" for n, k in r.limited.items()) or "none"
        print(f"generate: guards: contacts of the training frames pinned on {r.contact_frames} "
              f"frames, floor {r.floor_height:.4g} ({r.floor_frames} frames raised to it, "
              f"{r.floor_raised} with the whole body), joints limited (frames): {lim}")
    return 0
