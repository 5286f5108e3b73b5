"""Stick-figure animations of motions, side by side under one camera, written as GIF.

Drawing is done with Pillow directly (an orthographic camera, one panel per motion, a ground
grid), which is fast enough to render a whole clip in a second or two and needs nothing beyond
the package's dependencies. Motions are assumed Y-up, as BVH files almost always are.

Every panel uses the same camera: the same scale, the same view direction and the same target,
which follows the first motion across the ground (its first joint that moves: the root, or the
hips under a root that stays at the origin as Bandai's ``joint_Root``), so differences between
the panels (denoised, exaggerated, retimed) are differences of the motions, not of the framing.
"""
from __future__ import annotations

import math
import re

import numpy as np

from .metrics import body_height
from .up_axis import to_y_up

from ._files import atomic_output
from .errors import InvalidArgumentError

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
    "left": (re.compile(r"(^left|left$|^l_|_l$|\.l$)", re.IGNORECASE), re.compile(r"^[lL](?=[A-Z])")),
    "right": (re.compile(r"(^right|right$|^r_|_r$|\.r$)", re.IGNORECASE), re.compile(r"^[rR](?=[A-Z])")),
}


def body_side(name: str) -> str:
    """'left', 'right' or 'center' from a joint name, for the naming schemes of common rigs
    (CMU "LeftUpLeg", Daz "lThigh", Bandai "UpperLeg_L", Blender "thigh.L")."""
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


def followed_joint(positions: np.ndarray) -> int:
    """The joint the camera follows: the first joint (in skeleton order, so the root or the
    joint nearest to it) whose horizontal position moves by more than 1% of the body's height
    over the clip; joint 0 when none does. Rigs such as Bandai's keep a ``joint_Root`` at the
    origin and move the body with the hips below it."""
    p = np.asarray(positions, dtype=np.float64)
    height = body_height(p, "y") or 1.0
    xz = p[:, :, [0, 2]]
    moved = np.linalg.norm(xz - xz[:1], axis=-1).max(axis=0) > 0.01 * height
    return int(np.argmax(moved)) if moved.any() else 0


def render_gif(motions, path, *, labels=None, fps: float = 30.0, panel_size=(320, 380),
               azimuth: float = 35.0, elevation: float = 12.0, max_seconds: float | None = None,
               progress=None) -> int:
    """Render motions side by side into an animated GIF at `path` (written atomically).

    motions      Motion objects (anything with `positions()`, `parents`, `joint_names`, `fps`).
    labels       one caption per panel (default "0", "1", ...).
    fps          frame rate of the GIF; each panel shows its motion's frame nearest in time.
    panel_size   (width, height) of one panel in pixels.
    azimuth, elevation   camera direction in degrees (azimuth about the vertical axis).
    max_seconds  render only the first seconds of the clips.
    progress     optional callable(done, total) called as frames are drawn.
    Returns the number of GIF frames written.
    """
    from PIL import Image, ImageDraw  # Pillow comes with matplotlib

    motions = list(motions)
    if not motions:
        raise InvalidArgumentError("render_gif: no motions given")
    if labels is None:
        labels = [str(i) for i in range(len(motions))]
    if len(labels) != len(motions):
        raise InvalidArgumentError(f"render_gif: {len(labels)} labels for {len(motions)} motions")
    if not (math.isfinite(fps) and fps > 0):
        raise InvalidArgumentError(f"render_gif: fps must be positive, got {fps}")
    pos = [to_y_up(getattr(m, "up_axis", "y"), np.asarray(m.positions(), dtype=np.float64))
           for m in motions]
    for p, m in zip(pos, motions):
        if p.shape[0] == 0:
            raise InvalidArgumentError("render_gif: a motion has no frames")
    duration = max(p.shape[0] / m.fps for p, m in zip(pos, motions))
    if max_seconds is not None:
        duration = min(duration, max_seconds)
    n_out = max(1, int(round(duration * fps)))

    # one camera for every panel: scale from the first motion's height, target following it
    cam = _camera(azimuth, elevation)
    p0 = pos[0]
    ground = min(float(np.percentile(p[:, :, 1], 0.5)) for p in pos)
    height = float(np.percentile(p0[:, :, 1].max(axis=1) - ground, 50)) or 1.0
    w, h = panel_size
    scale = 0.62 * h / height
    track = _smooth_track(p0[:, followed_joint(p0), [0, 2]], max(1, int(motions[0].fps)))

    spacing = height / 2.0
    palette = [c for rgb in _PALETTE.values() for c in rgb]
    blank = Image.new("P", (w, h), _INDEX["background"])
    blank.putpalette(palette)
    sides = [[body_side(n) for n in m.joint_names] for m in motions]
    frames = []
    for k in range(n_out):
        t = k / fps
        f0 = min(int(round(t * motions[0].fps)), p0.shape[0] - 1)
        target = np.array([track[f0, 0], ground + 0.45 * height, track[f0, 1]])

        def project(world):
            v = (np.asarray(world) - target) @ cam.T
            return np.stack([w / 2 + scale * v[..., 0], h / 2 - scale * v[..., 1]], -1)

        frame = Image.new("P", (w * len(motions), h), _INDEX["background"])
        frame.putpalette(palette)
        for i, (p, m) in enumerate(zip(pos, motions)):
            panel = blank.copy()  # each panel is drawn on its own, clipped to its box
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
                    draw.line([tuple(xy[par]), tuple(xy[j])], fill=_INDEX[sides[i][j]], width=3)
            for x, y in xy:
                draw.ellipse([x - 1.5, y - 1.5, x + 1.5, y + 1.5], fill=_INDEX["joint"])
            draw.text((8, 6), f"{labels[i]}", fill=_INDEX["text"])
            if i:
                draw.line([(0, 0), (0, h)], fill=_INDEX["grid"], width=1)
            else:
                draw.text((8, h - 16), f"{t:5.2f} s", fill=_INDEX["text"])
            frame.paste(panel, (i * w, 0))
        frames.append(frame)
        if progress is not None:
            progress(k + 1, n_out)

    with atomic_output(path, ".gif") as tmp:
        frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:],
                       duration=int(round(1000 / fps)), loop=0, optimize=False)
    return n_out
