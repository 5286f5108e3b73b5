"""The viewer's data side: the clips named on the command line, request parameters, and the
processing pipeline each slider move runs (no HTTP here; see :mod:`mlayer.viewer.server`).

Per clip, the decomposition (mlayer.decompose), the contacts of the original and its metrics
are computed once and cached; a request is then only

    synthesize(alpha per joint)                    C core, eq. 16-17
    (+ residual when denoising is off)             q * exp(residual), C quaternion kernels
    the guards (mlayer.Synthesis)                  joint limits, contacts, floor (mlr_guards)
    timewarp (length, strength), resample (fps)    C LGS solves

followed by forward kinematics for the figure and the metrics.
"""
from __future__ import annotations

import base64
import json
import math
import os
import re
import threading
import time
from collections import OrderedDict
from collections.abc import Collection, Hashable, Iterable, Sequence
from typing import TYPE_CHECKING, Any
from urllib.parse import parse_qsl

import numpy as np
from numpy.typing import NDArray

from ..errors import Error, InvalidArgumentError
from ..guards.contacts import contact_positions
from ..guards.metrics import foot_sliding, jitter
from ..io.bvh import read_bvh, write_bvh_string
from ..layers.alpha_curve import AlphaCurve
from ..model import quat
from ..pipeline import pipeline
from ..pipeline.retiming import frames_at_rate, resample, timewarp
from ..plotting.plot import plot_layers
from ..plotting.render import body_side

if TYPE_CHECKING:
    from ..model.motion import Motion

__all__ = ["ViewerClip", "load_clips", "body_parts", "parse_params", "ParamError", "PARAMS",
           "PART_NAMES", "ResultCache", "json_bytes", "DEFAULT_MAX_VALUES",
           "DEFAULT_CACHE_BYTES"]

#: the most output one request may produce: frames x points (joints and End Sites), checked
#: before any work (a clip is always served at its own size, whatever the limit)
DEFAULT_MAX_VALUES = 2_000_000
#: the byte bound of the result cache (processed motions and encoded answers)
DEFAULT_CACHE_BYTES = 256 << 20

#: body parts with their own alpha slider; every joint belongs to exactly one
PART_NAMES = ("arms", "legs", "spine")
# keyword lists (case-insensitive) over the rigs of the shared clips and common exporters
_ARM_WORDS = re.compile(r"shoulder|shldr|clavicle|collar|arm|elbow|hand|wrist|finger|thumb|"
                        r"index|middle|ring|pinky|carpal|palm", re.IGNORECASE)
_LEG_WORDS = re.compile(r"hip|upleg|thigh|leg|knee|shin|calf|foot|ankle|toe|ball|heel|"
                        r"paw|hoof|buttock", re.IGNORECASE)


def body_parts(names: Sequence[str], parents: Sequence[int] | NDArray[np.int32]) -> list[str]:
    """The body part of every joint, from its name.

    A joint on the left or right side (:func:`mlayer.plotting.render.body_side`) whose name matches
    an arm or leg keyword is that part (a centre-line joint only below a joint of that part); any
    other joint takes its parent's part (an eye under the head, a MakeHuman toe under a foot);
    the root and the centre line (spine, neck, head, tail) are the spine.

    Parameters
    ----------
    names : sequence of str
        The joint names.
    parents : sequence of int
        The parents (-1 for the root).

    Returns
    -------
    list of str
        ``"arms"``, ``"legs"`` or ``"spine"`` per joint.
    """
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
    """A bad request; the message says what and why.

    Parameters
    ----------
    message : str
        What and why.
    status : int, optional
        The HTTP status: 400 bad parameter, 404 unknown clip, 409 a clip that failed to load,
        413 a request over the output limit.
    """

    def __init__(self, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.status = status


#: name -> (kind, low, high, default). Floats must be finite and within [low, high].
PARAMS: dict[str, tuple[str, float | None, float | None, float | bool | None]] = {
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
    # alpha over time: "t:a,t:a,..." (seconds of the input clip, alphas within alpha's range),
    # replacing the global alpha; None: the constant global alpha
    "keys": ("keys", 0.0, 4.0, None),
}
_MAX_KEYS = 64
_LENGTH_RATIO = (0.1, 10.0)   # target length / clip length
_MAX_FPS_FACTOR = 100.0       # new fps / clip fps, either way (mlayer.resample's limit)


def query_pairs(query: str, allowed: Collection[str]) -> dict[str, str]:
    """The raw values of a query string by name: every key in ``allowed``, given once.
    Raises ParamError (400)."""
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
    return seen


def finite_number(raw: str, name: str) -> float:
    """A parameter's value as a finite float; ParamError (400) naming it otherwise."""
    try:
        v = float(raw)
    except ValueError:
        raise ParamError(f"{name} must be a number, got {raw!r}") from None
    if not math.isfinite(v):
        raise ParamError(f"{name} must be finite, got {raw!r}")
    return v


def parse_params(query: str, allowed: Collection[str]) -> dict[str, Any]:
    """Validate a query string against :data:`PARAMS`.

    Every key known and in ``allowed``, given once, a number that is finite and in range (or
    0/1/true/false).

    Parameters
    ----------
    query : str
        The query string.
    allowed : collection of str
        The parameter names the request may give.

    Returns
    -------
    dict
        Name -> value for every allowed key (defaults filled in).

    Raises
    ------
    ParamError
        (400) For anything else.
    """
    seen = query_pairs(query, allowed)
    out: dict[str, Any] = {}
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
        if kind == "keys":
            out[key] = _alpha_keys(raw, key, lo, hi) if raw else None
            continue
        if kind == "int":
            if not re.fullmatch(r"[0-9]{1,9}", raw):
                raise ParamError(f"{key} must be a non-negative integer, got {raw!r}")
            out[key] = int(raw)
            continue
        v = finite_number(raw, key)
        assert lo is not None and hi is not None  # every number parameter has a range
        if not lo <= v <= hi:
            raise ParamError(f"{key} must be in [{lo:g}, {hi:g}], got {raw!r}")
        out[key] = v
    return out


def _alpha_keys(raw: str, name: str, lo: float | None, hi: float | None) -> str:
    """The keys of an alpha curve, checked (at most _MAX_KEYS, alphas in [lo, hi], times in
    [0, 36000] s), in their canonical text; ParamError (400) naming the key otherwise."""
    if raw.count(",") >= _MAX_KEYS:
        raise ParamError(f"{name}: at most {_MAX_KEYS} keys")
    try:
        c = AlphaCurve.parse(raw)
    except InvalidArgumentError as e:
        raise ParamError(f"{name}: {e}") from None
    assert lo is not None and hi is not None
    for k, (t, a) in enumerate(c.keys):
        if not lo <= a <= hi:
            raise ParamError(f"{name}: the alpha of key {k} must be in [{lo:g}, {hi:g}], "
                             f"got {a:g}")
        if not 0.0 <= t <= 36000.0:
            raise ParamError(f"{name}: the time of key {k} must be in [0, 36000] s, got {t:g}")
    return str(c)


# ---- answers and the result cache ----------------------------------------------------------

def _json_default(o):
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


def _clean(o):
    """JSON has no NaN/inf: map them to null."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, list):
        return [_clean(v) for v in o]
    return o


def json_bytes(obj: Any) -> bytes:
    """An object as compact JSON.

    Parameters
    ----------
    obj : object
        Dicts, lists, numbers, strings, numpy arrays and scalars.

    Returns
    -------
    bytes
        UTF-8 JSON; NaN and infinities as null.
    """
    return json.dumps(_clean(obj), separators=(",", ":"), allow_nan=False,
                      default=_json_default).encode()


class ResultCache:
    """A thread-safe LRU cache bounded by bytes.

    ``put(key, value, nbytes)`` evicts the least recently used entries until the total is at
    most ``max_bytes``; an entry larger than the bound is not kept. ``nbytes`` is the caller's
    measure of the value (its arrays, its encoded bytes).

    Parameters
    ----------
    max_bytes : int, optional
        The bound.
    """
    max_bytes: int
    bytes: int

    def __init__(self, max_bytes: int = DEFAULT_CACHE_BYTES) -> None:
        self.max_bytes = int(max_bytes)
        self.bytes = 0
        self._d: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._d)

    def get(self, key: Hashable) -> Any:
        """The value of a key, now the most recently used, or None.

        Parameters
        ----------
        key : hashable
            The key.

        Returns
        -------
        object or None
            The value.
        """
        with self._lock:
            hit = self._d.get(key)
            if hit is None:
                return None
            self._d.move_to_end(key)
            return hit[0]

    def put(self, key: Hashable, value: Any, nbytes: int) -> None:
        """Keep a value, evicting the least recently used entries beyond the bound.

        Parameters
        ----------
        key : hashable
            The key.
        value : object
            The value.
        nbytes : int
            Its size as the caller measures it; larger than the bound: not kept.
        """
        nbytes = int(nbytes)
        with self._lock:
            old = self._d.pop(key, None)
            if old is not None:
                self.bytes -= old[1]
            if nbytes > self.max_bytes:
                return
            self._d[key] = (value, nbytes)
            self.bytes += nbytes
            while self.bytes > self.max_bytes:
                _, (_, n) = self._d.popitem(last=False)
                self.bytes -= n


def _nbytes(*objs) -> int:
    """The bytes of the arrays in ``objs`` (Motions: root_pos, rot, trans), plus 1 KiB each."""
    total = 0
    for o in objs:
        if hasattr(o, "rot"):
            total += sum(np.asarray(a).nbytes for a in (o.root_pos, o.rot, o.trans)
                         if a is not None)
        elif o is not None:
            total += np.asarray(o).nbytes
        total += 1024
    return total


# ---- clips ----------------------------------------------------------------------------------

def _b64(a, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _points(m, fk=None) -> np.ndarray:
    """(N, J + E, 3): joint positions, then End Site positions (the figure's points), from one
    forward-kinematics pass (or from fk, the motion's (positions, world rotations))."""
    pos, wrot = m.forward_kinematics() if fk is None else fk
    if m.skeleton.n_end_sites == 0:
        return pos
    return np.concatenate([pos, m._end_sites(pos, wrot)], axis=1)


def _angle_deg(q) -> np.ndarray:
    return np.degrees(np.linalg.norm(quat.log(q), axis=-1))


def _decimate(n: int, most: int = 1500) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(np.int64))


class ViewerClip:
    """One clip named on the command line: its motion (or the error that stopped it).

    Thread-safe: one lock serializes the work on a clip; answers already in the cache are
    served without it.

    Parameters
    ----------
    index : int
        The clip's index in the server.
    path : str
        The BVH file (read here; an error is kept in ``error``).
    cache : ResultCache, optional
        Shared by the clips of a server: keeps processed motions and encoded answers.
    max_values : int, optional
        Caps the frames x points of one request's output (and of its intermediate retiming),
        never below the clip's own size.
    """
    name: str
    cache: ResultCache

    def __init__(self, index: int, path: str, *, cache: ResultCache | None = None,
                 max_values: int = DEFAULT_MAX_VALUES) -> None:
        self.index = index
        self.path = path
        self.name = os.path.basename(path)
        # Any: None until read (``ok``); the methods that use it run only for a clip that is ok
        self.motion: Any = None
        self.error: str | None = None
        self.cache = cache if cache is not None else ResultCache()
        self.max_values = max_values
        self._lock = threading.Lock()
        # made on first use (under the lock)
        self._layers: Any = None
        self._contacts: Any = None
        self._original: Any = None
        self._original_body: Any = None
        self._plot_png: Any = None
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
        """Whether the clip was read."""
        return self.motion is not None

    def summary(self) -> dict[str, Any]:
        """The clip's line of the clip list.

        Returns
        -------
        dict
            ``index``, ``name``, ``error``; and ``frames``, ``fps``, ``joints``, ``duration``
            when the clip was read.
        """
        d = {"index": self.index, "name": self.name, "error": self.error}
        if self.ok:
            m = self.motion
            d.update(frames=m.n_frames, fps=m.fps, joints=m.n_joints, duration=m.duration)
        return d

    # -- cached per clip (call with the lock held) --

    def _ensure(self):
        if self._layers is None:
            m = self.motion
            clip = pipeline.Clip(m, name=self.path)
            t0 = time.perf_counter()
            self._layers = clip.layers()
            self._decompose_ms = 1e3 * (time.perf_counter() - t0)
            self._height = clip.body_height or 1.0
            # the guards with and without the foot cleanup (contacts and floor), sharing the
            # layers; the joint limits apply in both when some alpha > 1
            self._synth = {on: clip.synthesis(keep_contacts=on, floor="auto" if on else None)
                           for on in (True, False)}
            self._contacts = self._synth[True].contacts()
            names, c = self._contacts
            self._parts = body_parts(m.joint_names, m.parents)
            ctrl = np.asarray(self._layers.control)
            self._plot_joint = int(np.argmax(np.linalg.norm(ctrl[:, 1:, :], axis=-1)
                                             .std(axis=0)))
            self._fk = clip.forward_kinematics
            self._original_metrics = self._metrics(m, c, names, self._fk)
        return self._layers

    def _metrics(self, m, c, names, fk=None) -> dict:
        """Jitter and foot sliding of m in body heights, from one forward-kinematics pass (or
        from fk, m's (positions, world rotations))."""
        h = self._height
        pos, wrot = m.forward_kinematics() if fk is None else fk
        slide = foot_sliding(m, c, names, pos=pos, wrot=wrot) / h if names else float("nan")
        return {"jitter": jitter(pos, fps=m.fps) / h,
                "sliding": None if not math.isfinite(slide) else slide}

    def warm(self) -> None:
        """Decompose now (the server does this in the background after it starts)."""
        if self.ok:
            with self._lock:
                self._ensure()

    def original(self) -> dict[str, Any]:
        """The figure data of the original (cached).

        Returns
        -------
        dict
            Skeleton, points, contacts, metrics.
        """
        with self._lock:
            self._ensure()
            if self._original is None:
                m = self.motion
                sk = m.skeleton
                names, c = self._contacts
                pts = _points(m, self._fk)
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
                    "contact_points": _b64(self._contact_points(m, names, self._fk),
                                             np.float32),
                    "contacts": _b64(c, np.uint8),
                    "metrics": self._original_metrics,
                    "decompose_ms": self._decompose_ms,
                    "plot_joint": self._plot_joint,
                }
            return self._original

    def original_body(self) -> bytes:
        """:meth:`original` as JSON bytes (encoded once).

        Returns
        -------
        bytes
            The JSON.
        """
        if self._original_body is None:
            body = json_bytes(self.original())
            with self._lock:
                self._original_body = body
        return self._original_body

    def _contact_points(self, m, names, fk) -> np.ndarray:
        """(N, C, 3) positions of the contact points of m, from its forward kinematics fk."""
        if not names:
            return np.zeros((m.n_frames, 0, 3))
        return contact_positions(m, names, *fk)

    @property
    def n_points(self) -> int:
        """Joints plus End Sites, the points of the figure (the unit of the output cap)."""
        return self.motion.n_joints + self.motion.skeleton.n_end_sites

    def plan(self, p: dict[str, Any]) -> tuple[int, int]:
        """The sizes of a request, from the parameters alone (no work).

        Parameters
        ----------
        p : dict
            Validated parameters (:func:`parse_params`).

        Returns
        -------
        tuple of int
            (frames after the time warp, frames out).

        Raises
        ------
        ParamError
            400 for a length or fps out of range for this clip, 413 for more than
            ``max_values`` frames x points.
        """
        m = self.motion
        n_len = m.n_frames
        if p["length"] is not None:
            ratio = p["length"] / m.duration if m.duration > 0 else 1.0
            if not _LENGTH_RATIO[0] <= ratio <= _LENGTH_RATIO[1]:
                lo, hi = (r * m.duration for r in _LENGTH_RATIO)
                raise ParamError(f"length must be within {_LENGTH_RATIO[0]:g}x to "
                                 f"{_LENGTH_RATIO[1]:g}x of the clip's {m.duration:.3f} s "
                                 f"({lo:.3f} to {hi:.3f} s) for {self.name}, got "
                                 f"{p['length']:g} s")
            n_len = max(4, int(round(p["length"] * m.fps)))
        n_out = n_len
        if p["fps"] is not None and abs(p["fps"] - m.fps) > 1e-9 * m.fps:
            r = p["fps"] / m.fps
            if not 1.0 / _MAX_FPS_FACTOR <= r <= _MAX_FPS_FACTOR:
                lo = max(PARAMS["fps"][1], m.fps / _MAX_FPS_FACTOR)
                hi = min(PARAMS["fps"][2], m.fps * _MAX_FPS_FACTOR)
                raise ParamError(f"fps must be within {_MAX_FPS_FACTOR:g}x of the clip's "
                                 f"{m.fps:.6g} fps ({lo:.6g} to {hi:.6g}) for {self.name}, got "
                                 f"{p['fps']:g}")
            try:
                n_out = frames_at_rate(n_len, m.fps, p["fps"])
            except InvalidArgumentError:  # less than one frame at that rate
                n_out = 0
            if n_out < 4:
                raise ParamError(f"fps {p['fps']:g} would leave {n_out} frames of {self.name}; "
                                 f"the viewer needs at least 4: raise fps or length")
        most = max(int(self.max_values), m.n_frames * self.n_points)
        frames = max(n_len, n_out)
        if frames * self.n_points > most:
            fit = most // self.n_points
            raise ParamError(
                f"this request would produce {frames:,} frames x {self.n_points} points = "
                f"{frames * self.n_points:,} values, over the viewer's limit of {most:,} "
                f"({fit:,} frames of {self.name}); choose a shorter length or a lower fps, or "
                f"restart mlayer view with a larger --max-values", 413)
        return n_len, n_out

    def _key(self, p: dict) -> tuple:
        return tuple(sorted((k, v) for k, v in p.items() if k not in ("clip", "joint")))

    def _result(self, L, p: dict):
        """(info, processed motion, source frame per output frame) of ``p``: from the cache,
        or computed and cached (call with the lock held)."""
        key = ("result", self.index, self._key(p))
        hit = self.cache.get(key)
        if hit is None:
            hit = self._run(L, p)
            info, out, src = hit
            self.cache.put(key, hit, _nbytes(out, src, info["contacts"]))
        return hit

    def process(self, p: dict[str, Any]) -> tuple[dict[str, Any], Motion]:
        """Run the pipeline for validated parameters.

        Results are cached (see ``cache``). The request is checked against the output cap
        (:meth:`plan`) before any work.

        Parameters
        ----------
        p : dict
            Validated parameters (:func:`parse_params`).

        Returns
        -------
        data : dict
            The figure data for the page.
        motion : Motion
            The processed motion.
        """
        self.plan(p)
        key = ("result", self.index, self._key(p))
        cached = self.cache.get(key) is not None
        with self._lock:
            L = self._ensure()
            info, out, src = self._result(L, p)
            data = self._response(info, out, src, p)
        data["cached"] = cached
        return data, out

    def process_body(self, p: dict[str, Any]) -> bytes:
        """:meth:`process`'s figure data as JSON bytes, the encoded answer cached too.

        A repeated request is a cache look-up, without the clip's lock.

        Parameters
        ----------
        p : dict
            Validated parameters (:func:`parse_params`).

        Returns
        -------
        bytes
            The JSON, with ``cached`` saying whether it came from the cache.
        """
        key = ("body", self.index, self._key(p), p.get("joint"))
        body = self.cache.get(key)
        if body is None:
            data, _ = self.process(p)
            cached = data.pop("cached")
            body = json_bytes(data)
            self.cache.put(key, body, len(body) + 1024)
        else:
            cached = True
        # the flag first: {"cached":true,...}
        return b'{"cached":' + (b"true," if cached else b"false,") + body[1:]

    def _run(self, L, p):
        m = self.motion
        t0 = time.perf_counter()
        alpha: Any = p["alpha"]
        if p.get("keys"):  # alpha over time in the place of the global alpha
            alpha = AlphaCurve.parse(p["keys"])
        joints = {}
        for name, part in zip(m.joint_names, self._parts):  # the root joint is "spine"
            if p.get(part) is not None:
                joints[_glob_escape(name)] = p[part]
        # the root translation follows the global alpha (its curve with keys)
        out, _report = self._synth[bool(p["contacts"])].run(
            alpha, joints or None, root_alpha=None if p.get("keys") else alpha,
            residual=not p["denoise"])
        names, c = self._contacts
        src = np.arange(m.n_frames, dtype=np.float64)   # input frame of each output frame
        N = m.n_frames
        n_len, _ = self.plan(p)
        if n_len != N or p["warp"] > 0:
            # allow_extreme: a strong warp may slow a calm stretch by over 100x locally; the
            # output length is fixed (and capped by plan), so this is what the slider asks for
            out, t = timewarp(out, strength=p["warp"], n_frames=n_len, return_map=True,
                              allow_extreme=True)
            src = np.interp(np.arange(out.n_frames), t, src)
        if p["fps"] is not None and abs(p["fps"] - out.fps) > 1e-9 * out.fps:
            n1 = out.n_frames
            out = resample(out, fps=p["fps"])
            k = np.arange(out.n_frames) * (out.frame_time * m.fps)
            src = np.interp(np.minimum(k, n1 - 1), np.arange(n1), src)
        c_out = c[np.clip(np.rint(src).astype(np.int64), 0, N - 1)] if names else \
            np.zeros((out.n_frames, 0), dtype=bool)
        info: dict[str, Any] = {"compute_ms": 1e3 * (time.perf_counter() - t0)}
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
        fk = out.forward_kinematics()
        io, ip = _decimate(m.n_frames), _decimate(out.n_frames)
        q_ctrl = quat.mul(L.base.rot[:, j], quat.exp(np.asarray(L.control)[:, 1 + j]))
        return {
            "clip": self.index, "frames": out.n_frames, "fps": out.fps,
            "duration": out.duration, "n_points": m.n_joints + m.skeleton.n_end_sites,
            "positions": _b64(_points(out, fk), np.float32),
            "contact_points": _b64(self._contact_points(out, names, fk), np.float32),
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
            "alpha_curve": self._alpha_curve(p, io),
        }

    def _alpha_curve(self, p: dict[str, Any], io: NDArray[np.int64]) -> dict | None:
        """The global alpha over the input's time at the chart's frames, with its keys (None
        without keys)."""
        if not p.get("keys"):
            return None
        c = AlphaCurve.parse(p["keys"])
        t = io / self.motion.fps
        return {"t": t.tolist(), "alpha": c(t).tolist(), "keys": c.keys}

    def download(self, p: dict[str, Any]) -> tuple[str, str]:
        """The processed motion as a BVH file.

        Parameters
        ----------
        p : dict
            Validated parameters (:func:`parse_params`).

        Returns
        -------
        tuple of str
            (file name, BVH text).
        """
        _, out = self.process(p)
        stem = os.path.splitext(self.name)[0]
        return f"{stem}_processed.bvh", write_bvh_string(out)

    def layers_png(self) -> bytes:
        """The layer figure of ``mlayer layers`` (:mod:`mlayer.plotting.plot`, matplotlib), cached.

        Returns
        -------
        bytes
            A PNG image.
        """
        with self._lock:
            L = self._ensure()
            if self._plot_png is None:
                import io
                fig = plot_layers(self.motion, L, title=f"{self.name}: layers")
                buf = io.BytesIO()
                fig.savefig(buf, format="png", dpi=110)
                self._plot_png = buf.getvalue()
            return self._plot_png


def _glob_escape(name: str) -> str:
    """A joint name as an fnmatch pattern that matches only itself."""
    return "".join(f"[{ch}]" if ch in "*?[" else ch for ch in name)


def load_clips(paths: Iterable[str | os.PathLike[str]], *, cache: ResultCache | None = None,
               max_values: int = DEFAULT_MAX_VALUES) -> list[ViewerClip]:
    """Read every path; a clip that fails keeps its error (see ``ViewerClip.error``).

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        The BVH files.
    cache : ResultCache, optional
        Shared by the clips (a new :class:`ResultCache` of the default size if None).
    max_values : int, optional
        The output cap of each clip.

    Returns
    -------
    list of ViewerClip
        One per path, in order.
    """
    cache = cache if cache is not None else ResultCache()
    return [ViewerClip(i, os.fspath(p), cache=cache, max_values=max_values)
            for i, p in enumerate(paths)]
