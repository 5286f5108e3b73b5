"""Clips per second of `mlayer.batch` with its defaults against a plain loop in one process.

    python bench/python/bench_batch.py [FOLDER_OR_GLOB ...] [--min-clips 100] [--repeat 3]
                                       [--op denoise] [--workers N] [--dask]

The clips: every .bvh of the folders or globs given (default: the shared real clips,
$MLR_TEST_MOCAP_DIR or ../shared/data/mocap beside the repo), repeated by hard links (copies
across file systems) in a temporary folder until there are at least --min-clips of them.

Timed --repeat times each, round robin (median; the machine is shared), every run forced (no
output skipped), in the same process:
- loop: per clip what a batch task does, in one process: read_bvh, the operation, the
  output written (write_bvh, atomic), without the metrics;
- loop + metrics: the same with the jitter and foot-sliding figures before and after (the
  work of a batch with its defaults);
- batch --no-metrics: mlayer.batch(..., metrics=False), otherwise its defaults (the local
  process pool, one worker per CPU, chunks of clips);
- batch (defaults): mlayer.batch(...) with its defaults, metrics included;
- with --dask: the defaults on an embedded Dask cluster (scheduler="dask"; its start-up is in
  the time, as for a user).
Printed: wall seconds and clips/s per configuration, and the ratios of the batches' wall times
to the loops' (below 1: the batch is faster).
"""
from __future__ import annotations

import argparse
import glob
import os
import pathlib
import shutil
import tempfile
import time
import warnings

import numpy as np
from benchutil import mocap_dir

import mlayer
from mlayer.batching import operations
# the task's writer and figures: the loop does what a batch task does
from mlayer.batching.task import _figures, _write
from mlayer.pipeline.pipeline import Clip


def find(items: list[str]) -> list[pathlib.Path]:
    out: list[pathlib.Path] = []
    for item in items:
        p = pathlib.Path(item)
        if p.is_dir():
            out += sorted(p.rglob("*.bvh"))
        else:
            out += sorted(pathlib.Path(f) for f in glob.glob(item, recursive=True))
    return sorted(set(out))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("inputs", nargs="*", help="folders or globs of .bvh files")
    p.add_argument("--min-clips", type=int, default=100)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--op", default="denoise", choices=["denoise", "stylize", "features"])
    p.add_argument("--workers", type=int, help="n_workers (default: the batch's, one per CPU)")
    p.add_argument("--dask", action="store_true", help="also an embedded Dask cluster")
    a = p.parse_args()
    # the clips' parse and guard warnings (the forked pool workers inherit the filter)
    warnings.simplefilter("ignore")

    src = find(a.inputs or [str(mocap_dir())])
    src = [f for f in src if _readable(f)]
    if not src:
        raise SystemExit("bench_batch: no readable .bvh files")
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="mlayer-bench-batch-"))
    try:
        ind = tmp / "in"
        ind.mkdir()
        copies = -(-a.min_clips // len(src))
        for k in range(copies):
            for i, f in enumerate(src):
                dst = ind / f"c{k:03d}_{i:04d}_{f.name}"
                try:
                    os.link(f, dst)
                except OSError:  # another file system
                    shutil.copyfile(f, dst)
        clips = sorted(ind.glob("*.bvh"))
        n = len(clips)
        op = operations()[a.op]
        variants = [{"alpha": 2.0}] if op.uses_alphas else [{}]
        kw = {"alphas": [2.0]} if op.uses_alphas else {}
        print(f"{n} clips ({len(src)} distinct files x {copies}), operation {a.op}; "
              f"{len(os.sched_getaffinity(0))} CPUs; mlayer {mlayer.__version__}; "
              f"median of {a.repeat}")

        def loop(metrics: bool) -> None:
            out = tmp / "loop"
            shutil.rmtree(out, ignore_errors=True)
            out.mkdir()
            for f in clips:
                try:  # a clip that fails is a failed record in the batch: caught here too
                    clip = Clip(mlayer.read_bvh(f, threads=1))
                    if metrics:
                        _figures(clip)
                    res = op.run(clip if op.takes_clip else clip.motion, variants)
                    _write(res[0], str(out / (f.stem + op.extension)))
                    if metrics and not isinstance(res[0], dict):
                        _figures(clip, res[0])
                except mlayer.Error:
                    pass

        def run_batch(**extra) -> None:
            res = mlayer.batch(op.name, ind, tmp / "batch", force=True, progress=False,
                               n_workers=a.workers, **kw, **extra)
            assert res.ok + res.failed == n, res.table()

        configs = [("loop", lambda: loop(False)), ("loop + metrics", lambda: loop(True)),
                   ("batch --no-metrics", lambda: run_batch(metrics=False)),
                   ("batch (defaults)", lambda: run_batch())]
        if a.dask:
            configs.append(("batch on embedded Dask", lambda: run_batch(scheduler="dask")))
        # round robin (each repeat runs every configuration), so that a change of the
        # machine's load falls on all of them alike
        times: dict[str, list[float]] = {name: [] for name, _ in configs}
        for _ in range(a.repeat):
            for name, fn in configs:
                t0 = time.perf_counter()
                fn()
                times[name].append(time.perf_counter() - t0)
        walls = {name: float(np.median(t)) for name, t in times.items()}
        for name, t in times.items():
            print(f"{name:24} {walls[name]:7.2f} s  {n / walls[name]:7.1f} clips/s  "
                  f"(runs: {', '.join(f'{x:.2f}' for x in t)} s)")
        ratios = [("batch --no-metrics", "loop"), ("batch (defaults)", "loop + metrics"),
                  ("batch (defaults)", "loop")]
        if a.dask:
            ratios.append(("batch on embedded Dask", "loop + metrics"))
        for b, lp in ratios:
            print(f"{b + ' / ' + lp + ':':38} {walls[b] / walls[lp]:.2f}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _readable(f: pathlib.Path) -> bool:
    return f.is_file() and os.access(f, os.R_OK)


if __name__ == "__main__":  # the embedded Dask cluster's workers import this file again
    main()
