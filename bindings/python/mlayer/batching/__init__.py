"""Corpus-scale batch processing: clean, stylize, resample and featurize mocap libraries, in
parallel on this machine or on a Dask cluster.

    result = mlayer.batch("stylize", "clips/", "out/", alphas=[0.5, 1.5, 2.0])
    result = mlayer.batch("denoise", "captures/**/*.bvh", "clean/", scheduler="tcp://host:8786")

A task is a chunk of clips (largest first, about four tasks per worker, at most eight clips
each): for each clip it reads it, runs the operation for every requested variant (one output
per alpha for stylize, sharing one decomposition), writes each output atomically and returns
small records (status, error text, frames, seconds, jitter and foot sliding before and after).
Only paths and records travel between the processes; the clips are read and written by the
workers, so with a remote cluster the input and output folders must be visible to every worker
under the same paths (a shared file system), and the workers need mlayer installed.

Without ``scheduler``, the tasks run on a local :class:`concurrent.futures.ProcessPoolExecutor`
of one single-threaded worker process per CPU (``n_workers`` to change it): workers times
threads never exceed the cores, and no Dask is needed. With ``scheduler`` (an address, a
Client or a Cluster) they run on Dask; ``scheduler="dask"`` starts an embedded
``dask.distributed.LocalCluster`` on loopback (mutual TLS with temporary credentials: no other
process can submit work to it; no dashboard: its HTTP servers, on free ports, answer every
request with 404), one single-threaded worker process per CPU, closed at the end.

Nothing is lost:
- every output is written to a temporary file and renamed into place, then a small sidecar
  ``OUT_DIR/.mlayer-batch/<output>.json`` records the input's size and modification time, the
  hash of the options (operation, its arguments, the variant, the mlayer version) and the
  output's size and time. A re-run skips every output whose sidecar matches (the input and
  the options are unchanged and the output was not touched since), so an interrupted run
  resumes where it stopped; ``force=True`` redoes everything.
- an exception on one clip becomes a "failed" record with its error text; the batch goes on.
  A worker process of the local pool that dies (killed, or crashed in native code) takes its
  pool down: the clips not done are run again one at a time, so the clip that kills its process
  is reported failed and the others are done. On Dask, a worker that dies is replaced and its
  task re-run (up to ``distributed.scheduler.allowed-failures`` times, then its clips are
  reported as failed).
- temporary files left by a killed writer of one of this batch's outputs or sidecars (named
  by the rule of ``mlr_bvh.h``, :func:`mlayer._files.stale_temporaries`) are removed at the
  start and at the end of the run.

Quality figures in the records are unit-free: jitter (:func:`mlayer.guards.metrics.jitter`, per
second cubed) and foot sliding (:func:`mlayer.guards.metrics.foot_sliding` on the contacts detected
on the input) both divided by the input's body height (:func:`mlayer.guards.metrics.body_height`).

The function is :func:`mlayer.batch` (this subpackage has another name, so that
``import mlayer.batching`` gives the module); its parts:

- :mod:`.registry`: the operations (what each one does to one clip) and their variants;
- :mod:`.inputs`: finding the clips (folders, globs, files, exclusions, symbolic links);
- :mod:`.task`: the task of one clip on a worker (read, operation, write, figures), and of a
  chunk of clips;
- :mod:`.cache`: the outputs' up-to-date key, their sidecars, stale temporaries;
- :mod:`.report`: the records, the summary table, the CSV/JSON report (the progress bar over
  clips is tqdm's, through mlayer._progress);
- :mod:`.run`: the local pool or the Dask cluster, the chunks, ``batch`` itself.
"""
from __future__ import annotations

from .cache import SIDECAR_DIR
from .inputs import find_inputs
from .registry import Operation, operations, parse_alphas, register_operation
from .report import (FIELDS, STATUS_FAILED, STATUS_LINK, STATUS_OK, STATUS_SKIPPED,
                     BatchResult)
from .run import batch
from .task import READ_OPTIONS, process_clip

__all__ = ["batch", "BatchResult", "Operation", "register_operation", "operations",
           "parse_alphas", "find_inputs", "process_clip", "SIDECAR_DIR", "READ_OPTIONS",
           "FIELDS", "STATUS_OK", "STATUS_SKIPPED", "STATUS_FAILED", "STATUS_LINK"]
