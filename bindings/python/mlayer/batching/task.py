"""The task of one clip, run on a Dask worker: read the clip, run the operation for every
variant, write each output atomically with its sidecar, and return small records (status,
error text, frames, seconds, jitter and foot sliding before and after).

Quality figures are unit-free: jitter (:func:`mlayer.metrics.jitter`, per second cubed) and
foot sliding (:func:`mlayer.metrics.foot_sliding` on the contacts detected on the input) both
divided by the input's body height (:func:`mlayer.metrics.body_height`).
"""
from __future__ import annotations

import math
import os
import time

import numpy as np

from .._files import atomic_output
from ..bvh import _options as _bvh_options, read_bvh, write_bvh
from ..contacts import detect_contacts
from ..errors import InvalidArgumentError
from ..metrics import body_height, foot_sliding, jitter, units_arg
from ..motion import Motion
from ..trimming import frames_arg
from ..up_axis import axis_name
from .cache import write_sidecar
from .registry import Operation
from .report import STATUS_FAILED, STATUS_OK

__all__ = ["process_clip", "READ_OPTIONS"]

#: read_bvh's keywords that batch(read=...) passes to the workers.
READ_OPTIONS = ("strict", "up", "trim", "units")


def read_options(read) -> dict:
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
    out = {}
    if read.get("strict") is not None:
        _bvh_options(read["strict"], False, "batch: read")
        out["strict"] = read["strict"]
    for name, check_arg in (("up", axis_name), ("trim", frames_arg), ("units", units_arg)):
        if read.get(name) is not None:
            out[name] = check_arg(read[name], f"batch: read {name}")
    return out


def _metrics_before(motion):
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
        from distributed import get_worker  # optional: the batch extra
        return get_worker().address
    except Exception:  # noqa: BLE001  (not on a worker: a plain call)
        return f"pid {os.getpid()}"


def _write(result, out: str) -> int:
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
            write_sidecar(src, out, sidecar, key, r)
    return records
