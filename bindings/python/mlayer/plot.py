"""Figures of the motion layers (like paper 1, Figures 1 and 2), drawn with matplotlib, and
the two helpers every figure of the package is made and saved with.

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
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from . import quat
from ._files import atomic_output
from ._optional import require
from .errors import InvalidArgumentError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .layers import Layers
    from .motion import Motion

__all__ = ["new_figure", "save_figure", "plot_layers", "layer_choice"]


def new_figure(feature: str = "mlayer.plot", **kwargs: Any) -> Figure:
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
    fig = new_figure("mlayer.plot.plot_layers", figsize=(9, 8.5))
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
