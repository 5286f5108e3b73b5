"""The viewer's data side: the clips named on the command line, request parameters, and the
processing pipeline each slider move runs (no HTTP here; see :mod:`mlayer.viewer.server`).

Per clip, the decomposition (mlayer.decompose), the contacts of the original and its metrics
are computed once and cached; a request is then only

    synthesize(alpha per joint)                    C core, eq. 16-17
    (+ residual when denoising is off)             q * exp(residual), C quaternion kernels
    the guards (mlayer.pipeline.Synthesis)         joint limits, contacts, floor (mlr_guards)
    timewarp (length, strength), resample (fps)    C LGS solves

followed by forward kinematics for the figure and the metrics.
"""
from __future__ import annotations

import base64
import math
import os
import re
import tempfile
import threading
import time
from collections import OrderedDict
from urllib.parse import parse_qsl

import numpy as np

from .. import quat
from ..bvh import read_bvh, write_bvh_string
from ..errors import Error, InvalidArgumentError
from ..layers import decompose
from ..pipeline import Synthesis
from ..metrics import body_height, foot_sliding, jitter
from ..render import body_side
from ..resample import resample, timewarp

__all__ = ["Clip", "load_clips", "body_parts", "parse_params", "ParamError", "PARAMS",
           "PART_NAMES"]

#: body parts with their own alpha slider; every joint belongs to exactly one
PART_NAMES = ("arms", "legs", "spine")
# keyword lists (case-insensitive) over the rigs of the shared clips and common exporters
_ARM_WORDS = re.compile(r"shoulder|shldr|clavicle|collar|arm|elbow|hand|wrist|finger|thumb|"
                        r"index|middle|ring|pinky|carpal|palm", re.IGNORECASE)
_LEG_WORDS = re.compile(r"hip|upleg|thigh|leg|knee|shin|calf|foot|ankle|toe|ball|heel|"
                        r"paw|hoof|buttock", re.IGNORECASE)


def body_parts(names, parents) -> list[str]:
    """'arms', 'legs' or 'spine' (spine, neck, head, root, tail) per joint, from its name.

    A joint on the left or right side (:func:`mlayer.render.body_side`) whose name matches an arm
    or leg keyword is that part (a centre-line joint only below a joint of that part); any
    other joint takes its parent's part (an eye under the head, a MakeHuman toe under a foot);
    the root and the centre line (spine, neck, head, tail) are the spine."""
    out: list[str] = []
    for j, name in enumerate(names):
        p = int(parents[j])
        if p < 0:
            out.append("spine")
            continue
        sided = body_side(name) != "center" or (  # MakeHuman's "lhip", "rcollar"
            name[:1] in "lr" and bool(_LEG_WORDS.match(name[1:]) or _ARM_WORDS.match(name[1:])))
        if _LEG_WORDS.search(name) and (sided or out[p] == "legs"):
            out.append("legs")
        elif _ARM_WORDS.search(name) and (sided or out[p] == "arms"):
            out.append("arms")
        else:
            out.append(out[p])
    return out


# ---- request parameters ---------------------------------------------------------------------

class ParamError(Exception):
    """A bad request: ``status`` is the HTTP status (400 bad parameter, 404 unknown clip,
    409 a clip that failed to load), the message says what and why."""

    def __init__(self, message: str, status: int = 400):
        super().__init__(message)
        self.status = status


#: name -> (kind, low, high, default). Floats must be finite and within [low, high].
PARAMS = {
    "clip": ("int", 0, None, None),
    "alpha": ("float", 0.0, 4.0, 1.0),
    "arms": ("float", 0.0, 4.0, None),      # None: the global alpha
    "legs": ("float", 0.0, 4.0, None),
    "spine": ("float", 0.0, 4.0, None),
    "denoise": ("bool", None, None, True),
    "contacts": ("bool", None, None, True),
    "length": ("float", 0.01, 36000.0, None),   # seconds; None: the clip's own
    "fps": ("float", 1.0, 1000.0, None),        # None: the clip's own
    "warp": ("float", 0.0, 5.0, 0.0),
    "joint": ("int", 0, None, None),            # the joint of the layer chart
}
_LENGTH_RATIO = (0.1, 10.0)   # target length / clip length


def parse_params(query: str, allowed) -> dict:
    """Validate a query string against :data:`PARAMS`: every key known and in ``allowed``,
    given once, a number that is finite and in range (or 0/1/true/false). Returns name ->
    value for every allowed key (defaults filled in). Raises ParamError (400)."""
    try:
        pairs = parse_qsl(query, keep_blank_values=True, strict_parsing=bool(query),
                          max_num_fields=len(allowed) + 1)
    except ValueError as e:
        raise ParamError(f"malformed query string: {e}") from None
    seen: dict = {}
    for key, raw in pairs:
        if key not in allowed:
            raise ParamError(f"unknown parameter {key!r}; expected: {', '.join(allowed)}")
        if key in seen:
            raise ParamError(f"parameter {key!r} given twice")
        seen[key] = raw
    out = {}
    for key in allowed:
        kind, lo, hi, default = PARAMS[key]
        if key not in seen:
            out[key] = default
            continue
        raw = seen[key].strip()
        if kind == "bool":
            low = raw.lower()
            if low not in ("0", "1", "true", "false"):
                raise ParamError(f"{key} must be 0, 1, true or false, got {raw!r}")
            out[key] = low in ("1", "true")
            continue
        if kind == "int":
            if not re.fullmatch(r"[0-9]{1,9}", raw):
                raise ParamError(f"{key} must be a non-negative integer, got {raw!r}")
            out[key] = int(raw)
            continue
        try:
            v = float(raw)
        except ValueError:
            raise ParamError(f"{key} must be a number, got {raw!r}") from None
        if not math.isfinite(v):
            raise ParamError(f"{key} must be finite, got {raw!r}")
        if not lo <= v <= hi:
            raise ParamError(f"{key} must be in [{lo:g}, {hi:g}], got {raw!r}")
        out[key] = v
    return out


# ---- clips ----------------------------------------------------------------------------------

def _b64(a, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _points(m) -> np.ndarray:
    """(N, J + E, 3): joint positions, then End Site positions (the figure's points)."""
    pos = m.positions()
    if m.skeleton.n_end_sites == 0:
        return pos
    return np.concatenate([pos, m.end_site_positions()], axis=1)


def _angle_deg(q) -> np.ndarray:
    return np.degrees(np.linalg.norm(quat.log(q), axis=-1))


def _decimate(n: int, most: int = 1500) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(np.int64))


class Clip:
    """One clip named on the command line: its motion (or the error that stopped it) and the
    per-clip caches. Thread-safe: one lock serializes the work on a clip."""

    def __init__(self, index: int, path: str):
        self.index = index
        self.path = path
        self.name = os.path.basename(path)
        self.motion = None
        self.error = None
        self._lock = threading.Lock()
        self._layers = None
        self._contacts = None
        self._original = None
        self._plot_png = None
        self._results: OrderedDict = OrderedDict()
        try:
            self.motion = read_bvh(path)
            if self.motion.n_frames < 4:
                raise InvalidArgumentError(f"{path}: {self.motion.n_frames} frames; the viewer "
                                           f"needs at least 4")
        except (Error, OSError) as e:
            self.motion, self.error = None, str(e) or e.__class__.__name__
            if isinstance(e, OSError) and e.strerror:
                self.error = f"{path}: {e.strerror}"

    @property
    def ok(self) -> bool:
        return self.motion is not None

    def summary(self) -> dict:
        d = {"index": self.index, "name": self.name, "error": self.error}
        if self.ok:
            m = self.motion
            d.update(frames=m.n_frames, fps=m.fps, joints=m.n_joints, duration=m.duration)
        return d

    # -- cached per clip (call with the lock held) --

    def _ensure(self):
        if self._layers is None:
            m = self.motion
            t0 = time.perf_counter()
            self._layers = decompose(m)
            self._decompose_ms = 1e3 * (time.perf_counter() - t0)
            self._height = body_height(m) or 1.0
            # the guards with and without the foot cleanup (contacts and floor), sharing the
            # layers; the joint limits apply in both when some alpha > 1
            self._synth = {on: Synthesis(m, layers=self._layers, keep_contacts=on,
                                         floor="auto" if on else None)
                           for on in (True, False)}
            self._contacts = self._synth[True].contacts()
            names, c = self._contacts
            self._parts = body_parts(m.joint_names, m.parents)
            ctrl = np.asarray(self._layers.control)
            self._plot_joint = int(np.argmax(np.linalg.norm(ctrl[:, 1:, :], axis=-1)
                                             .std(axis=0)))
            self._original_metrics = self._metrics(m, c, names)
        return self._layers

    def _metrics(self, m, c, names) -> dict:
        h = self._height
        slide = foot_sliding(m, c, names) / h if names else float("nan")
        return {"jitter": jitter(m, fps=m.fps) / h,
                "sliding": None if not math.isfinite(slide) else slide}

    def warm(self) -> None:
        """Decompose now (the server does this in the background after it starts)."""
        if self.ok:
            with self._lock:
                self._ensure()

    def original(self) -> dict:
        """The figure data of the original: skeleton, points, contacts, metrics (cached)."""
        with self._lock:
            self._ensure()
            if self._original is None:
                m = self.motion
                sk = m.skeleton
                names, c = self._contacts
                pts = _points(m)
                parents = list(map(int, sk.parents)) + list(map(int, sk.end_site_parents))
                sides = [body_side(n) for n in m.joint_names]
                sides += [sides[p] for p in map(int, sk.end_site_parents)]
                self._original = {
                    "index": self.index, "name": self.name, "frames": m.n_frames,
                    "fps": m.fps, "duration": m.duration, "height": self._height,
                    "joint_names": list(m.joint_names), "parents": parents, "sides": sides,
                    "parts": self._parts, "n_points": pts.shape[1],
                    "positions": _b64(pts, np.float32),
                    "contact_names": names,
                    "contact_points": _b64(self._contact_points(m, names), np.float32),
                    "contacts": _b64(c, np.uint8),
                    "metrics": self._original_metrics,
                    "decompose_ms": self._decompose_ms,
                    "plot_joint": self._plot_joint,
                }
            return self._original

    def _contact_points(self, m, names) -> np.ndarray:
        if not names:
            return np.zeros((m.n_frames, 0, 3))
        from ..contacts import contact_positions
        return contact_positions(m, names)

    def process(self, p: dict) -> tuple[dict, object]:
        """Run the pipeline for validated parameters ``p`` (see :func:`parse_params`); returns
        (figure data for the page, the processed Motion). The last few results are cached."""
        key = tuple(sorted((k, v) for k, v in p.items() if k not in ("clip", "joint")))
        with self._lock:
            L = self._ensure()
            hit = self._results.get(key)
            cached = hit is not None
            if hit is None:
                hit = self._run(L, p)
                self._results[key] = hit
                while len(self._results) > 4:
                    self._results.popitem(last=False)
            else:
                self._results.move_to_end(key)
            info, out, src = hit
            data = self._response(info, out, src, p)
            data["cached"] = cached
            return data, out

    def _run(self, L, p):
        m = self.motion
        t0 = time.perf_counter()
        alpha = p["alpha"]
        joints = {}
        for name, part in zip(m.joint_names, self._parts):  # the root joint is "spine"
            if p.get(part) is not None:
                joints[_glob_escape(name)] = p[part]
        # the root translation follows the global alpha
        out, _report = self._synth[bool(p["contacts"])].run(
            alpha, joints or None, root_alpha=alpha, residual=not p["denoise"])
        names, c = self._contacts
        src = np.arange(m.n_frames, dtype=np.float64)   # input frame of each output frame
        N = m.n_frames
        n_len = N
        if p["length"] is not None:
            ratio = p["length"] / m.duration if m.duration > 0 else 1.0
            if not _LENGTH_RATIO[0] <= ratio <= _LENGTH_RATIO[1]:
                raise ParamError(f"length must be within {_LENGTH_RATIO[0]:g}x to "
                                 f"{_LENGTH_RATIO[1]:g}x of the clip's {m.duration:.3f} s, got "
                                 f"{p['length']:g} s")
            n_len = max(4, int(round(p["length"] * m.fps)))
        if n_len != N or p["warp"] > 0:
            out, t = timewarp(out, strength=p["warp"], n_frames=n_len, return_map=True)
            src = np.interp(np.arange(out.n_frames), t, src)
        if p["fps"] is not None and abs(p["fps"] - out.fps) > 1e-9 * out.fps:
            n1 = out.n_frames
            out = resample(out, fps=p["fps"])
            k = np.arange(out.n_frames) * (out.frame_time * m.fps)
            src = np.interp(np.minimum(k, n1 - 1), np.arange(n1), src)
        c_out = c[np.clip(np.rint(src).astype(np.int64), 0, N - 1)] if names else \
            np.zeros((out.n_frames, 0), dtype=bool)
        info = {"compute_ms": 1e3 * (time.perf_counter() - t0)}
        info["metrics"] = self._metrics(out, c_out, names)
        info["contacts"] = c_out
        return info, out, src

    def _response(self, info, out, src, p) -> dict:
        m = self.motion
        names, _ = self._contacts
        j = self._plot_joint if p.get("joint") is None else p["joint"]
        if j >= m.n_joints:
            raise ParamError(f"joint must be below {m.n_joints} for {self.name}, got {j}")
        L = self._layers
        io, ip = _decimate(m.n_frames), _decimate(out.n_frames)
        q_ctrl = quat.mul(L.base.rot[:, j], quat.exp(np.asarray(L.control)[:, 1 + j]))
        return {
            "clip": self.index, "frames": out.n_frames, "fps": out.fps,
            "duration": out.duration, "n_points": m.n_joints + m.skeleton.n_end_sites,
            "positions": _b64(_points(out), np.float32),
            "contact_points": _b64(self._contact_points(out, names), np.float32),
            "contacts": _b64(info["contacts"], np.uint8),
            "source_frame": _b64(src, np.float32),
            "metrics": info["metrics"], "compute_ms": info["compute_ms"],
            "plot": {
                "joint": j, "joint_name": m.joint_names[j],
                "t": (io / m.fps).tolist(),
                "original": _angle_deg(m.rot[io, j]).tolist(),
                "base": _angle_deg(L.base.rot[io, j]).tolist(),
                "control": _angle_deg(q_ctrl[io]).tolist(),
                "t_processed": (ip / out.fps).tolist(),
                "processed": _angle_deg(out.rot[ip, j]).tolist(),
            },
        }

    def download(self, p: dict) -> tuple[str, str]:
        """(file name, BVH text) of the processed motion."""
        _, out = self.process(p)
        stem = os.path.splitext(self.name)[0]
        return f"{stem}_processed.bvh", write_bvh_string(out)

    def layers_png(self) -> bytes:
        """The layer figure of `mlayer layers` (plot.py, matplotlib) as PNG bytes (cached)."""
        with self._lock:
            L = self._ensure()
            if self._plot_png is None:
                from ..plot import plot_layers
                fd, tmp = tempfile.mkstemp(suffix=".png")
                os.close(fd)
                try:
                    plot_layers(self.motion, L, tmp, title=f"{self.name}: layers")
                    with open(tmp, "rb") as f:
                        self._plot_png = f.read()
                finally:
                    os.unlink(tmp)
            return self._plot_png


def _glob_escape(name: str) -> str:
    """A joint name as an fnmatch pattern that matches only itself."""
    return "".join(f"[{ch}]" if ch in "*?[" else ch for ch in name)


def load_clips(paths) -> list[Clip]:
    """Parse every path; a clip that fails keeps its error (see :attr:`Clip.error`)."""
    return [Clip(i, os.fspath(p)) for i, p in enumerate(paths)]
