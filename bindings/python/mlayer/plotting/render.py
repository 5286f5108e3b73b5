"""Stick-figure animations of motions, side by side under one camera: an animated GIF, an MP4
video or a PNG strip of frames (:func:`render`, by the path's extension).

Drawing is done with Pillow directly (an orthographic camera, one panel per motion, a ground
grid), which is fast enough to render a whole clip in a second or two. Pillow is the
``render`` extra; MP4 needs imageio-ffmpeg too (the ``video`` extra, which carries an ffmpeg
binary). Motions are drawn Y-up (a clip's detected up axis is turned to Y).

Every panel uses the same camera: the same scale, the same view direction and the same target,
which follows the first motion across the ground (its first joint that moves: the root, or the
hips under a root that stays at the origin as Bandai's ``joint_Root``), so differences between
the panels (denoised, exaggerated, retimed) are differences of the motions, not of the framing.
"""
from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..guards.metrics import body_height
from ..model.up_axis import to_y_up

from .._args import integer
from .._files import atomic_output
from .._optional import require
from .._progress import BarFactory, ProgressArg, resolve
from ..errors import InvalidArgumentError

if TYPE_CHECKING:
    from ..model.motion import Motion

__all__ = ["render", "render_gif", "body_side", "followed_joint", "FORMATS"]

# Fixed palette (GIF frames are drawn in "P" mode: no per-frame quantization needed).
_PALETTE = {
    "background": (250, 250, 247),
    "grid": (214, 214, 208),
    "center": (70, 70, 78),
    "left": (38, 110, 200),
    "right": (205, 60, 50),
    "text": (30, 30, 30),
    "joint": (20, 20, 20),
}
_INDEX = {name: i for i, name in enumerate(_PALETTE)}

_SIDE_PATTERNS = {
    # case-insensitive prefixes/suffixes, and Daz's case-sensitive "lThigh" / "rShldr"
    "left": (re.compile(r"(^left|left$|^l_|_l$|\.l$)", re.IGNORECASE),
             re.compile(r"^[lL](?=[A-Z])")),
    "right": (re.compile(r"(^right|right$|^r_|_r$|\.r$)", re.IGNORECASE),
              re.compile(r"^[rR](?=[A-Z])")),
}


def body_side(name: str) -> str:
    """The side of the body a joint is on, from its name.

    Knows the naming schemes of common rigs (CMU "LeftUpLeg", Daz "lThigh", Bandai
    "UpperLeg_L", Blender "thigh.L").

    Parameters
    ----------
    name : str
        A joint name.

    Returns
    -------
    str
        ``"left"``, ``"right"`` or ``"center"``.
    """
    for side, (loose, daz) in _SIDE_PATTERNS.items():
        if loose.search(name) or daz.search(name):
            return side
    low = name.lower()
    return "left" if "left" in low else "right" if "right" in low else "center"


def _camera(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """Rows: screen right, screen up, toward the viewer (world Y-up)."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    ry = np.array([[math.cos(az), 0.0, -math.sin(az)], [0.0, 1.0, 0.0],
                   [math.sin(az), 0.0, math.cos(az)]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(el), -math.sin(el)],
                   [0.0, math.sin(el), math.cos(el)]])
    return rx @ ry


def _smooth_track(xz: np.ndarray, frames: int) -> np.ndarray:
    """Moving average over `frames` samples (edge-padded), so the camera glides."""
    if frames <= 1 or len(xz) < 3:
        return xz
    k = np.ones(frames) / frames
    pad = frames // 2
    padded = np.pad(xz, ((pad, frames - 1 - pad), (0, 0)), mode="edge")
    return np.stack([np.convolve(padded[:, c], k, mode="valid") for c in range(xz.shape[1])], 1)


def followed_joint(positions: ArrayLike) -> int:
    """The joint the camera follows.

    The first joint (in skeleton order, so the root or the joint nearest to it) whose
    horizontal position moves by more than 1% of the body's height over the clip. Rigs such
    as Bandai's keep a ``joint_Root`` at the origin and move the body with the hips below it.

    Parameters
    ----------
    positions : array_like, shape (N, J, 3)
        World joint positions, Y-up.

    Returns
    -------
    int
        The joint index; 0 when no joint moves.
    """
    p = np.asarray(positions, dtype=np.float64)
    height = body_height(p, "y") or 1.0
    xz = p[:, :, [0, 2]]
    moved = np.linalg.norm(xz - xz[:1], axis=-1).max(axis=0) > 0.01 * height
    return int(np.argmax(moved)) if moved.any() else 0


class _Scene:
    """What every frame of a render shares: the motions in Y-up, the camera, the palette."""

    def __init__(self, motions: Iterable[Motion], labels: Iterable[str] | None, fps: float,
                 panel_size: tuple[int, int], azimuth: float, elevation: float,
                 max_seconds: float | None, where: str) -> None:
        from PIL import Image
        motions = list(motions)
        if not motions:
            raise InvalidArgumentError(f"{where}: no motions given")
        if labels is None:
            labels = [str(i) for i in range(len(motions))]
        labels = list(labels)
        if len(labels) != len(motions):
            raise InvalidArgumentError(f"{where}: {len(labels)} labels for {len(motions)} "
                                       "motions")
        if not (math.isfinite(fps) and fps > 0):
            raise InvalidArgumentError(f"{where}: fps must be positive, got {fps}")
        pos = [to_y_up(getattr(m, "up_axis", "y"), np.asarray(m.positions(), dtype=np.float64))
               for m in motions]
        for p in pos:
            if p.shape[0] == 0:
                raise InvalidArgumentError(f"{where}: a motion has no frames")
        duration = max(p.shape[0] / m.fps for p, m in zip(pos, motions))
        if max_seconds is not None:
            duration = min(duration, max_seconds)
        self.n_out = max(1, int(round(duration * fps)))
        self.motions, self.labels, self.pos, self.fps = motions, labels, pos, fps

        # one camera for every panel: scale from the first motion's height, target following it
        self.cam = _camera(azimuth, elevation)
        p0 = pos[0]
        self.ground = min(float(np.percentile(p[:, :, 1], 0.5)) for p in pos)
        self.height = float(np.percentile(p0[:, :, 1].max(axis=1) - self.ground, 50)) or 1.0
        self.w, self.h = panel_size
        self.scale = 0.62 * self.h / self.height
        self.track = _smooth_track(p0[:, followed_joint(p0), [0, 2]],
                                   max(1, int(motions[0].fps)))
        self.spacing = self.height / 2.0
        self.palette = [c for rgb in _PALETTE.values() for c in rgb]
        self.blank = Image.new("P", (self.w, self.h), _INDEX["background"])
        self.blank.putpalette(self.palette)
        self.sides = [[body_side(n) for n in m.joint_names] for m in motions]

    def frame(self, k: int) -> Any:
        """Output frame k (time k / fps): the panels side by side, a "P" mode image."""
        from PIL import Image, ImageDraw
        w, h, motions, p0 = self.w, self.h, self.motions, self.pos[0]
        t = k / self.fps
        f0 = min(int(round(t * motions[0].fps)), p0.shape[0] - 1)
        target = np.array([self.track[f0, 0], self.ground + 0.45 * self.height,
                           self.track[f0, 1]])
        cam, scale, ground, spacing = self.cam, self.scale, self.ground, self.spacing

        def project(world: Any) -> NDArray[np.float64]:
            v = (np.asarray(world) - target) @ cam.T
            return np.stack([w / 2 + scale * v[..., 0], h / 2 - scale * v[..., 1]], -1)

        frame = Image.new("P", (w * len(motions), h), _INDEX["background"])
        frame.putpalette(self.palette)
        for i, (p, m) in enumerate(zip(self.pos, motions)):
            panel = self.blank.copy()  # each panel is drawn on its own, clipped to its box
            draw = ImageDraw.Draw(panel)
            cx = math.floor(target[0] / spacing) * spacing
            cz = math.floor(target[2] / spacing) * spacing
            ext = np.arange(-4, 5) * spacing
            for d in ext:
                a = project([[cx + d, ground, cz + ext[0]], [cx + d, ground, cz + ext[-1]]])
                b = project([[cx + ext[0], ground, cz + d], [cx + ext[-1], ground, cz + d]])
                draw.line([tuple(a[0]), tuple(a[1])], fill=_INDEX["grid"], width=1)
                draw.line([tuple(b[0]), tuple(b[1])], fill=_INDEX["grid"], width=1)
            fi = min(int(round(t * m.fps)), p.shape[0] - 1)
            xy = project(p[fi])
            for j, par in enumerate(m.parents):
                if par >= 0:
                    draw.line([tuple(xy[par]), tuple(xy[j])], fill=_INDEX[self.sides[i][j]],
                              width=3)
            for x, y in xy:
                draw.ellipse([x - 1.5, y - 1.5, x + 1.5, y + 1.5], fill=_INDEX["joint"])
            draw.text((8, 6), f"{self.labels[i]}", fill=_INDEX["text"])
            if i:
                draw.line([(0, 0), (0, h)], fill=_INDEX["grid"], width=1)
            else:
                draw.text((8, h - 16), f"{t:5.2f} s", fill=_INDEX["text"])
            frame.paste(panel, (i * w, 0))
        return frame


#: the formats :func:`render` writes, by the path's extension (lower case)
FORMATS = {".gif": "an animated GIF", ".mp4": "an MP4 video (H.264; needs imageio-ffmpeg)",
           ".png": "a PNG strip of frames (time left to right, one row per motion)"}


def render(motions: Iterable[Motion], path: str | os.PathLike[str], *,
           labels: Iterable[str] | None = None, fps: float = 30.0,
           panel_size: tuple[int, int] = (320, 380), azimuth: float = 35.0,
           elevation: float = 12.0, max_seconds: float | None = None, strip_frames: int = 8,
           progress: ProgressArg = None) -> int:
    """Render motions side by side under one camera, in the format the path's extension names.

    Written atomically; the file honours the umask.

    - ``.gif``: an animated GIF (:func:`render_gif`);
    - ``.mp4``: an H.264 video at ``fps`` (needs imageio-ffmpeg: the ``video`` extra), its size
      padded with the background to multiples of 16 pixels;
    - ``.png``: a strip of ``strip_frames`` frames evenly spaced over the clip (the first and
      the last included): time runs left to right, one row per motion, each panel
      ``panel_size``; the first row shows the times.

    Parameters
    ----------
    motions : iterable of Motion
        The motions, one panel each.
    path : str or os.PathLike
        The output, ending in ``.gif``, ``.mp4`` or ``.png``.
    labels : iterable of str, optional
        One caption per panel (default ``"0"``, ``"1"``, ...).
    fps : float, optional
        Frame rate of the output; each panel shows its motion's frame nearest in time.
    panel_size : tuple of int, optional
        (width, height) of one panel in pixels.
    azimuth, elevation : float, optional
        Camera direction in degrees (azimuth about the vertical axis).
    max_seconds : float, optional
        Render only the first seconds of the clips.
    strip_frames : int, optional
        Frames of a PNG strip.
    progress : None, bool, stream or callable, optional
        A progress bar over the frames: None (on stderr when it is a terminal and tqdm is
        installed), True, False, a stream, or a callable ``f(done, total)``.

    Returns
    -------
    int
        The number of frames written (for a strip, its frames).

    Raises
    ------
    mlayer.InvalidArgumentError
        For another extension or bad arguments, before any work.
    mlayer.MissingDependencyError
        Without Pillow (or imageio-ffmpeg for MP4), before any work.
    """
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in FORMATS:
        what = ext or "a path without an extension"
        raise InvalidArgumentError(f"render: {os.fspath(path)}: cannot write {what}; give a "
                                   "path ending in .gif, .mp4 or .png")
    if ext == ".gif":
        return render_gif(motions, path, labels=labels, fps=fps, panel_size=panel_size,
                          azimuth=azimuth, elevation=elevation, max_seconds=max_seconds,
                          progress=progress)
    require("PIL", feature="mlayer.plotting.render")
    if ext == ".mp4":
        ffmpeg = require("imageio_ffmpeg", feature="mlayer.plotting.render to .mp4", extra="video")
        make_bar = resolve(progress, "mlayer.plotting.render")
        scene = _Scene(motions, labels, fps, panel_size, azimuth, elevation, max_seconds,
                       "render")
        return _write_mp4(scene, path, ffmpeg, make_bar)
    strip_frames = integer(strip_frames, "strip_frames", 1)
    make_bar = resolve(progress, "mlayer.plotting.render")
    scene = _Scene(motions, labels, fps, panel_size, azimuth, elevation, max_seconds, "render")
    return _write_strip(scene, path, strip_frames, make_bar)


def _write_mp4(scene: _Scene, path: str | os.PathLike[str], ffmpeg: Any,
               make_bar: BarFactory) -> int:
    from PIL import Image
    w, h = scene.w * len(scene.motions), scene.h
    W, H = -(-w // 16) * 16, -(-h // 16) * 16  # H.264 (yuv420p) in whole macro blocks
    back = _PALETTE["background"]
    with make_bar(scene.n_out, "rendering", "frame") as bar, \
            atomic_output(path, ".mp4") as tmp:
        writer = ffmpeg.write_frames(tmp, (W, H), fps=scene.fps, codec="libx264",
                                     pix_fmt_in="rgb24", macro_block_size=16,
                                     ffmpeg_log_level="error")
        writer.send(None)
        try:
            for k in range(scene.n_out):
                img = Image.new("RGB", (W, H), back)
                img.paste(scene.frame(k).convert("RGB"), (0, 0))
                writer.send(img.tobytes())
                bar.update(1)
        finally:
            writer.close()
    return scene.n_out


def _write_strip(scene: _Scene, path: str | os.PathLike[str], n: int,
                 make_bar: BarFactory) -> int:
    from PIL import Image
    n = min(n, scene.n_out)
    ks = np.unique(np.round(np.linspace(0, scene.n_out - 1, n)).astype(int))
    w, h, M = scene.w, scene.h, len(scene.motions)
    strip = Image.new("P", (w * len(ks), h * M), _INDEX["background"])
    strip.putpalette(scene.palette)
    with make_bar(len(ks), "rendering", "frame") as bar:
        for c, k in enumerate(ks):
            frame = scene.frame(int(k))
            for i in range(M):
                strip.paste(frame.crop((i * w, 0, (i + 1) * w, h)), (c * w, i * h))
            bar.update(1)
    with atomic_output(path, ".png") as tmp:
        strip.save(tmp, format="PNG")
    return len(ks)


def render_gif(motions: Iterable[Motion], path: str | os.PathLike[str], *,
               labels: Iterable[str] | None = None, fps: float = 30.0,
               panel_size: tuple[int, int] = (320, 380), azimuth: float = 35.0,
               elevation: float = 12.0, max_seconds: float | None = None,
               progress: ProgressArg = None) -> int:
    """Render motions side by side into an animated GIF (written atomically).

    The GIF is written whatever the path's extension; :func:`render` chooses the format by
    extension. Needs Pillow (the ``render`` extra).

    Parameters
    ----------
    motions : iterable of Motion
        The motions (anything with ``positions()``, ``parents``, ``joint_names``, ``fps``),
        one panel each.
    path : str or os.PathLike
        The output.
    labels : iterable of str, optional
        One caption per panel (default ``"0"``, ``"1"``, ...).
    fps : float, optional
        Frame rate of the GIF; each panel shows its motion's frame nearest in time. GIF delays
        are whole centiseconds: they alternate (30, 40, 30 ms at 30 fps) so that the GIF lasts
        as long as the motion; above 50 fps frames last 20 ms (browsers slow shorter ones).
    panel_size : tuple of int, optional
        (width, height) of one panel in pixels.
    azimuth, elevation : float, optional
        Camera direction in degrees (azimuth about the vertical axis).
    max_seconds : float, optional
        Render only the first seconds of the clips.
    progress : None, bool, stream or callable, optional
        A progress bar over the frames: None (on stderr when it is a terminal and tqdm is
        installed), True, False, a stream, or a callable ``f(done, total)`` called as frames
        are drawn.

    Returns
    -------
    int
        The number of GIF frames written.

    Raises
    ------
    mlayer.MissingDependencyError
        Without Pillow, before any work.
    mlayer.InvalidArgumentError
        For bad arguments (no motions, a label count that differs, fps not positive).
    """
    require("PIL", feature="mlayer.render_gif")
    make_bar = resolve(progress, "mlayer.render_gif")
    scene = _Scene(motions, labels, fps, panel_size, azimuth, elevation, max_seconds,
                   "render_gif")
    frames = []
    with make_bar(scene.n_out, "rendering", "frame") as bar:
        for k in range(scene.n_out):
            frames.append(scene.frame(k))
            bar.update(1)
    with atomic_output(path, ".gif") as tmp:
        frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:],
                       duration=gif_delays(scene.n_out, fps), loop=0, optimize=False)
    return scene.n_out


def gif_delays(n: int, fps: float) -> list[int]:
    """The delays (ms, multiples of 10) of n GIF frames at fps: GIF counts centiseconds, so
    each delay is the step between the rounded times of its frame and the next, and the clip
    keeps its length (a constant round(1000 / fps) became 30 ms at 30 fps in the file: 10%
    fast). At least 20 ms each: browsers play 0 or 10 ms as 100 ms."""
    cs = [int(round(100.0 * k / fps)) for k in range(n + 1)]
    return [10 * max(2, cs[k + 1] - cs[k]) for k in range(n)]
