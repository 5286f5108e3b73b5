"""Clips per second of mlayer.batch on Dask (1 and 2 workers) against a plain Python loop.

    python bench/python/bench_batch.py [--copies 25] [--op denoise] [--no-contacts]
                                       [--metrics] [--workers 1,2] [MOCAP_DIR]

The shared corpus (8 clips) is repeated to about 200 clips by links in a temporary folder (hard
links, or copies across file systems: batch refuses symbolic links that leave its input folder).
The loop does per clip what a batch task does: read_bvh, the operation, write_bvh (atomic) to
the output folder. Each Dask run uses a fresh LocalCluster (processes, one thread each, on
loopback) started before the clock; its start-up time is printed apart. Every run is forced
(no output skipped). The scheduling overhead per clip is (Dask wall - loop wall) / clips with
one worker, and, from the tasks' own timings, (wall x workers - sum of task times) / clips.
One pass per configuration (the machine is shared): rerun to see the spread.
"""
import argparse
import logging
import os
import pathlib
import shutil
import tempfile
import time

import mlayer
from mlayer.batching import batch, operations
# the task's writer (write_bvh, or np.savez atomically) and its figures
from mlayer.batching.task import _figures, _write
from mlayer.pipeline import Clip


def main():
    p = argparse.ArgumentParser()
    p.add_argument("mocap", nargs="?", default=str(pathlib.Path(__file__).resolve().parents[3]
                                                    / "shared" / "data" / "mocap"))
    p.add_argument("--copies", type=int, default=25)
    p.add_argument("--op", default="denoise", choices=["denoise", "stylize", "features"])
    p.add_argument("--no-contacts", action="store_true")
    p.add_argument("--metrics", action="store_true", help="also the jitter/sliding figures")
    p.add_argument("--workers", default="1,2")
    a = p.parse_args()

    from distributed import LocalCluster

    src = sorted(pathlib.Path(a.mocap).glob("*.bvh"))
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="mlayer-bench-batch-"))
    try:
        ind = tmp / "in"
        ind.mkdir()
        for k in range(a.copies):
            for f in src:
                dst = ind / f"c{k:03d}_{f.name}"
                try:
                    os.link(f, dst)
                except OSError:  # another file system
                    shutil.copyfile(f, dst)
        clips = sorted(ind.glob("*.bvh"))
        n = len(clips)
        frames = sum(mlayer.read_bvh(f).n_frames for f in src) * a.copies
        options = {"keep_contacts": False} if a.no_contacts else {}
        op = operations()[a.op]
        variants = [{"alpha": 2.0}] if op.uses_alphas else [{}]
        print(f"{n} clips ({len(src)} distinct, {frames} frames), operation {a.op}"
              f"{' without contact cleanup' if a.no_contacts else ''}"
              f"{', with metrics' if a.metrics else ''}; {os.cpu_count()} CPUs")

        # plain loop over the same functions the tasks call
        out = tmp / "loop"
        out.mkdir()
        t0 = time.perf_counter()
        for f in clips:
            clip = Clip(mlayer.read_bvh(f))
            if a.metrics:
                _figures(clip)
            res = op.run(clip, variants, **options)
            _write(res[0], str(out / (f.stem + op.extension)))
        t_loop = time.perf_counter() - t0
        print(f"{'plain loop':22} {t_loop:7.2f} s  {n / t_loop:7.1f} clips/s")

        rows = {}
        for w in [int(x) for x in a.workers.split(",")]:
            t0 = time.perf_counter()
            with LocalCluster(n_workers=w, threads_per_worker=1, processes=True, host="127.0.0.1",
                              dashboard_address=None, silence_logs=logging.ERROR) as cluster:
                t_start = time.perf_counter() - t0
                kw = {"alphas": [2.0]} if op.uses_alphas else {}
                res = batch(op.name, ind, tmp / f"dask{w}", scheduler=cluster, force=True,
                            progress=False, metrics=a.metrics, **kw, **options)
            assert res.ok == n, res.table()
            busy = sum(r["seconds"] for r in res.records)
            rows[w] = res.seconds
            over = (res.seconds * w - busy) / n
            print(f"{'dask, ' + str(w) + ' worker' + ('s' if w > 1 else ''):22} "
                  f"{res.seconds:7.2f} s  {n / res.seconds:7.1f} clips/s  (cluster start "
                  f"{t_start:.2f} s; tasks {busy:.2f} s; "
                  f"idle+scheduling {1e3 * over:.1f} ms/clip)")
        if 1 in rows:
            print(f"scheduling overhead vs the loop, 1 worker: "
                  f"{1e3 * (rows[1] - t_loop) / n:.1f} ms/clip")
            for w, t in rows.items():
                if w > 1:
                    print(f"scaling {w} workers vs 1: {rows[1] / t:.2f}x; vs the loop: "
                          f"{t_loop / t:.2f}x")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":  # the workers are spawned processes: they import this file
    main()
