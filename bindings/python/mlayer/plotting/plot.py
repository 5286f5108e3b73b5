"""Every figure of mlayer, drawn with matplotlib: the motion layers (like paper 1, Figures 1
and 2), foot contacts, retiming (the resampling variance, the time map of paper 1, Figure 9),
the streaming comparison, and the motion primitives (the manifold of paper 2, Figure 1, the
criteria for k, the transition matrix of paper 2, Figure 3); and the two helpers every figure
is made and saved with. The command line draws its figures with these functions.

Only imported when a figure is asked for: the rest of mlayer does not need matplotlib (the
``plot`` extra). Figures are ``matplotlib.figure.Figure`` objects made directly, without
pyplot: the user's backend is left alone (nothing calls ``matplotlib.use``), no window opens,
and a figure is not kept by pyplot's figure manager (it goes away with its last reference).
Every figure function returns its Figure and writes it to ``path`` when one is given
(atomically, by extension: PNG, SVG or PDF; the file honours the umask). In a notebook,
display the returned figure; in a script, ``fig.savefig(...)``.
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._files import atomic_output
from .._optional import require
from ..errors import InvalidArgumentError
from ..guards.contacts import contact_intervals
from ..manifold.clustering import elbow_point
from ..manifold.som import u_matrix
from ..model import quat
from ..pipeline.retiming import timewarp_speed

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..layers.layers import Layers
    from ..model.motion import Motion
    from ..manifold.primitives import PrimitiveModel

__all__ = ["new_figure", "save_figure", "plot_layers", "layer_choice", "plot_contacts",
           "plot_resample_variance", "plot_timewarp", "plot_stream", "plot_som", "plot_elbow",
           "plot_transitions"]




def new_figure(feature: str = "mlayer.plotting.plot", **kwargs: Any) -> Figure:
    """A ``matplotlib.figure.Figure(**kwargs)``: no pyplot, no backend switch.

    Parameters
    ----------
    feature : str, optional
        What asks for it, named in the error without matplotlib.
    **kwargs
        Passed to ``Figure`` (``figsize``, ``dpi``, ...).

    Returns
    -------
    matplotlib.figure.Figure
        A new figure.

    Raises
    ------
    mlayer.MissingDependencyError
        Naming the ``plot`` extra, without matplotlib.
    """
    require("matplotlib", feature=feature)
    from matplotlib.figure import Figure as _Figure
    return _Figure(**kwargs)


def save_figure(fig: Figure, path: str | os.PathLike[str] | None, *, dpi: float = 110) -> None:
    """Write a figure atomically, in the format of its extension.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or os.PathLike or None
        Where; PNG when the extension is none matplotlib knows; nothing is written when None.
    dpi : float, optional
        Resolution of raster formats.
    """
    if path is None:
        return
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    fmt = ext[1:] if ext in (".png", ".svg", ".pdf", ".jpg", ".jpeg", ".eps", ".ps", ".tif",
                             ".tiff", ".webp") else "png"
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=fmt)


def _angle(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation angle in degrees of unit quaternions (..., 4)."""
    return np.degrees(np.linalg.norm(quat.log(q), axis=-1))


def layer_choice(motion: Motion, layers: Layers, joint: str | None = None,
                 root_axis: int | None = None) -> tuple[str, int]:
    """What :func:`plot_layers` shows.

    Parameters
    ----------
    motion : Motion
        The decomposed motion.
    layers : Layers
        Its layers (:func:`mlayer.decompose`).
    joint : str, optional
        A joint name; default: the joint whose controllable layer moves most.
    root_axis : {0, 1, 2}, optional
        Default: the axis whose controllable layer moves most.

    Returns
    -------
    tuple of (str, int)
        The joint name and the root axis.

    Raises
    ------
    mlayer.InvalidArgumentError
        For an unknown joint or an axis other than 0, 1, 2.
    """
    names = list(motion.joint_names)
    ctrl = np.asarray(layers.control)
    if root_axis is None:
        root_axis = int(np.argmax(ctrl[:, 0, :].std(axis=0)))
    if root_axis not in (0, 1, 2):
        raise InvalidArgumentError(f"root_axis must be 0, 1 or 2, got {root_axis}")
    if joint is None:
        j = int(np.argmax(np.linalg.norm(ctrl[:, 1:, :], axis=-1).std(axis=0)))
    elif joint in names:
        j = names.index(joint)
    else:
        raise InvalidArgumentError(f"no joint {joint!r}; joints: {', '.join(names)}")
    return names[j], int(root_axis)


def plot_layers(motion: Motion, layers: Layers, path: str | os.PathLike[str] | None = None, *,
                joint: str | None = None, root_axis: int | None = None,
                title: str | None = None) -> Figure:
    """A figure of the layers of a motion (like paper 1, Figures 1 and 2).

    Top: one root translation channel through the original, the base layer and base plus the
    controllable layer, with the residual under it. Bottom: the same for one joint's rotation
    angle (degrees). Outlier frames of the robust decomposition (``layers.outliers``) are
    marked with red ticks on the residual panels (the translation's on the root panel, the
    joint's on the joint's). :func:`layer_choice` says which joint and axis are shown (the
    CLI prints them).

    Parameters
    ----------
    motion : Motion
        The decomposed motion.
    layers : Layers
        Its layers (:func:`mlayer.decompose`).
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).
    joint : str, optional
        A joint name; default: the joint whose controllable layer moves most.
    root_axis : {0, 1, 2}, optional
        Default: the axis whose controllable layer moves most.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.
    """
    fig = new_figure("mlayer.plotting.plot.plot_layers", figsize=(9, 8.5))
    names = list(motion.joint_names)
    ctrl = np.asarray(layers.control)
    resid = np.asarray(layers.residual)
    base = layers.base
    t = np.arange(motion.n_frames) / motion.fps
    shown, root_axis = layer_choice(motion, layers, joint, root_axis)
    j = names.index(shown)

    axis_name = "XYZ"[root_axis]
    pb = base.root_pos[:, root_axis]
    ax = fig.subplots(4, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1, 3, 1]})
    ax[0].plot(t, motion.root_pos[:, root_axis], color="0.55", lw=2.2, label="original M")
    ax[0].plot(t, pb, color="tab:blue", lw=1.2, label="base Mb")
    ax[0].plot(t, pb + ctrl[:, 0, root_axis], color="tab:red", lw=1.0, ls="--",
               label="Mb (+) control")
    ax[0].set_ylabel(f"root {axis_name}")
    ax[0].legend(loc="best", fontsize=8)
    ax[1].plot(t, resid[:, 0, root_axis], color="tab:green", lw=0.8)
    ax[1].set_ylabel("residual")

    qb = base.rot[:, j]
    q_ctrl = quat.mul(qb, quat.exp(ctrl[:, 1 + j]))
    ax[2].plot(t, _angle(motion.rot[:, j]), color="0.55", lw=2.2, label="original M")
    ax[2].plot(t, _angle(qb), color="tab:blue", lw=1.2, label="base Mb")
    ax[2].plot(t, _angle(q_ctrl), color="tab:red", lw=1.0, ls="--", label="Mb (+) control")
    ax[2].set_ylabel(f"{names[j]} angle (deg)")
    ax[2].legend(loc="best", fontsize=8)
    ax[3].plot(t, np.degrees(np.linalg.norm(resid[:, 1 + j], axis=-1)), color="tab:green",
               lw=0.8)
    ax[3].set_ylabel("|residual| (deg)")
    out = np.asarray(getattr(layers, "outliers", np.zeros((motion.n_frames, 1 + len(names)),
                                                          dtype=bool)))
    for a, g in ((ax[1], 0), (ax[3], 1 + j)):
        hit = np.flatnonzero(out[:, g])
        if hit.size:
            a.plot(t[hit], np.zeros(hit.size), "|", color="tab:red", ms=10,
                   label=f"outliers ({hit.size} frames)")
            a.legend(loc="best", fontsize=7)
    ax[3].set_xlabel("time (s)")
    fig.suptitle(title or "motion layers: base, controllable, residual")
    fig.tight_layout()
    save_figure(fig, path)
    return fig


def plot_contacts(names: Sequence[str], contacts: ArrayLike, fps: float,
                  path: str | os.PathLike[str] | None = None, *,
                  title: str | None = None) -> Figure:
    """A timeline of foot contacts, one row per contact point (``mlayer contacts --plot``).

    Parameters
    ----------
    names : sequence of str
        The contact points' names, as :func:`mlayer.detect_contacts` returns them.
    contacts : array_like of bool, shape (N, len(names))
        In contact per frame (N frames) and point (the second value of
        :func:`mlayer.detect_contacts`).
    fps : float
        The clip's frame rate (the time axis is in seconds).
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).
    title : str, optional
        The axes' title (default "foot contacts").

    Returns
    -------
    matplotlib.figure.Figure
        The figure: one axes.

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.
    mlayer.InvalidArgumentError
        When ``contacts`` is not (frames, len(names)).

    Examples
    --------
    >>> m = mlayer.data.load_sample()                                   # doctest: +SKIP
    >>> names, c = mlayer.detect_contacts(m)                            # doctest: +SKIP
    >>> mlayer.plotting.plot.plot_contacts(names, c, m.fps, "contacts.png")      # doctest: +SKIP
    """
    c = np.asarray(contacts, dtype=bool)
    names = list(names)
    if c.ndim != 2 or c.shape[1] != len(names):
        raise InvalidArgumentError(f"contacts must be (frames, {len(names)}) for {len(names)} "
                                   f"names, got shape {c.shape}")
    n, k = c.shape
    fig = new_figure("mlayer.plotting.plot.plot_contacts", figsize=(10, 0.45 * k + 1.0))
    ax = fig.subplots()
    for i in range(k):
        for a, b in contact_intervals(c[:, i]):
            ax.broken_barh([(a / fps, (b - a) / fps)], (k - 1 - i + 0.1, 0.8), color="C0")
    ax.set_yticks([k - 1 - i + 0.5 for i in range(k)], names)
    ax.set_xlim(0, n / fps)
    ax.set_ylim(0, k)
    ax.set_xlabel("time (s)")
    ax.set_title(title or "foot contacts")
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    return fig


def plot_resample_variance(var: ArrayLike, fps: float, observed: ArrayLike,
                           path: str | os.PathLike[str] | None = None, *,
                           title: str = "posterior variance of the resampled motion") -> Figure:
    """The posterior variance of an LGS resampling per output frame, with the input frames
    (the observations) marked (``mlayer resample --report PLOT.png``).

    Parameters
    ----------
    var : array_like, shape (n_out,)
        The variance per output frame, relative to one observation's
        (``mlayer.resample(..., return_var=True)``).
    fps : float
        The output's frame rate.
    observed : array_like
        Where the input frames fall, in output frames (fractional).
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure: one axes.

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.

    Examples
    --------
    >>> out, var = mlayer.resample(m, fps=30, return_var=True)          # doctest: +SKIP
    >>> obs = np.arange(m.n_frames) * (out.n_frames - 1) / (m.n_frames - 1)  # doctest: +SKIP
    >>> mlayer.plotting.plot.plot_resample_variance(var, out.fps, obs)           # doctest: +SKIP
    """
    v = np.asarray(var, dtype=np.float64)
    obs = np.asarray(observed, dtype=np.float64)
    fig = new_figure("mlayer.plotting.plot.plot_resample_variance", figsize=(9, 3.6))
    ax = fig.subplots()
    t = np.arange(v.shape[0]) / fps
    ax.plot(t, v, color="tab:red", lw=1.3, label="posterior variance")
    ax.plot(obs / fps, np.full(obs.shape, v.min() if v.size else 0.0), "|", color="0.4", ms=9,
            label="input frames (observations)")
    ax.set_xlabel("output time (s)")
    ax.set_ylabel("variance (x sigma^2)")
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    return fig


def plot_timewarp(motion: Motion, warped: Motion, time_map: ArrayLike,
                  path: str | os.PathLike[str] | None = None, *, speed: ArrayLike | None = None,
                  title: str = "time warp") -> Figure:
    """Like paper 1, Figure 9: the time map (output time against input time) with the motion
    speed under it, and the root height of the original and of the warped motion (``mlayer
    timewarp --plot``).

    Parameters
    ----------
    motion : Motion
        The input.
    warped : Motion
        The time-warped motion (:func:`mlayer.timewarp`).
    time_map : array_like, shape (N,)
        The output frame position of each of the input's N frames
        (:func:`mlayer.timewarp_map`).
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).
    speed : array_like, shape (N,), optional
        The motion speed per input frame; default :func:`mlayer.timewarp_speed` of ``motion``.
    title : str, optional
        The top axes' title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure: three axes (time map, speed, root height).

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.

    Examples
    --------
    >>> t = mlayer.timewarp_map(m, strength=1.5)                        # doctest: +SKIP
    >>> mlayer.plotting.plot.plot_timewarp(m, mlayer.timewarp(m, time_map=t), t)  # doctest: +SKIP
    """
    if speed is None:
        speed = timewarp_speed(motion)
    t = np.asarray(time_map, dtype=np.float64)
    sp = np.asarray(speed, dtype=np.float64)
    fig = new_figure("mlayer.plotting.plot.plot_timewarp", figsize=(9, 8))
    ax = fig.subplots(3, 1, gridspec_kw={"height_ratios": [3, 1.3, 2]})
    tin = np.arange(motion.n_frames) * motion.frame_time
    tout = t * warped.frame_time
    ax[0].plot(tin, tin * (tout[-1] / tin[-1]), "--", color="0.6", lw=1, label="uniform")
    ax[0].plot(tin, tout, color="tab:red", lw=1.6, label="time map")
    ax[0].set_ylabel("output time (s)")
    ax[0].set_title(title, fontsize=10)
    ax[0].legend(loc="upper left", fontsize=8)
    ax[1].plot(tin, sp, color="tab:blue", lw=1)
    ax[1].set_ylabel("motion speed\n(rad / frame)")
    ax[1].set_xlabel("input time (s)")
    ax[1].sharex(ax[0])
    for a in ax[:2]:
        a.grid(alpha=0.3)
    ax[2].plot(tin, motion.root_pos[:, 1], color="tab:blue", lw=1.3, label="original")
    ax[2].plot(np.arange(warped.n_frames) * warped.frame_time, warped.root_pos[:, 1],
               color="tab:red", lw=1.3, label="time-warped")
    ax[2].set_xlabel("time (s)")
    ax[2].set_ylabel("root Y")
    ax[2].legend(loc="upper right", fontsize=8)
    ax[2].grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    return fig


def plot_stream(motion: Motion, channels: ArrayLike, offline: ArrayLike, streamed: ArrayLike,
                one_euro: ArrayLike, path: str | os.PathLike[str] | None = None, *,
                joint: int, component: int, lag: int, lam: float, sigma: float,
                cutoff: float, beta: float) -> Figure:
    """One rotation channel of a clip streamed through the fixed-lag smoother, against the
    offline solve and a One Euro filter, and each one's difference to the offline solve
    (``mlayer stream --plot``).

    Parameters
    ----------
    motion : Motion
        The streamed clip (its frame time and joint names).
    channels, offline, streamed, one_euro : array_like, shape (N, C)
        N frames of C channels: the input's (:func:`mlayer.pipeline.stream.motion_channels`:
        translations, then 4 quaternion components per joint), the offline LGS solve, the
        stream's output and the One Euro filter's.
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).
    joint : int
        The joint shown (its index).
    component : {0, 1, 2, 3}
        The quaternion component shown (w, x, y, z).
    lag, lam, sigma : int, float, float
        The stream's lag (frames) and LGS parameters, for the legend.
    cutoff, beta : float
        The One Euro filter's minimum cutoff (Hz) and beta, for the legend.

    Returns
    -------
    matplotlib.figure.Figure
        The figure: two axes (the channel, the differences).

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.
    """
    y, ref = np.asarray(channels), np.asarray(offline)
    x, euro = np.asarray(streamed), np.asarray(one_euro)
    col = y.shape[1] - 4 * motion.n_joints + 4 * joint + component
    t = np.arange(len(y)) * motion.frame_time
    name = f"{motion.joint_names[joint]} q.{'wxyz'[component]}"
    fig = new_figure("mlayer.plotting.plot.plot_stream", figsize=(11, 6.5))
    a1, a2 = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    a1.plot(t, y[:, col], color="0.75", lw=1.0, label="input")
    a1.plot(t, ref[:, col], color="k", lw=1.4, label=f"offline LGS (lam {lam:g}, sigma {sigma:g})")
    a1.plot(t, x[:, col], color="tab:blue", lw=1.0, ls="--", label=f"streamed, lag {lag}")
    a1.plot(t, euro[:, col], color="tab:red", lw=1.0,
            label=f"One Euro (min cutoff {cutoff:.3g} Hz, beta {beta:g})")
    a1.set_ylabel(name)
    a1.legend(loc="best", fontsize=8)
    a1.set_title(f"{name}: offline vs streamed vs One Euro")
    a2.plot(t, x[:, col] - ref[:, col], color="tab:blue", lw=1.0, label="streamed - offline")
    a2.plot(t, euro[:, col] - ref[:, col], color="tab:red", lw=1.0, label="One Euro - offline")
    a2.axhline(0.0, color="k", lw=0.6)
    a2.set_xlabel("time (s)")
    a2.set_ylabel("difference")
    a2.legend(loc="best", fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    return fig


def plot_som(model: PrimitiveModel, path: str | os.PathLike[str] | None = None, *,
             clip: int = 0, title: str | None = None) -> Figure:
    """The motion manifold with one training clip's trajectory (paper 2, Figure 1) and the
    primitives' centres: on a SOM, its U-matrix in grey (``mlayer primitives``, PREFIX_som.png).

    Parameters
    ----------
    model : PrimitiveModel
        A fitted model (:meth:`mlayer.PrimitiveModel.fit`).
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).
    clip : int, optional
        The training clip whose trajectory is drawn (default the first).
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure: one axes.

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.
    mlayer.InvalidArgumentError
        For a clip the model does not have.
    """
    starts = np.asarray(model.clip_starts)
    if not 0 <= clip < len(starts):
        raise InvalidArgumentError(f"clip must be 0 to {len(starts) - 1}, got {clip}")
    a = int(starts[clip])
    b = int(starts[clip + 1]) if clip + 1 < len(starts) else model.points.shape[0]
    p = model.points[a:b]
    fig = new_figure("mlayer.plotting.plot.plot_som", figsize=(5.5, 5.2))
    ax = fig.subplots()
    if model.manifold == "som":
        rows, cols, _ = model.som_codebook.shape
        # U-matrix shading: mean distance of each unit to its lattice neighbours
        ax.imshow(u_matrix(model.som_codebook), cmap="Greys", origin="lower",
                  extent=(-0.5, cols - 0.5, -0.5, rows - 0.5))
        ax.set_xlabel("lattice column")
        ax.set_ylabel("lattice row")
    else:
        ax.set_xlabel("PC 2")
        ax.set_ylabel("PC 1")
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
    save_figure(fig, path)
    return fig


def plot_elbow(model: PrimitiveModel, path: str | os.PathLike[str] | None = None) -> Figure:
    """The criteria for the number of primitives against k: k-means inertia (the elbow), and
    when the model has them the silhouette and the GMM BIC, each criterion's pick circled, the
    model's k a dashed line (``mlayer primitives``, PREFIX_elbow.png).

    Parameters
    ----------
    model : PrimitiveModel
        A fitted model with candidate ks (``model.elbow_ks`` not empty: ``k="auto"`` or
        ``ks=`` given to :meth:`mlayer.PrimitiveModel.fit`).
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).

    Returns
    -------
    matplotlib.figure.Figure
        The figure: one axes per criterion (three, or one without ``model.criteria``).

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.
    mlayer.InvalidArgumentError
        When the model was fitted without candidate ks.
    """
    ks = np.asarray(model.elbow_ks)
    if ks.size == 0:
        raise InvalidArgumentError("the model has no candidate ks to plot: fit it with "
                                   "k='auto' or ks=")
    k = model.centers.shape[0]
    c = getattr(model, "criteria", None)
    rows = [("k-means inertia", model.elbow_inertia, "elbow")]
    if c is not None:
        rows += [("silhouette", c.silhouette, "silhouette"), ("GMM BIC", c.bic, "bic")]
    fig = new_figure("mlayer.plotting.plot.plot_elbow", figsize=(5, 2.2 * len(rows) + 0.6))
    axes = fig.subplots(len(rows), 1, sharex=True, squeeze=False)
    for ax, (label, v, name) in zip(axes[:, 0], rows):
        ax.plot(ks, v, "o-")
        if c is not None:
            pick = c.picks[name]
        else:
            pick = elbow_point(ks, v)[0]
        i = int(np.flatnonzero(ks == pick)[0])
        ax.plot([pick], [v[i]], "o", ms=12, mfc="none", color="tab:red",
                label=f"{name}: k = {pick}")
        ax.axvline(k, color="tab:green", lw=1, ls="--")
        ax.set_ylabel(label)
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel(f"k (dashed: the model's k = {k})")
    fig.tight_layout()
    save_figure(fig, path)
    return fig


def plot_transitions(model: PrimitiveModel,
                     path: str | os.PathLike[str] | None = None) -> Figure:
    """The transition matrix of the primitives (paper 2, Figure 3): bright = likely; the most
    likely next distinct primitive of each row (equation 5) is marked (``mlayer primitives``,
    PREFIX_transitions.png).

    Parameters
    ----------
    model : PrimitiveModel
        A fitted model.
    path : str or os.PathLike, optional
        Also write the figure there (PNG, SVG or PDF, by extension).

    Returns
    -------
    matplotlib.figure.Figure
        The figure: the matrix's axes and its colour bar's.

    Raises
    ------
    mlayer.MissingDependencyError
        Without matplotlib.
    """
    P = model.markov.P
    k = P.shape[0]
    fig = new_figure("mlayer.plotting.plot.plot_transitions", figsize=(5.2, 4.5))
    ax = fig.subplots()
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
    save_figure(fig, path)
    return fig
