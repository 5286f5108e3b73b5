"""Corpus-scale batch processing on Dask: clean, stylize, resample and featurize mocap libraries.

    result = mlayer.batch("stylize", "clips/", "out/", alphas=[0.5, 1.5, 2.0])
    result = mlayer.batch("denoise", "captures/**/*.bvh", "clean/", scheduler="tcp://host:8786")

One Dask task per clip reads it, runs the operation for every requested variant (one output per
alpha for stylize, sharing one decomposition), writes each output atomically and returns small
records (status, error text, frames, seconds, jitter and foot sliding before and after). Only
paths and records travel through the scheduler; the clips are read and written by the workers,
so with a remote cluster the input and output folders must be visible to every worker under
the same paths (a shared file system), and the workers need mlayer installed.

Without ``scheduler``, an embedded ``dask.distributed.LocalCluster`` is started on loopback
(mutual TLS with temporary credentials: no other process can submit work to it),
one single-threaded worker process per CPU (``n_workers`` to change it), and closed at the end.

Nothing is lost:
- every output is written to a temporary file and renamed into place, then a small sidecar
  ``OUT_DIR/.mlayer-batch/<output>.json`` records the input's size and modification time, the
  hash of the options (operation, its arguments, the variant, the mlayer version) and the
  output's size and time. A re-run skips every output whose sidecar matches (the input and
  the options are unchanged and the output was not touched since), so an interrupted run
  resumes where it stopped; ``force=True`` redoes everything.
- an exception on one clip becomes a "failed" record with its error text; the batch goes on.
  A worker process that dies is replaced and its task re-run by Dask (up to
  ``distributed.scheduler.allowed-failures`` times, then the clip is reported as failed).
- temporary files left by a killed writer of one of this batch's outputs are removed at the
  start and at the end of the run.

Quality figures in the records are unit-free: jitter (:func:`mlayer.metrics.jitter`, per
second cubed) and foot sliding (:func:`mlayer.metrics.foot_sliding` on the contacts detected
on the input) both divided by the input's body height (:func:`mlayer.metrics.body_height`).
"""
from __future__ import annotations

import contextlib
import csv
import dataclasses
import glob
import hashlib
import io
import json
import math
import os
import pathlib
import sys
import time
from typing import Any, Callable

import numpy as np

from ._files import atomic_output
from ._args import integer
from .errors import InvalidArgumentError

__all__ = ["batch", "BatchResult", "Operation", "register_operation", "operations",
           "parse_alphas", "find_inputs", "SIDECAR_DIR"]

#: hidden folder of OUT_DIR holding one sidecar (.json) per output
SIDECAR_DIR = ".mlayer-batch"

STATUS_OK, STATUS_SKIPPED, STATUS_FAILED = "ok", "skipped", "failed"
#: records of symbolic links that were not read as clips (links to folders, dangling links);
#: the record's error field says which and whether it was followed
STATUS_LINK = "link"

#: report columns, in order
FIELDS = ("input", "output", "variant", "status", "error", "frames", "frames_out", "fps",
          "seconds", "jitter_before", "jitter_after", "sliding_before", "sliding_after",
          "worker")


# ---- operations -----------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Operation:
    """A batch operation.

    name       the name used by :func:`batch` and the CLI
    run        ``run(motion, variants, **options) -> list`` with one result per variant dict
               (e.g. ``[{"alpha": 1.5}, {"alpha": 2}]``, or ``[{}]``): a Motion (written as
               BVH) or a dict of numpy arrays (written as .npz)
    extension  ".bvh" or ".npz"
    options    the keyword options ``run`` accepts (checked before anything runs)
    uses_alphas  True when the variants are alphas (stylize): one output per alpha
    help       one line for the CLI
    """
    name: str
    run: Callable
    extension: str = ".bvh"
    options: frozenset = frozenset()
    uses_alphas: bool = False
    help: str = ""


_OPERATIONS: dict[str, Operation] = {}


def register_operation(op: Operation) -> Operation:
    """Add (or replace) an operation in the table :func:`batch` and ``mlayer batch`` use."""
    if not isinstance(op, Operation):
        raise TypeError("register_operation: expected a mlayer.batch.Operation")
    if op.extension not in (".bvh", ".npz"):
        raise InvalidArgumentError(f"operation {op.name}: extension must be .bvh or .npz")
    _OPERATIONS[op.name] = op
    return op


def operations() -> dict[str, Operation]:
    """The registered operations by name (resample and timewarp only when this mlayer has
    them)."""
    _register_resampling()
    return dict(_OPERATIONS)


_LAYER_OPTIONS = frozenset({"gamma", "lam_c", "sigma_c", "lam_b", "sigma_b", "base_cutoff"})


def _op_denoise(motion, variants, keep_contacts=True, **options):
    from .pipeline import denoise
    return [denoise(motion, keep_contacts=keep_contacts, **options) for _ in variants]


def _op_stylize(motion, variants, keep_contacts=True, joints=None, root_alpha=None, **options):
    """mlayer.stylize for every alpha, sharing one decomposition and one set of guards
    (mlayer.pipeline.Synthesis)."""
    from .pipeline import Synthesis
    s = Synthesis(motion, keep_contacts=keep_contacts, **options)
    return [s.run(v["alpha"], joints, root_alpha=root_alpha)[0] for v in variants]


def _op_features(motion, variants, keep_contacts=True, **options):
    """Arrays for machine learning: the input frames, world joint positions, foot contacts,
    every layer and its parameters (as Layers.save_npz), and mlayer.pose_features when this
    mlayer has it."""
    del keep_contacts  # accepted for a uniform CLI; nothing is synthesized
    from . import contacts as _contacts
    from .layers import _PARAMS, decompose
    layers = decompose(motion, **options)
    names, contacts = _contacts.detect_contacts(motion)
    arrays = {
        "fps": np.float64(motion.fps), "frame_time": np.float64(motion.frame_time),
        "joint_names": np.array(motion.joint_names), "parents": np.asarray(motion.parents),
        "offsets": np.asarray(motion.offsets), "root_pos": motion.root_pos, "rot": motion.rot,
        "positions": motion.positions(), "contacts": contacts,
        "contact_names": np.array(names, dtype=str),
        "base_root_pos": layers.base.root_pos, "base_rot": layers.base.rot,
        "control": layers.control, "residual": layers.residual,
    }
    arrays.update({name: getattr(layers, name) for name in _PARAMS})
    import mlayer
    pose_features = getattr(mlayer, "pose_features", None)
    if pose_features is not None:
        feats = pose_features(motion)
        if isinstance(feats, dict):
            arrays.update({f"pose_{k}": np.asarray(v) for k, v in feats.items()})
        else:
            arrays["pose_features"] = np.asarray(feats)
    return [arrays for _ in variants]


def _op_resample(motion, variants, keep_contacts=True, **options):
    del keep_contacts
    import mlayer
    return [mlayer.resample(motion, **options) for _ in variants]


def _op_timewarp(motion, variants, keep_contacts=True, **options):
    del keep_contacts
    import mlayer
    return [mlayer.timewarp(motion, **options) for _ in variants]


register_operation(Operation(
    "denoise", _op_denoise, ".bvh", _LAYER_OPTIONS | {"keep_contacts"},
    help="smooth each clip (mlayer.denoise)"))
register_operation(Operation(
    "stylize", _op_stylize, ".bvh", _LAYER_OPTIONS | {"keep_contacts", "joints", "root_alpha"},
    uses_alphas=True, help="scale each clip's style, one output per alpha (mlayer.stylize)"))
register_operation(Operation(
    "features", _op_features, ".npz", _LAYER_OPTIONS | {"keep_contacts"},
    help="frames, positions, contacts and layers of each clip as .npz for machine learning"))


def _register_resampling() -> None:
    """resample and timewarp; called lazily, once the package is fully imported."""
    if "resample" in _OPERATIONS:
        return
    register_operation(Operation(
        "resample", _op_resample, ".bvh",
        frozenset({"keep_contacts", "fps", "n_frames", "lam", "sigma", "allow_extreme",
                   "style"}),
        help="resample each clip to a new frame rate or frame count (mlayer.resample)"))
    register_operation(Operation(
        "timewarp", _op_timewarp, ".bvh",
        frozenset({"keep_contacts", "strength", "n_frames", "lam", "sigma",
                   "smooth_seconds", "root_weight", "allow_extreme", "style"}),
        help="retime each clip along its automatic time map (mlayer.timewarp)"))



# ---- arguments ------------------------------------------------------------------------------

def parse_alphas(spec) -> list[float]:
    """Alphas from a number, a sequence, or a string "0.5,1,2" or "START:STOP:STEP" (STOP
    included when it falls on the grid: "0.5:2.5:0.5" is 0.5, 1, ..., 2.5)."""
    if spec is None:
        return []
    if isinstance(spec, str):
        s = spec.strip()
        if ":" in s:
            parts = s.split(":")
            if len(parts) != 3:
                raise InvalidArgumentError(f"alphas range must be START:STOP:STEP, got {spec!r}")
            try:
                a, b, step = (float(p) for p in parts)
            except ValueError:
                raise InvalidArgumentError(f"alphas range {spec!r}: not numbers") from None
            if not all(math.isfinite(x) for x in (a, b, step)) or step <= 0 or b < a:
                raise InvalidArgumentError(
                    f"alphas range {spec!r}: needs finite START <= STOP and STEP > 0")
            n = int(math.floor((b - a) / step + 1e-9)) + 1
            if n > 10000:
                raise InvalidArgumentError(f"alphas range {spec!r} gives {n} alphas (> 10000)")
            return [round(a + k * step, 12) for k in range(n)]
        spec = [p for p in s.split(",") if p.strip()]
    if isinstance(spec, (int, float, np.integer, np.floating)):
        spec = [spec]
    out = []
    for v in spec:
        try:
            f = float(v)
        except (TypeError, ValueError):
            raise InvalidArgumentError(f"alpha must be a number, got {v!r}") from None
        if not math.isfinite(f):
            raise InvalidArgumentError(f"alpha must be finite, got {v!r}")
        if f not in out:
            out.append(f)
    if not out:
        raise InvalidArgumentError("alphas: empty")
    return out


def _is_bvh(p: pathlib.Path) -> bool:
    return p.suffix.lower() == ".bvh" and p.is_file()


def _under(path, folder) -> bool:
    """Whether path (resolved) is folder (resolved) or inside it."""
    if folder is None:
        return False
    p, f = os.path.realpath(path), os.path.realpath(folder)
    return p == f or p.startswith(f.rstrip(os.sep) + os.sep)


def _walk(folder: pathlib.Path, exclude, links):
    """The .bvh files below folder (hidden parts and `exclude` left out). Symbolic links to
    folders are not followed (a link may lead out of the tree or back into it) and dangling
    links cannot be read: both are appended to ``links`` as (path, note)."""
    if _under(folder, exclude):
        exclude = None  # the output folder is this folder (or holds it): the overwrite check
    out = []
    for f in sorted(folder.rglob("*")):
        rel = f.relative_to(folder)
        if any(part.startswith(".") for part in rel.parts) or _under(f, exclude):
            continue
        if f.is_symlink():
            if not f.exists():
                links.append((f, "dangling link (its target does not exist): skipped"))
                continue
            if f.is_dir():
                links.append((f, "link to a folder: not followed, its clips are skipped"))
                continue
        if _is_bvh(f):
            out.append((f, rel))
    return out


def _glob(pattern: str, exclude, links):
    """The .bvh files matching a glob, relative to its fixed prefix. Python's glob follows
    links to folders ("**" included): each one crossed is noted in ``links``, as are dangling
    links that match."""
    root = pathlib.Path(pattern)
    while glob.has_magic(str(root)):
        root = root.parent
    if _under(root, exclude):
        exclude = None
    out, crossed = [], set()
    for name in sorted(glob.glob(pattern, recursive=True)):
        f = pathlib.Path(name)
        if _under(f, exclude):
            continue
        if f.is_symlink() and not f.exists():
            links.append((f, "dangling link (its target does not exist): skipped"))
            continue
        if not _is_bvh(f):
            continue
        rel = f.relative_to(root)
        for k in range(1, len(rel.parts)):
            d = root.joinpath(*rel.parts[:k])
            if d.is_symlink() and d not in crossed:
                crossed.add(d)
                links.append((d, "link to a folder: followed (the glob reaches its clips)"))
        out.append((f, rel))
    return out


def find_inputs(inputs, *, exclude=None, links=None) -> list[tuple[pathlib.Path, pathlib.PurePath]]:
    """(input path, output path relative to OUT_DIR without extension) for every clip: a
    folder (every .bvh below it, sub-folders kept), a glob pattern ("**" recurses; paths
    relative to the pattern's fixed prefix), a file, or a list of these. Sorted, no
    duplicates.

    exclude: a folder whose files are never inputs (batch passes its output folder, so an
    output folder inside the input folder can be resumed). links: a list that receives
    (path, note) for each symbolic link that was not simply read: links to folders (not
    followed in a folder walk; followed by a glob, as Python's glob does) and dangling links
    (skipped). Links to files are read as clips (each link a clip of its own)."""
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    links = [] if links is None else links
    found: dict[pathlib.Path, pathlib.PurePath] = {}
    for item in inputs:
        s = os.fspath(item)
        p = pathlib.Path(s)
        if p.is_dir():
            pairs = _walk(p, exclude, links)
        elif glob.has_magic(s):
            pairs = _glob(s, exclude, links)
        elif p.is_file():
            pairs = [(p, pathlib.PurePath(p.name))]
        elif p.is_symlink():
            raise InvalidArgumentError(f"{s}: dangling link (its target does not exist)")
        else:
            raise InvalidArgumentError(f"{s}: no such file, folder or matching glob")
        for f, rel in pairs:
            # absolute, symlinks kept: links to one file are separate clips (corpus copies)
            found.setdefault(pathlib.Path(os.path.abspath(f)), rel.with_suffix(""))
    return sorted(found.items(), key=lambda kv: str(kv[1]))


# ---- per-clip work (runs on the workers) ----------------------------------------------------

def _sidecar_path(out_dir: pathlib.Path, out: pathlib.Path) -> pathlib.Path:
    rel = out.relative_to(out_dir)
    return out_dir / SIDECAR_DIR / rel.parent / (rel.name + ".json")


def _stat(path):
    st = os.stat(path)
    return st.st_size, st.st_mtime_ns


def _up_to_date(src: str, out: pathlib.Path, sidecar: pathlib.Path, key: str):
    """The stored record when `out` is complete and up to date, else None."""
    try:
        with open(sidecar, encoding="utf-8") as f:
            side = json.load(f)
        in_size, in_mtime = _stat(src)
        out_size, out_mtime = _stat(out)
    except (OSError, ValueError):
        return None
    if (side.get("options") == key and side.get("input_size") == in_size
            and side.get("input_mtime_ns") == in_mtime and side.get("output_size") == out_size
            and side.get("output_mtime_ns") == out_mtime and out_mtime >= in_mtime):
        return side.get("record") or {}
    return None


def _metrics_before(motion):
    from .contacts import detect_contacts
    from .metrics import body_height, foot_sliding, jitter
    pos = motion.positions()
    h = body_height(pos)
    if not (h > 0):
        h = float("nan")
    jb = jitter(pos, fps=motion.fps) / h if motion.n_frames >= 4 else float("nan")
    try:
        names, c = detect_contacts(motion)
        sb = foot_sliding(motion, c, names) / h if names else float("nan")
    except Exception:  # noqa: BLE001  (a figure is not worth failing the clip)
        names, c, sb = [], None, float("nan")
    return h, names, c, jb, sb


def _metrics_after(out, h, names, c):
    from .contacts import detect_contacts
    from .metrics import foot_sliding, jitter
    ja = jitter(out, fps=out.fps) / h if out.n_frames >= 4 else float("nan")
    sa = float("nan")
    if names:
        try:
            if c is None or out.n_frames != c.shape[0]:  # resampled: detect on the output
                names, c = detect_contacts(out)
            sa = foot_sliding(out, c, names) / h if names else float("nan")
        except Exception:  # noqa: BLE001
            sa = float("nan")
    return ja, sa


def _fin(x):
    """JSON-safe float (None for NaN/inf)."""
    try:
        f = float(x)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def _worker_name() -> str:
    try:
        from distributed import get_worker
        return get_worker().address
    except Exception:  # noqa: BLE001  (not on a worker: a plain call)
        return f"pid {os.getpid()}"


def _write(result, out: str) -> int:
    from .bvh import write_bvh
    from .motion import Motion
    if isinstance(result, Motion):
        write_bvh(result, out)
        return result.n_frames
    if isinstance(result, dict):
        with atomic_output(out, ".npz") as tmp:
            np.savez(tmp, **result)
        return int(result["rot"].shape[0]) if "rot" in result else 0
    raise TypeError(f"operation returned {type(result).__name__}, expected a Motion or a dict")


def process_clip(op: Operation, src: str, jobs: list, options: dict, metrics: bool = True,
                 read: dict | None = None):
    """Run `op` on one clip for every job (variant, output path, sidecar path, options key);
    ``read``: read_bvh's keyword arguments (strict, up, trim, units). Returns one record per
    job. Never raises for a bad clip: the error goes in the records."""
    t0 = time.perf_counter()
    worker = _worker_name()
    records = [{"input": src, "output": out, "variant": variant, "status": STATUS_FAILED,
                "error": "", "worker": worker} for variant, out, _, _ in jobs]
    try:
        from .bvh import read_bvh
        motion = read_bvh(src, threads=1, **(read or {}))  # the workers are the parallelism
        for r in records:
            r["frames"], r["fps"] = motion.n_frames, motion.fps
        before = _metrics_before(motion) if metrics else None
        results = op.run(motion, [v for v, _, _, _ in jobs], **options)
        if len(results) != len(jobs):
            raise RuntimeError(f"operation {op.name} returned {len(results)} results for "
                               f"{len(jobs)} variants")
        for r, res, (variant, out, sidecar, key) in zip(records, results, jobs):
            r["frames_out"] = _write(res, out)
            if before is not None:
                h, names, c, jb, sb = before
                r["jitter_before"], r["sliding_before"] = _fin(jb), _fin(sb)
                if not isinstance(res, dict):
                    ja, sa = _metrics_after(res, h, names, c)
                    r["jitter_after"], r["sliding_after"] = _fin(ja), _fin(sa)
            r["status"] = STATUS_OK
    except Exception as e:  # noqa: BLE001  (one bad clip must not stop the batch)
        msg = str(e) or type(e).__name__
        for r in records:
            if r["status"] != STATUS_OK:
                r["error"] = f"{type(e).__name__}: {msg}"
    seconds = time.perf_counter() - t0
    for r in records:
        r["seconds"] = seconds
    for r, (_, out, sidecar, key) in zip(records, jobs):
        if r["status"] == STATUS_OK:
            _write_sidecar(src, out, sidecar, key, r)
    return records


def _write_sidecar(src, out, sidecar, key, record) -> None:
    in_size, in_mtime = _stat(src)
    out_size, out_mtime = _stat(out)
    side = {"options": key, "input": src, "input_size": in_size, "input_mtime_ns": in_mtime,
            "output_size": out_size, "output_mtime_ns": out_mtime, "record": record}
    os.makedirs(os.path.dirname(sidecar), exist_ok=True)
    with atomic_output(sidecar, ".json") as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(side, f, indent=1)


# ---- the client side -----------------------------------------------------------------------

@dataclasses.dataclass
class BatchResult:
    """What :func:`batch` did: one record per output (dicts with the keys of FIELDS), in input
    order, then one record per symbolic link that was not read as a clip (status "link": a
    link to a folder or a dangling link, its note in ``error``), and the wall time."""
    operation: str
    records: list
    seconds: float
    n_workers: int = 0
    scheduler: str = ""

    def count(self, status: str) -> int:
        return sum(1 for r in self.records if r["status"] == status)

    @property
    def outputs(self) -> list:
        """The records of outputs (without the link records)."""
        return [r for r in self.records if r["status"] != STATUS_LINK]

    @property
    def links(self) -> int:
        return self.count(STATUS_LINK)

    @property
    def ok(self) -> int:
        return self.count(STATUS_OK)

    @property
    def skipped(self) -> int:
        return self.count(STATUS_SKIPPED)

    @property
    def failed(self) -> int:
        return self.count(STATUS_FAILED)

    @property
    def exit_code(self) -> int:
        """0 when every output is done (now or by an earlier run), 1 when any failed."""
        return 1 if self.failed else 0

    def table(self) -> str:
        """A summary table: one line per output, then the totals."""
        def f(x, fmt="{:.3g}"):
            return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) \
                else fmt.format(x)
        rows = []
        for r in self.records:
            name = os.path.basename(r.get("output") or r["input"])
            rows.append((name, r["status"], f(r.get("frames"), "{:d}"),
                         f(r.get("seconds"), "{:.2f}"),
                         f"{f(r.get('jitter_before'))} -> {f(r.get('jitter_after'))}",
                         f"{f(r.get('sliding_before'))} -> {f(r.get('sliding_after'))}"))
        head = ("output", "status", "frames", "s", "jitter (h/s^3)", "foot sliding (h/s)")
        w = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
        line = "  ".join
        out = [line(h.ljust(w[k]) for k, h in enumerate(head))]
        out += [line(str(x).ljust(w[k]) for k, x in enumerate(row)) for row in rows]
        for r in self.records:
            if r["status"] == STATUS_FAILED:
                out.append(f"FAILED {r['input']}: {r.get('error', '')}")
            elif r["status"] == STATUS_LINK:
                out.append(f"LINK {r['input']}: {r.get('error', '')}")
        done = [r for r in self.records if r["status"] == STATUS_OK]
        clips = len({r["input"] for r in done})
        busy = sum({r["input"]: r.get("seconds") or 0.0 for r in done}.values())
        out.append(f"{self.operation}: {len(self.outputs)} outputs: {self.ok} done, "
                   f"{self.skipped} up to date (skipped), {self.failed} failed; "
                   f"{clips} clips in {self.seconds:.2f} s wall "
                   f"({busy:.2f} s in tasks, {self.n_workers} workers)")
        return "\n".join(out)

    def write_report(self, path) -> None:
        """The records as JSON (.json: {"operation", "seconds", "summary", "records"}) or CSV
        (any other extension), written atomically."""
        path = os.fspath(path)
        if path.lower().endswith(".json"):
            doc = {"operation": self.operation, "seconds": self.seconds,
                   "n_workers": self.n_workers, "scheduler": self.scheduler,
                   "summary": {"outputs": len(self.outputs), "ok": self.ok,
                               "skipped": self.skipped, "failed": self.failed,
                               "links": self.links},
                   "records": self.records}
            text = json.dumps(doc, indent=1, default=_json_default)
        else:
            buf = io.StringIO()
            w = csv.DictWriter(buf, fieldnames=FIELDS, extrasaction="ignore")
            w.writeheader()
            for r in self.records:
                w.writerow({k: (json.dumps(v) if k == "variant" else v)
                            for k, v in r.items()})
            text = buf.getvalue()
        parent = os.path.dirname(os.path.abspath(path))
        os.makedirs(parent, exist_ok=True)
        with atomic_output(path) as tmp:
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                f.write(text)


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def _options_key(op: Operation, options: dict, variant: dict, read: dict | None = None) -> str:
    from . import __version__
    doc = {"operation": op.name, "run": f"{op.run.__module__}.{op.run.__qualname__}",
           "options": options, "variant": variant, "mlayer": __version__}
    if read:  # (absent when the clips are read as they are: earlier keys stay valid)
        doc["read"] = read
    text = json.dumps(doc, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _variant_tag(variant: dict) -> str:
    return "".join(f"_{k}{v:g}" if isinstance(v, float) else f"_{k}{v}"
                   for k, v in variant.items())


def _stale_temps(out: pathlib.Path) -> list:
    """Temporary files a killed writer of `out` may have left: the C BVH writer's
    "<out>.tmp-<hex>" and atomic_output's ".<name>.<random><ext>"."""
    d, name = out.parent, out.name
    return (glob.glob(glob.escape(str(out)) + ".tmp-*")
            + glob.glob(os.path.join(glob.escape(str(d)), "." + glob.escape(name) + ".*")))


def _sweep(paths) -> None:
    for out in paths:
        for t in _stale_temps(out):
            with contextlib.suppress(OSError):
                os.unlink(t)


class _Progress:
    """A progress bar over clips on stderr (redrawn in place on a terminal, a line per tenth
    otherwise)."""

    def __init__(self, total: int, enabled: bool, stream=None):
        self.total, self.enabled = total, enabled and total > 0
        self.stream = stream or sys.stderr
        self.tty = self.enabled and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.t0 = time.perf_counter()
        self.done = self.failed = 0
        self._next_line = 0

    def update(self, failed: bool) -> None:
        self.done += 1
        self.failed += bool(failed)
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        rate = self.done / el if el > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else float("nan")
        frac = self.done / self.total
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        text = (f"[{bar}] {self.done}/{self.total} clips, {self.failed} failed, "
                f"{rate:.2f} clips/s, eta {eta:.0f} s")
        if self.tty:
            self.stream.write("\r" + text + ("\n" if self.done == self.total else ""))
            self.stream.flush()
        elif self.done >= self._next_line or self.done == self.total:
            self.stream.write(text + "\n")
            self.stream.flush()
            self._next_line = self.done + max(1, self.total // 10)


def _default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def _client(scheduler, n_workers):
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ImportError("mlayer.batch needs Dask: pip install 'dask[distributed]' "
                          "(or the mlayer[batch] extra)") from None
    import logging
    if scheduler is not None:
        if hasattr(scheduler, "scheduler_address"):  # a Cluster object
            with Client(scheduler) as client:
                yield client
        elif hasattr(scheduler, "submit"):  # a Client
            yield scheduler
        else:
            with Client(str(scheduler), timeout="30s") as client:
                yield client
        return
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                      host="127.0.0.1", protocol="tls://", security=_embedded_security(),
                      dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client


def _embedded_security():
    """Mutual TLS with credentials made for this run only (``Security.temporary()``: a new
    self-signed CA, certificate and key, held by this process and handed to the workers it
    starts). The embedded scheduler runs
    arbitrary tasks for whoever connects to it, and loopback is open to every user of the
    machine: with TLS, only this process and the workers it starts hold a certificate the
    scheduler accepts (a client without one, or with its own, is disconnected in the TLS
    handshake)."""
    try:
        from distributed.security import Security
        return Security.temporary()
    except ImportError as e:  # Security.temporary needs the cryptography package
        raise ImportError("mlayer.batch secures its embedded Dask cluster with TLS, which needs "
                          "the cryptography package: pip install cryptography (or the "
                          f"mlayer[batch] extra) [{e}]") from None


#: read_bvh's keywords that batch(read=...) passes to the workers.
READ_OPTIONS = ("strict", "up", "trim", "units")


def _read_options(read) -> dict:
    """batch's ``read``: checked here, before anything runs, with read_bvh's own rules."""
    if read is None:
        return {}
    if not isinstance(read, dict):
        raise InvalidArgumentError(f"batch: read must be a dict of read_bvh options, got "
                                   f"{type(read).__name__}")
    bad = sorted(set(read) - set(READ_OPTIONS))
    if bad:
        raise InvalidArgumentError(f"batch: unknown read option(s) {', '.join(bad)}; accepted: "
                                   f"{', '.join(READ_OPTIONS)}")
    from .bvh import _options
    from .units import units_arg
    from .trimming import frames_arg
    from .up_axis import axis_name
    out = {}
    if read.get("strict") is not None:
        _options(read["strict"], False, "batch: read")
        out["strict"] = read["strict"]
    for name, check_arg in (("up", axis_name), ("trim", frames_arg), ("units", units_arg)):
        if read.get(name) is not None:
            out[name] = check_arg(read[name], f"batch: read {name}")
    return out


def batch(operation, inputs, out_dir, *, alphas=None, scheduler=None, n_workers=None,
          report=None, progress=True, force=False, metrics=True, read=None,
          **options) -> BatchResult:
    """Run an operation over every clip of `inputs` on Dask, writing into `out_dir`.

    operation  "denoise", "stylize", "features", "resample", "timewarp" (when this mlayer has
               them; see :func:`operations`), or an :class:`Operation`
    inputs     a folder (every .bvh below it), a glob ("captures/**/*.bvh"), a file, or a list
               of these; outputs keep the paths relative to the folder (the glob's fixed part)
    out_dir    created if needed. Outputs: <rel>.bvh, <rel>_alpha<A>.bvh per alpha for stylize,
               <rel>.npz for features
    alphas     stylize only: one alpha or several (a list, a range such as np.arange, or a
               string "0.5:2.5:0.5" or "1,1.5,2"); default 2
    scheduler  None: an embedded LocalCluster on loopback, secured by mutual TLS with
               credentials made for this run (other users of the machine cannot connect);
               "tls://host:8786" or "tcp://host:8786": an existing cluster (a dask Client or
               LocalCluster object also works). Securing that one is its owner's business:
               a tcp:// scheduler runs the tasks of anyone who can reach its port. Start it
               with TLS (``dask scheduler --tls-ca-file ca.pem --tls-cert sched.pem --tls-key
               sched.key``, the workers likewise) and give this process its credentials in the
               Dask configuration (``distributed.comm.tls.ca-file`` and
               ``distributed.comm.tls.client.cert`` / ``.key``, e.g. the environment variables
               DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ..._CLIENT__CERT, ..._CLIENT__KEY), or
               pass ``Client(address, security=Security(...))`` as ``scheduler``
    n_workers  worker processes of the embedded cluster (default: one per CPU, at most one per
               clip)
    report     write the records there: .json, or CSV for any other extension
    progress   a progress bar on stderr
    force      redo outputs that are up to date
    metrics    compute jitter and foot sliding before/after (costs a few forward kinematics)
    read       how the workers read each clip: read_bvh's strict, up, trim and units (for
               example ``{"trim": "auto", "up": "z"}``); part of the outputs' up-to-date key
    options    the operation's keyword arguments: keep_contacts=False, gamma, lam_c, sigma_c,
               joints and root_alpha (stylize), fps / n_frames / lam (resample), strength ...
    Returns a :class:`BatchResult`; ``result.exit_code`` is 1 when any clip failed. Raises
    InvalidArgumentError before anything runs for an unknown operation or option, no inputs,
    or outputs that would collide or overwrite an input.
    """
    t0 = time.perf_counter()
    read = _read_options(read)
    op = operations().get(operation) if isinstance(operation, str) else operation
    if not isinstance(op, Operation):
        raise InvalidArgumentError(f"unknown batch operation {operation!r}; available: "
                                   f"{', '.join(sorted(_OPERATIONS))}")
    bad = sorted(set(options) - set(op.options))
    if bad:
        raise InvalidArgumentError(f"batch {op.name}: unknown option(s) {', '.join(bad)}; "
                                   f"accepted: {', '.join(sorted(op.options)) or 'none'}")
    if op.uses_alphas:
        variants = [{"alpha": a} for a in parse_alphas(2.0 if alphas is None else alphas)]
    elif alphas is not None:
        raise InvalidArgumentError(f"batch {op.name}: alphas apply to stylize only")
    else:
        variants = [{}]
    if n_workers is not None:
        if scheduler is not None:
            raise InvalidArgumentError("n_workers sizes the embedded cluster; the cluster at "
                                       "`scheduler` has its own workers")
        integer(n_workers, "n_workers", 1)
    out_root = pathlib.Path(out_dir).resolve()
    links: list = []
    clips = find_inputs(inputs, exclude=out_root, links=links)
    if not clips:
        raise InvalidArgumentError(f"no .bvh files in {inputs!r}")
    inputs_set = {str(src) for src, _ in clips} | {os.path.realpath(src) for src, _ in clips}
    plan, seen = [], {}
    for src, rel in clips:
        jobs = []
        for v in variants:
            out = out_root / rel.parent / (rel.name + _variant_tag(v) + op.extension)
            if str(out) in inputs_set or os.path.realpath(out) in inputs_set:
                raise InvalidArgumentError(f"batch: output {out} would overwrite an input; "
                                           "choose another output folder")
            if str(out) in seen:
                raise InvalidArgumentError(f"batch: {src} and {seen[str(out)]} both map to "
                                           f"{out}")
            seen[str(out)] = src
            jobs.append((v, str(out), str(_sidecar_path(out_root, out)),
                         _options_key(op, options, v, read)))
        plan.append((str(src), jobs))

    all_outs = [pathlib.Path(o) for _, jobs in plan for _, o, _, _ in jobs]
    records_by_out: dict[str, dict] = {}
    todo = []
    for src, jobs in plan:
        need = []
        for job in jobs:
            v, out, side, key = job
            prev = None if force else _up_to_date(src, pathlib.Path(out), pathlib.Path(side), key)
            if prev is None:
                need.append(job)
            else:
                rec = {k: prev.get(k) for k in FIELDS}
                rec.update(input=src, output=out, variant=v, status=STATUS_SKIPPED, error="")
                records_by_out[out] = rec
        if need:
            todo.append((src, need))
    for d in {p.parent for p in all_outs}:
        d.mkdir(parents=True, exist_ok=True)
    _sweep(all_outs)

    n_used, address = 0, ""
    if todo:
        workers = n_workers or min(_default_workers(), len(todo))
        with _client(scheduler, workers if scheduler is None else None) as client:
            from distributed import as_completed
            address = client.scheduler.address if client.scheduler else ""
            n_used = len(client.scheduler_info().get("workers", {})) or workers
            bar = _Progress(len(todo), progress)
            futures = {}
            for src, need in todo:
                fut = client.submit(process_clip, op, src, need, options, metrics, read,
                                    pure=False)
                futures[fut] = (src, need)
            try:
                for fut in as_completed(futures):
                    src, need = futures[fut]
                    try:
                        recs = fut.result()
                    except Exception as e:  # noqa: BLE001  (e.g. KilledWorker)
                        recs = [{"input": src, "output": out, "variant": v,
                                 "status": STATUS_FAILED,
                                 "error": f"{type(e).__name__}: {e}"} for v, out, _, _ in need]
                    for r in recs:
                        records_by_out[r["output"]] = r
                    bar.update(any(r["status"] == STATUS_FAILED for r in recs))
            except BaseException:
                client.cancel(list(futures))
                raise
            finally:
                _sweep(all_outs)
    records = []
    for o in all_outs:
        r = records_by_out[str(o)]
        records.append({k: r.get(k) for k in FIELDS})
    for path, note in links:  # links to folders and dangling links: said, not silently lost
        rec = dict.fromkeys(FIELDS)
        rec.update(input=os.path.abspath(path), output="", variant={}, status=STATUS_LINK,
                   error=note)
        records.append(rec)
    result = BatchResult(op.name, records, time.perf_counter() - t0, n_used, address)
    if report is not None:
        result.write_report(report)
    return result
