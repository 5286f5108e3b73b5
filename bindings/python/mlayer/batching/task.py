"""The task of one clip, run on a worker (a process of the local pool, or Dask's): read the
clip, run the operation for every variant, write each output atomically with its sidecar, and
return small records (status, error text, frames, seconds, jitter and foot sliding before and
after). A task of the batch is a chunk of clips (:func:`process_chunk`).

Quality figures are unit-free: jitter (:func:`mlayer.guards.metrics.jitter`, per second cubed) and
foot sliding (:func:`mlayer.guards.metrics.foot_sliding` on the contacts detected on the input)
both divided by the input's body height (:func:`mlayer.guards.metrics.body_height`).
"""
from __future__ import annotations

import math
import os
import sys
import time
from typing import Any

import numpy as np

from .._files import atomic_output
from ..io.bvh import _options as _bvh_options, read_bvh, write_bvh
from ..errors import InvalidArgumentError
from ..model.motion import Motion
from ..pipeline.pipeline import Clip
from ..model.trimming import frames_arg
from ..model.units import units_arg
from ..model.up_axis import axis_name
from .cache import write_sidecar
from .registry import Operation
from .report import STATUS_FAILED, STATUS_OK

__all__ = ["process_clip", "process_chunk", "READ_OPTIONS"]

#: read_bvh's keywords that batch(read=...) passes to the workers.
READ_OPTIONS = ("strict", "up", "trim", "units")


def read_options(read: dict[str, Any] | None) -> dict[str, Any]:
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


def _figures(clip: Clip, out: Motion | None = None) -> tuple[float, float]:
    """(jitter, foot sliding) of the input, or of an output ``out``, in body heights
    (:meth:`mlayer.pipeline.pipeline.Clip.jitter` and
    :meth:`~mlayer.pipeline.pipeline.Clip.foot_sliding`: the input's forward kinematics and
    contacts are computed once for every output)."""
    j = clip.jitter(out)
    try:
        s = clip.foot_sliding(out)
    except Exception:  # noqa: BLE001  (a figure is not worth failing the clip)
        s = float("nan")
    return j, s


def _fin(x: Any) -> float | None:
    """JSON-safe float (None for NaN/inf)."""
    try:
        f = float(x)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def _worker_name() -> str:
    """The Dask worker's address, or ``pid N`` (a process of the local pool, a plain call).
    Dask is not imported for it: a process that has not imported it is no Dask worker."""
    if "distributed" in sys.modules:
        try:
            from distributed import get_worker  # optional: the batch extra
            return str(get_worker().address)
        except Exception:  # noqa: BLE001  (not on a worker: a plain call)
            pass
    return f"pid {os.getpid()}"


def _write(result: Motion | dict[str, Any], out: str) -> int:
    if isinstance(result, Motion):
        write_bvh(result, out)
        return result.n_frames
    if isinstance(result, dict):
        with atomic_output(out, ".npz") as tmp:
            np.savez(tmp, **result)
        return int(result["rot"].shape[0]) if "rot" in result else 0
    raise TypeError(f"operation returned {type(result).__name__}, expected a Motion or a dict")


def process_clip(op: Operation, src: str, jobs: list[tuple[dict[str, Any], str, str, str]],
                 options: dict[str, Any], metrics: bool = True,
                 read: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """The task of one clip on a worker: read, run the operation, write, measure.

    Never raises for a bad clip: the error goes in the records.

    Parameters
    ----------
    op : Operation
        The operation.
    src : str
        The input clip.
    jobs : list of tuple
        (variant, output path, sidecar path, options key) per output.
    options : dict
        The operation's keyword options.
    metrics : bool, optional
        Measure jitter and foot sliding before and after.
    read : dict, optional
        read_bvh's keyword arguments (strict, up, trim, units).

    Returns
    -------
    list of dict
        One record per job (the keys of :data:`mlayer.batching.FIELDS`).
    """
    t0 = time.perf_counter()
    worker = _worker_name()
    records: list[dict[str, Any]] = [
        {"input": src, "output": out, "variant": variant, "status": STATUS_FAILED,
         "error": "", "worker": worker} for variant, out, _, _ in jobs]
    try:
        motion = read_bvh(src, threads=1, **(read or {}))  # the workers are the parallelism
        for r in records:
            r["frames"], r["fps"] = motion.n_frames, motion.fps
        clip = Clip(motion, name=src)
        before = _figures(clip) if metrics else None
        results = op.run(clip if op.takes_clip else motion, [v for v, _, _, _ in jobs],
                         **options)
        if len(results) != len(jobs):
            raise RuntimeError(f"operation {op.name} returned {len(results)} results for "
                               f"{len(jobs)} variants")
        for r, res, (_variant, out, _sidecar, _key) in zip(records, results, jobs):
            r["frames_out"] = _write(res, out)
            if before is not None:
                r["jitter_before"], r["sliding_before"] = map(_fin, before)
                if not isinstance(res, dict):
                    r["jitter_after"], r["sliding_after"] = map(_fin, _figures(clip, res))
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


def process_chunk(op: Operation,
                  chunk: list[tuple[str, list[tuple[dict[str, Any], str, str, str]]]],
                  options: dict[str, Any], metrics: bool = True,
                  read: dict[str, Any] | None = None) -> list[list[dict[str, Any]]]:
    """One task of a batch: :func:`process_clip` for each clip of a chunk, in turn.

    Parameters
    ----------
    op : Operation
        The operation.
    chunk : list of tuple
        (input clip, jobs) per clip, the jobs as :func:`process_clip` takes them.
    options : dict
        The operation's keyword options.
    metrics : bool, optional
        Measure jitter and foot sliding before and after.
    read : dict, optional
        read_bvh's keyword arguments (strict, up, trim, units).

    Returns
    -------
    list of list of dict
        The records of each clip, in the chunk's order.
    """
    return [process_clip(op, src, jobs, options, metrics, read) for src, jobs in chunk]
