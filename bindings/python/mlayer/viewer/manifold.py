"""The viewer's motion manifold (paper 2, sections 4 and 5): a :class:`mlayer.PrimitiveModel`
learned on the loaded clips on request, and the motions made on it (no HTTP here; see
:mod:`mlayer.viewer.server`).

Training (:meth:`ManifoldSession.status` with ``start``) runs in one background thread, once per
server (the model is kept; a failed training can be started again). Its size is bounded before
any work: at most ``max_frames`` training frames (every clip of the first good clip's skeleton,
each decimated by one common stride) and at most the server's ``max_values`` frames x points.
No request waits for it: the page polls the state and the steps done (SOM, elbow rule, GRBF,
guards).

Motions (:meth:`ManifoldSession.motion`), one of three kinds per request:

- ``points=r,c;r,c;...``: lattice points clicked on the map (row, column, within the lattice):
  the LGS spline through them (knot times by chord length), resampled to ``frames`` frames,
  mapped to poses by the GRBF (paper Figure 4);
- ``keys=CLIP:FRAME,...``: key frames of the loaded clips: their BMUs, the spline through them
  (``generate(key_poses=...)``, paper Figure 5);
- ``start=CLIP:FRAME`` with ``chain=most|second|sample``, ``noise``, ``seed``: a primitive
  sequence from the primitive of that frame (the nearest training frame), spread over the frames
  at the primitives' mean durations (paper section 5.2). ``most``: each step to the most likely
  other primitive (equation 5: the highest entry of the row after the diagonal, the chain of
  paper Figure 3 (c)); ``second``: to the runner-up; both on the transition matrix perturbed by
  ``noise`` (:meth:`mlayer.Markov.perturbed`, seeded). ``sample``: primitives drawn from the
  chain, perturbed by ``noise`` (:meth:`PrimitiveModel.generate`).

Every motion goes through the guards of generated motion (``guards=0`` turns them off). Answers
and motions are cached in the server's result cache.

The paper's figures are drawn by the page from these answers: the map data carries each
primitive's key pose (the GRBF's pose at the primitive's centre, paper Figure 2 (b); the page's
key-pose column) and the skeleton's tree; a motion carries its knots' frames (``knot_times``,
the poses drawn along the spline on the map, Figure 4) and each frame's fuzzy membership in the
primitives (``memberships``, fuzzy c-means memberships with m = 2 of the frame's manifold point
to the primitives' centres, and ``membership``, the primitive of the largest; the colour bar
under the pose strip, Figures 6 and 7).
"""
from __future__ import annotations

import math
import threading
import time
import warnings
from typing import IO, TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from ..errors import Error
from ..guards.contacts import contact_positions
from ..guards.metrics import body_height
from ..io.bvh import write_bvh_string
from ..manifold.features import pose_features
from ..manifold.mixture import _memberships
from ..manifold.primitives import PrimitiveModel, join_skeletons, same_units
from ..manifold.som import u_matrix
from ..plotting.render import body_side
from .session import (ParamError, ResultCache, ViewerClip, _b64, _points, finite_number,
                      json_bytes, query_pairs)

if TYPE_CHECKING:
    from ..manifold.markov import Markov
    from ..model.motion import Motion

__all__ = ["ManifoldSession", "ranked_next", "ranked_chain", "ranked_cycle", "memberships",
           "DEFAULT_MANIFOLD_FRAMES", "MAX_MOTION_FRAMES", "MAX_KNOTS"]

#: the most training frames (all clips together, after decimation)
DEFAULT_MANIFOLD_FRAMES = 3000
#: the most frames one manifold motion may have (and frames x points <= max_values)
MAX_MOTION_FRAMES = 5000
#: the most clicked points or key frames of one request
MAX_KNOTS = 64
_CHAINS = ("most", "second", "sample")
# fit's progress lines, in order: the fraction done after each
_STEPS = ("features:", "SOM ", "SOM:", "elbow:", "primitives:", "GRBF: ", "GRBF: mean", "guards:")


# ---- the ranked chains (paper Figure 3 (c)) ---------------------------------------------------

def ranked_next(P: NDArray[np.float64], j: int, rank: int = 1) -> int:
    """The rank-th most likely next primitive other than j in a transition matrix.

    Rank 1: equation 5, argmax over k != j of P[j, k]; rank 2: the runner-up; lowest index on
    ties; with fewer than rank other primitives the least likely of them.

    Parameters
    ----------
    P : array_like, shape (n, n)
        The transition matrix.
    j : int
        The current primitive.
    rank : int, optional
        >= 1.

    Returns
    -------
    int
        The primitive; -1 with one primitive.
    """
    P = np.asarray(P, dtype=np.float64)
    n = P.shape[0]
    if n == 1:
        return -1
    row = P[j].copy()
    row[j] = -np.inf
    order = np.argsort(-row, kind="stable")[: n - 1]
    return int(order[min(rank, n - 1) - 1])


def ranked_chain(markov: Markov, start: int, n_frames: int, rank: int = 1) -> NDArray[np.int64]:
    """Primitives from a start following :func:`ranked_next`.

    Enough to fill n_frames at their mean durations (as
    :meth:`mlayer.PrimitiveModel.primitive_path` fills them; rank 1 is its ``most_likely``
    path).

    Parameters
    ----------
    markov : Markov
        The model (its P and run lengths).
    start : int
        The first primitive.
    n_frames : int
        Frames to fill.
    rank : int, optional
        >= 1.

    Returns
    -------
    numpy.ndarray of int64
        The primitives.
    """
    dur = np.maximum(markov.run_length, 1.0)
    path = [int(start)]
    total = 0.0
    while total < n_frames and len(path) <= 100000:
        nxt = ranked_next(markov.P, path[-1], rank)
        if nxt < 0:
            break
        path.append(nxt)
        total += (dur[path[-2]] + dur[path[-1]]) / 2.0
    return np.array(path, dtype=np.int64)


def ranked_cycle(P: NDArray[np.float64], start: int, rank: int = 1) -> list[int]:
    """Follow :func:`ranked_next` until a primitive repeats (that one included).

    The sequence of paper Figure 3 (c).

    Parameters
    ----------
    P : array_like, shape (n, n)
        The transition matrix.
    start : int
        The first primitive.
    rank : int, optional
        >= 1.

    Returns
    -------
    list of int
        The primitives.
    """
    path = [int(start)]
    while len(path) <= len(P):
        nxt = ranked_next(P, path[-1], rank)
        if nxt < 0:
            break
        path.append(nxt)
        if nxt in path[:-1]:
            break
    return path


# ---- request parameters -------------------------------------------------------------------

_MOTION_KEYS = ("points", "keys", "start", "chain", "noise", "seed", "frames", "guards")


def _pairs(query: str) -> dict:
    return {k: v.strip() for k, v in query_pairs(query, _MOTION_KEYS).items()}


def _int(raw: str, name: str, lo: int, hi: int) -> int:
    # ASCII digits only (str.isdigit takes "²", which int() refuses), and no more of them than
    # hi has (so that int() never reads a huge number); the range is checked after
    if not (raw.isascii() and raw.isdigit()) or len(raw.lstrip("0")) > len(str(hi)):
        raise ParamError(f"{name} must be a non-negative integer in {lo}..{hi}, got "
                         f"{raw[:40]!r}")
    v = int(raw)
    if not lo <= v <= hi:
        raise ParamError(f"{name} must be in {lo}..{hi}, got {v}")
    return v


def _clip_frames(raw: str, name: str) -> list[tuple[int, int]]:
    """'CLIP:FRAME,CLIP:FRAME' -> [(clip, frame)]."""
    items = [s for s in raw.split(",")] if raw else []
    if not items or len(items) > MAX_KNOTS:
        raise ParamError(f"{name} must list 1 to {MAX_KNOTS} CLIP:FRAME pairs, got "
                         f"{len(items)}")
    out = []
    for i, s in enumerate(items):
        a, sep, b = s.strip().partition(":")
        if not sep:
            raise ParamError(f"{name} {i + 1}: expected CLIP:FRAME, got {s[:40]!r}")
        out.append((_int(a.strip(), f"{name} {i + 1}: clip", 0, 10**9),
                    _int(b.strip(), f"{name} {i + 1}: frame", 0, 10**9)))
    return out


# ---- the session --------------------------------------------------------------------------

class _Progress:
    """The lines of a training: fit's steps (on_step) and the session's own notes."""

    def __init__(self):
        self.lines: list[str] = []

    def write(self, text: str) -> None:
        self.lines += [s for s in text.splitlines() if s.strip()]

    def flush(self) -> None:
        pass


class ManifoldSession:
    """The manifold of a server's clips (see the module's doc).

    Parameters
    ----------
    clips : list of mlayer.viewer.session.ViewerClip
        The server's clips.
    cache : ResultCache
        Its result cache.
    max_values : int
        Its output cap (frames x points).
    max_frames : int, optional
        The most training frames.
    log : text stream, optional
        Where the training's lines go.
    seed : int, optional
        Seed of the training.
    rename : dict of str to str, optional
        Joint names of another naming scheme mapped to the first good clip's
        (:func:`mlayer.manifold.primitives.join_skeletons`); a clip of other names or another tree
        is left out of the training, with the first differing joint as the reason.
    """
    max_values: int
    max_frames: int
    state: str
    used: list[ViewerClip]
    excluded: list[dict[str, object]]
    stride: int

    def __init__(self, clips: list[ViewerClip], *, cache: ResultCache, max_values: int,
                 max_frames: int = DEFAULT_MANIFOLD_FRAMES, log: IO[str] | None = None,
                 seed: int = 0, rename: dict[str, str] | None = None) -> None:
        self.clips = clips
        self.rename = rename
        self._joined: dict[int, Any] = {}  # clip index -> its motion, renamed if need be
        self.cache = cache
        self.max_values = int(max_values)
        self.max_frames = int(max_frames)
        self.seed = seed
        self.log = log
        self.state = "idle"
        self.error: str | None = None
        # Any: None until trained (``state == "ready"``); read only in that state
        self.model: Any = None
        self._progress = _Progress()
        self._t0: float | None = None
        self._t1: float | None = None
        self._lock = threading.Lock()      # the state
        self._work = threading.Lock()      # the model in use (one motion at a time)
        self._thread: threading.Thread | None = None
        self._map_body: bytes | None = None
        self._features: dict[Any, Any] = {}
        self.plan()

    # -- the training set --

    def plan(self) -> None:
        """Which clips train (those with the first good clip's skeleton: joint names, after
        ``rename``, and tree) and the common stride that keeps the frames within
        ``max_frames`` and ``max_values``."""
        good = [c for c in self.clips if c.ok]
        self.used, self.excluded = [], []
        self._joined = {}
        self.stride = 1
        if not good:
            return
        ref = good[0].motion
        for c in good:
            try:
                m = ref if c is good[0] else join_skeletons(
                    [c.motion], rename=self.rename, reference=ref.skeleton,
                    reference_name=good[0].name)[0]
            except Error as e:  # "clip 0: another skeleton: joint 2 is ..."
                self.excluded.append({"clip": c.index, "name": c.name,
                                      "reason": str(e).split(": ", 1)[1]})
            else:
                self._joined[c.index] = m
                self.used.append(c)
        total = sum(c.motion.n_frames for c in self.used)
        points = self.used[0].n_points
        cap = max(1, min(self.max_frames, self.max_values // max(points, 1)))
        self.stride = max(1, math.ceil(total / cap))
        keep = []
        for c in self.used:
            if len(range(0, c.motion.n_frames, self.stride)) < 2:
                self.excluded.append({"clip": c.index, "name": c.name,
                                      "reason": f"fewer than 2 frames at the stride "
                                                f"{self.stride}"})
            else:
                keep.append(c)
        self.used = keep

    def _train(self) -> None:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                motions = same_units([self._joined[c.index] for c in self.used])
                train = [m[::self.stride] for m in motions]
                self._progress.write(f"training set: {len(train)} clip(s), "
                                     f"{sum(m.n_frames for m in train)} frames (every "
                                     f"{self.stride}. frame)\n")
                model = PrimitiveModel.fit(train, seed=self.seed, progress=False,
                                           on_step=lambda line: self._progress.write(line + "\n"))
            for w in caught:
                self._progress.write(f"warning: {w.message}\n")
            self._motions = motions
            with self._lock:
                self.model, self.state = model, "ready"
        except Exception as e:  # reported on the page; the next train request tries again
            with self._lock:
                self.state, self.error = "failed", f"{type(e).__name__}: {e}" \
                    if not isinstance(e, Error) else str(e)
            if self.log is not None:
                print(f"mlayer view: manifold: {self.error}", file=self.log, flush=True)
        finally:
            self._t1 = time.monotonic()

    def start(self) -> None:
        """Start the training in the background (unless it runs or is done)."""
        with self._lock:
            if self.state in ("training", "ready"):
                return
            if not self.used:
                self.state, self.error = "failed", (
                    "no clip to learn the manifold from" if not self.excluded else
                    "no clip to learn the manifold from: " +
                    "; ".join(f"{e['name']}: {e['reason']}" for e in self.excluded))
                return
            self.state, self.error = "training", None
            self._progress = _Progress()
            self._t0, self._t1 = time.monotonic(), None
            self._thread = threading.Thread(target=self._train, name="mlayer-view-manifold",
                                            daemon=True)
            self._thread.start()

    def wait(self, timeout: float | None = None) -> str:
        """Wait for a training in progress (tests, warm-up).

        Parameters
        ----------
        timeout : float, optional
            Seconds at most (None: until it ends).

        Returns
        -------
        str
            The state: ``"idle"``, ``"training"``, ``"ready"`` or ``"failed"``.
        """
        t = self._thread
        if t is not None:
            t.join(timeout)
        return self.state

    # -- answers --

    def status(self, start: bool = False) -> bytes:
        """The state as JSON bytes.

        Parameters
        ----------
        start : bool, optional
            Start the training first (:meth:`start`).

        Returns
        -------
        bytes
            ``state`` (idle, training, ready, failed), ``progress`` (0..1) and ``steps`` (the
            lines of the training), ``error``; when ready the map data (:meth:`map_data`).
        """
        if start:
            self.start()
        if self.state == "ready":
            if self._map_body is None:
                self._map_body = json_bytes(self.map_data())
            return self._map_body
        lines = list(self._progress.lines)
        done = sum(1 for s in _STEPS if any(line.startswith(s) for line in lines))
        now = self._t1 if self._t1 is not None else time.monotonic()
        return json_bytes({
            "state": self.state, "error": self.error, "progress": done / (len(_STEPS) + 1),
            "steps": lines, "seconds": None if self._t0 is None else now - self._t0,
            "stride": self.stride, "max_frames": self.max_frames,
            "clips": [c.index for c in self.used], "excluded": self.excluded,
            "frames": sum(len(range(0, c.motion.n_frames, self.stride)) for c in self.used)})

    def map_data(self) -> dict[str, Any]:
        """The map of a trained session.

        Returns
        -------
        dict
            The lattice (U-matrix, the primitive of each unit), the training clips'
            trajectories, the primitives' centres, the transition matrix and the ranked
            cycles.
        """
        md = self.model
        rows, cols, _ = md.som_codebook.shape
        u = u_matrix(md.som_codebook)
        span = float(u.max() - u.min())
        grid = np.stack(np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"), -1)
        d = ((grid.reshape(-1, 1, 2) - md.centers[None]) ** 2).sum(-1)
        k = md.centers.shape[0]
        ends = list(md.clip_starts[1:]) + [md.points.shape[0]]
        trajs = []
        for c, a, b in zip(self.used, md.clip_starts, ends):
            trajs.append({"clip": c.index, "name": c.name, "stride": self.stride,
                          "points": md.points[a:b].tolist(),
                          "labels": md.labels[a:b].tolist()})
        sk = md.skeleton
        keys = self._key_poses()
        return {
            "state": "ready", "error": None, "progress": 1.0, "steps": self._progress.lines,
            "seconds": (self._t1 or time.monotonic()) - cast(float, self._t0),
            "rows": rows, "cols": cols,
            "umatrix": ((u - u.min()) / span if span > 0 else np.zeros_like(u)).ravel().tolist(),
            "regions": np.argmin(d, axis=1).tolist(), "k": k,
            "centers": md.centers.tolist(), "P": md.markov.P.tolist(),
            "run_length": md.markov.run_length.tolist(),
            "cycles": {"most": [ranked_cycle(md.markov.P, j, 1) for j in range(k)],
                       "second": [ranked_cycle(md.markov.P, j, 2) for j in range(k)]},
            "trajectories": trajs, "stride": self.stride, "frames": int(md.points.shape[0]),
            "clips": [c.index for c in self.used], "excluded": self.excluded,
            "fps": 1.0 / md.frame_time, "fit_error": md.fit_error,
            "joint_names": list(sk.joint_names), "n_points": sk.n_joints + sk.n_end_sites,
            "max_frames": min(MAX_MOTION_FRAMES,
                              self.max_values // (sk.n_joints + sk.n_end_sites)),
            "parents": _parents(sk), "sides": _sides(sk),
            "key_poses": _b64(keys, np.float32), "height": _height(keys),
        }

    def _key_poses(self) -> np.ndarray:
        """(k, points, 3): each primitive's key pose, the GRBF's pose at its centre (root at
        the origin, no heading, not smoothed), joints then End Sites."""
        md = self.model
        out = []
        for c in md.centers:
            m = md.motion_along(np.asarray(c, dtype=np.float64)[None], smooth=0.0)
            out.append(_points(m)[0])
        return np.stack(out)

    def _ready(self):
        if self.state != "ready":
            more = f": {self.error}" if self.error else ""
            raise ParamError(f"the manifold is not learned yet (state: {self.state}{more}); "
                             f"ask /api/manifold?train=1 first (the page's button)", 409)
        return self.model

    def parse(self, query: str) -> dict[str, Any]:
        """Validate a motion request (see the module's doc).

        Parameters
        ----------
        query : str
            The query string.

        Returns
        -------
        dict
            The parameters.

        Raises
        ------
        ParamError
            400, 413 or 409.
        """
        md = self._ready()
        q = _pairs(query)
        kinds = [k for k in ("points", "keys", "start") if k in q]
        if len(kinds) != 1:
            raise ParamError("give exactly one of points (lattice points), keys (key frames) "
                             f"or start (a start frame), got {', '.join(kinds) or 'none'}")
        kind = kinds[0]
        sk = md.skeleton
        n_pts = sk.n_joints + sk.n_end_sites
        most = min(MAX_MOTION_FRAMES, max(3, self.max_values // n_pts))
        p: dict[str, Any] = {"kind": kind, "frames": 120, "guards": True, "chain": "most",
                             "noise": 0.0,
             "seed": 0}
        if "frames" in q:
            raw = q["frames"]
            if not raw.isdigit() or len(raw) > 9:
                raise ParamError(f"frames must be a non-negative integer, got {raw[:40]!r}")
            n = int(raw)
            # 3 at least: the spline's smoothing and the guards take an order-2 prior
            if n < 3 or n > MAX_MOTION_FRAMES:
                raise ParamError(f"frames must be in 3..{MAX_MOTION_FRAMES}, got {n}")
            if n > most:
                raise ParamError(f"frames={n} x {n_pts} points is over the viewer's limit of "
                                 f"{self.max_values:,} values ({most} frames); restart mlayer "
                                 f"view with a larger --max-values", 413)
            p["frames"] = n
        if "guards" in q:
            if q["guards"].lower() not in ("0", "1", "true", "false"):
                raise ParamError(f"guards must be 0, 1, true or false, got "
                                 f"{q['guards'][:40]!r}")
            p["guards"] = q["guards"].lower() in ("1", "true")
        for k in ("chain", "noise", "seed"):
            if k in q and kind != "start":
                raise ParamError(f"{k} applies to start= only")
        if kind == "points":
            p["points"] = self._lattice_points(q["points"])
        elif kind == "keys":
            p["keys"] = [self._frame_of(c, f, f"key {i + 1}")
                         for i, (c, f) in enumerate(_clip_frames(q["keys"], "key"))]
            if len(p["keys"]) > p["frames"]:
                raise ParamError(f"{len(p['keys'])} key frames need at least as many frames, "
                                 f"got frames={p['frames']}")
        else:
            cf = _clip_frames(q["start"], "start")
            if len(cf) != 1:
                raise ParamError("start takes one CLIP:FRAME")
            p["start"] = self._frame_of(*cf[0], "start")
            if "chain" in q:
                if q["chain"] not in _CHAINS:
                    raise ParamError(f"chain must be one of {', '.join(_CHAINS)}, got "
                                     f"{q['chain'][:40]!r}")
                p["chain"] = q["chain"]
            if "noise" in q:
                v = finite_number(q["noise"], "noise")
                if not 0.0 <= v <= 10.0:
                    raise ParamError(f"noise must be in [0, 10], got {q['noise'][:40]!r}")
                p["noise"] = v
            if "seed" in q:
                p["seed"] = _int(q["seed"], "seed", 0, 2**31 - 1)
        return p

    def _lattice_points(self, raw: str) -> np.ndarray:
        rows, cols, _ = self.model.som_codebook.shape
        items = raw.split(";") if raw else []
        if not items or len(items) > MAX_KNOTS:
            raise ParamError(f"points must list 1 to {MAX_KNOTS} lattice points ROW,COL;..., "
                             f"got {len(items)}")
        out = []
        for i, s in enumerate(items):
            parts = s.split(",")
            if len(parts) != 2:
                raise ParamError(f"point {i + 1}: expected ROW,COL, got {s[:40]!r}")
            r, c = (finite_number(v.strip(), f"point {i + 1}") for v in parts)
            if not (0 <= r <= rows - 1 and 0 <= c <= cols - 1):
                raise ParamError(f"point {i + 1} ({r:g}, {c:g}) is outside the map: rows 0 to "
                                 f"{rows - 1}, columns 0 to {cols - 1}")
            out.append((r, c))
        return np.array(out, dtype=np.float64)

    def _frame_of(self, clip: int, frame: int, what: str) -> tuple[int, int]:
        """(position of the clip among the training clips, frame), checked."""
        pos = next((i for i, c in enumerate(self.used) if c.index == clip), None)
        if pos is None:
            if not 0 <= clip < len(self.clips):
                raise ParamError(f"{what}: no clip {clip}: the server has {len(self.clips)} "
                                 f"clip(s), 0 to {len(self.clips) - 1}")
            why = next((e["reason"] for e in self.excluded if e["clip"] == clip),
                       "it failed to load")
            raise ParamError(f"{what}: clip {clip} is not on the manifold ({why})")
        n = self.used[pos].motion.n_frames
        if frame >= n:
            raise ParamError(f"{what}: frame {frame} is beyond clip {clip} "
                             f"({self.used[pos].name}: {n} frames, 0 to {n - 1})")
        return pos, frame

    def _key(self, p: dict) -> tuple:
        return ("manifold", tuple((k, v.tobytes() if isinstance(v, np.ndarray) else
                                   (tuple(v) if isinstance(v, list) else v))
                                  for k, v in sorted(p.items())))

    def motion(self, query: str) -> tuple[bytes, Motion]:
        """A motion request, cached.

        Parameters
        ----------
        query : str
            The query string (:meth:`parse`).

        Returns
        -------
        body : bytes
            The figure data as JSON bytes.
        motion : Motion
            The generated motion.
        """
        p = self.parse(query)
        key = self._key(p)
        hit = self.cache.get(key)
        if hit is None:
            with self._work:
                hit = self.cache.get(key)
                if hit is None:
                    t0 = time.perf_counter()
                    motion, info = self._make(p)
                    info["compute_ms"] = 1e3 * (time.perf_counter() - t0)
                    body = json_bytes(self._figure(motion, info, p))
                    hit = (body, motion)
                    self.cache.put(key, hit, len(body) + 64 * motion.n_frames *
                                   motion.n_joints + 1024)
        return hit

    def download(self, query: str) -> tuple[str, str]:
        """A motion request as a BVH file.

        Parameters
        ----------
        query : str
            The query string (:meth:`parse`).

        Returns
        -------
        tuple of str
            (file name, BVH text).
        """
        p = self.parse(query)
        _, motion = self.motion(query)
        return f"manifold_{p['kind']}.bvh", write_bvh_string(motion)

    def _features_of(self, pos: int) -> np.ndarray:
        X = self._features.get(pos)
        if X is None:
            X = self._features[pos] = pose_features(self._motions[pos])
        return X

    def _training_frame(self, pos: int, frame: int) -> int:
        md = self.model
        a = int(md.clip_starts[pos])
        b = int(md.clip_starts[pos + 1]) if pos + 1 < len(md.clip_starts) \
            else md.points.shape[0]
        return a + min(int(round(frame / self.stride)), b - a - 1)

    def _make(self, p: dict):
        md = self.model
        n = p["frames"]
        info: dict = {}
        if p["kind"] == "points":
            knots = p["points"]
            keep = np.r_[True, np.any(np.diff(knots, axis=0) != 0, axis=1)]
            knots = knots[keep]
            chord = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))]
            if knots.shape[0] > 1:
                times = chord / chord[-1] * (n - 1)
                if np.any(np.diff(times) < 1.0):
                    raise ParamError(f"{knots.shape[0]} points need more than {n} frames: "
                                     f"raise frames or click fewer points")
            else:
                times = np.zeros(1)
            traj = md.clamp(md.spline(knots, times, n))
            motion = md.motion_along(traj)
            contacts = None
            if p["guards"]:
                motion, _, contacts = md.guard(motion, traj)
            elif md.has_guards:
                contacts = md.contacts_along(traj)
            info.update(trajectory=traj, knots=knots, times=times, contacts=contacts,
                        primitives=np.array([int(np.argmin(((md.centers - q) ** 2).sum(1)))
                                             for q in knots]))
        elif p["kind"] == "keys":
            X = np.stack([self._features_of(pos)[f] for pos, f in p["keys"]])
            motion, info = md.generate(n, key_poses=X, guards=p["guards"], return_info=True)
        else:
            tf = self._training_frame(*p["start"])
            info["start_training_frame"] = tf
            if p["chain"] == "sample":
                motion, got = md.generate(n, start_frame=tf, noise=p["noise"], seed=p["seed"],
                                          guards=p["guards"], return_info=True)
            else:
                mk = md.markov.perturbed(p["noise"], p["seed"]) if p["noise"] > 0 \
                    else md.markov
                path = ranked_chain(mk, int(md.labels[tf]), n,
                                    1 if p["chain"] == "most" else 2)
                if path.size < 2:
                    raise ParamError("the model has one primitive: no chain to follow")
                motion, got = md.generate(n, start_frame=tf, path=path, guards=p["guards"],
                                          return_info=True)
            info.update(got)
        return motion, info

    def _figure(self, motion, info: dict, p: dict) -> dict:
        """The figure data of a manifold motion, as the page's clip endpoint gives it."""
        md = self.model
        sk = motion.skeleton
        fk = motion.forward_kinematics()
        pts = _points(motion, fk)
        names = list(getattr(md, "contact_names", []) or [])
        c = info.get("contacts")
        if c is None or not names:
            names, c = [], np.zeros((motion.n_frames, 0), dtype=bool)
        cpos = contact_positions(motion, names, *fk) if names else \
            np.zeros((motion.n_frames, 0, 3))
        parents, sides = _parents(sk), _sides(sk)
        knots = np.asarray(info["knots"], dtype=np.float64)
        traj = np.asarray(info["trajectory"], dtype=np.float64)
        u = memberships(traj, md.centers)
        return {
            "kind": p["kind"], "frames": motion.n_frames, "fps": motion.fps,
            "duration": motion.duration, "height": body_height(motion) or 1.0,
            "joint_names": list(sk.joint_names), "parents": parents, "sides": sides,
            "n_points": pts.shape[1], "positions": _b64(pts, np.float32),
            "contact_names": names, "contact_points": _b64(cpos, np.float32),
            "contacts": _b64(np.asarray(c, dtype=bool), np.uint8),
            "trajectory": traj.tolist(), "knots": knots.tolist(),
            "knot_times": np.asarray(info["times"], dtype=np.float64).tolist(),
            "primitives": [int(v) for v in info["primitives"]],
            "k": int(md.centers.shape[0]), "memberships": _b64(u, np.float32),
            "membership": np.argmax(u, axis=1).tolist(),
            "start_training_frame": info.get("start_training_frame"),
            "compute_ms": info["compute_ms"],
        }


def memberships(points: NDArray[np.float64], centers: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fuzzy c-means memberships (m = 2) of manifold points to the primitives' centres.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Manifold points (a motion's trajectory).
    centers : array_like, shape (k, 2)
        The primitives' centres on the map.

    Returns
    -------
    numpy.ndarray, shape (n, k)
        u[i, j] = 1 / sum_l (d_ij / d_il)^2, rows summing to 1; a point on a centre belongs to
        it alone (paper 2, Figure 6: the membership of each sampled point).
    """
    P = np.asarray(points, dtype=np.float64)
    C = np.asarray(centers, dtype=np.float64)
    d2 = ((P[:, None, :] - C[None, :, :]) ** 2).sum(-1)
    return _memberships(d2, 2.0)


def _parents(sk) -> list[int]:
    return list(map(int, sk.parents)) + list(map(int, sk.end_site_parents))


def _sides(sk) -> list[str]:
    sides = [body_side(nm) for nm in sk.joint_names]
    return sides + [sides[q] for q in map(int, sk.end_site_parents)]


def _height(pts: np.ndarray) -> float:
    """The tallest key pose's extent along y (the up axis of the figures), for the page's
    scale."""
    h = float((pts[..., 1].max(axis=1) - pts[..., 1].min(axis=1)).max()) if pts.size else 0.0
    return h if h > 0 else 1.0
