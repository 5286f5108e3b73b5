"""BVH reading speed: mlayer.read_bvh against the Python BVH readers on PyPI, on the long shared
clips, in one run. Prints the median time of the repeats, MB/s, frames/s and each peer's time
divided by mlayer's (how many times faster mlayer is).

    python bench/python/bench_bvh.py [--clips lafan1_clip_a.bvh,cmu_01_01_playground_jumps.bvh]
                                     [--repeat 7] [--peer-repeat 3] [--mocap DIR]

Rows for mlayer: read_bvh as users call it (default threads: one per 512 KiB of frames, at most
the processors; the row every peer ratio refers to), the same on one thread, and both from
memory (bytes already read). The readers take turns in rounds (--peer-repeat of them; mlayer's
calls are spread over the rounds), so that the slow and fast spells of a shared machine fall on
all of them; in each round mlayer's first call, right after the peers, is timed on a row of its
own ("1st after peers"): the peers' memory use leaves glibc handing out new pages, whose first
touch costs a page fault each, so that call shows what a read costs with a cold heap.
Peers (each optional: pip install pybvh bvhtools bvhio bvh bvhtoolbox bvhsdk). What each one
does differs: mlayer parses and converts every joint's Euler angles to quaternions; pybvh
(np.loadtxt) and bvhtools keep Euler angles; bvhio builds per-joint glm poses; `bvh` and
bvhtoolbox only split the text into strings, so the bench converts their frames with
np.array(..., dtype=float) to get numbers at all; bvhsdk builds its animation objects.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import pathlib
import time
import warnings

import numpy as np

import mlayer
from benchutil import mocap_dir

HERE = pathlib.Path(__file__).resolve()
DEFAULT_MOCAP = mocap_dir()


def peers():
    """(name, reader(path)) for every peer that imports."""
    out = []
    try:
        import pybvh
        out.append(("pybvh", lambda p: pybvh.read_bvh_file(p)))
    except ImportError:
        pass
    try:
        import bvhTools.bvhIO as bvhtools_io
        out.append(("bvhtools", lambda p: bvhtools_io.readBvh(str(p))))
    except ImportError:
        pass
    try:
        import bvhio
        out.append(("bvhio.readAsBvh", lambda p: bvhio.readAsBvh(str(p))))
    except ImportError:
        pass
    try:
        import bvh

        def read_bvh_pkg(p):
            with open(p) as f:
                m = bvh.Bvh(f.read())
            return np.array(m.frames, dtype=float)
        out.append(("bvh (+np.array)", read_bvh_pkg))
    except ImportError:
        pass
    try:
        import bvhtoolbox

        def read_toolbox(p):
            with open(p) as f:
                m = bvhtoolbox.BvhTree(f.read())
            return np.array(m.frames, dtype=float)
        out.append(("bvhtoolbox (+np.array)", read_toolbox))
    except ImportError:
        pass
    try:
        import bvhsdk.bvh as bvhsdk_bvh

        def read_sdk(p):
            with contextlib.redirect_stdout(io.StringIO()):  # it prints per joint
                return bvhsdk_bvh.ReadFile(str(p))
        out.append(("bvhsdk", read_sdk))
    except ImportError:
        pass
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", default="lafan1_clip_a.bvh,cmu_01_01_playground_jumps.bvh")
    ap.add_argument("--repeat", type=int, default=7, help="repeats for mlayer")
    ap.add_argument("--peer-repeat", type=int, default=3, help="repeats for each peer")
    ap.add_argument("--mocap", default=os.environ.get("MLR_TEST_MOCAP_DIR", str(DEFAULT_MOCAP)))
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    peer_list = peers()
    print(f"{'clip':<32} {'reader':<24} {'median ms':>10} {'MB/s':>8} {'frames/s':>11}"
          f" {'peer/mlayer':>12}")
    for clip in a.clips.split(","):
        path = pathlib.Path(a.mocap) / clip
        size = path.stat().st_size
        data = path.read_bytes()
        n_frames = mlayer.read_bvh(path).n_frames

        def row(name, t, base=None):
            ratio = f"{t / base:12.1f}" if base else f"{'':>12}"
            print(f"{clip:<32} {name:<24} {t * 1e3:10.2f} {size / t / 1e6:8.1f}"
                  f" {n_frames / t:11.0f} {ratio}", flush=True)

        mine = {
            "mlayer.read_bvh": lambda: mlayer.read_bvh(path),
            "mlayer.read_bvh threads=1": lambda: mlayer.read_bvh(path, threads=1),
            "mlayer (from memory)": lambda: mlayer.read_bvh_string(data),
            "mlayer (memory, 1 thr.)": lambda: mlayer.read_bvh_string(data, threads=1),
        }
        theirs = {}
        for name, reader in peer_list:
            try:
                reader(path)  # warm up, and skip peers that cannot read the clip
            except Exception as e:  # noqa: BLE001 - a peer's failure is a result, not a crash
                print(f"{clip:<32} {name:<24} fails: {type(e).__name__}: {str(e)[:60]}")
                continue
            theirs[name] = (lambda r: lambda: r(path))(reader)
        # rounds with every reader in each, so that the shared machine's slow and fast spells
        # fall on mlayer and the peers alike. In each round mlayer's first call comes right
        # after the peers have allocated and freed their memory: glibc then hands out new pages,
        # whose first touch costs a page fault each (about 1.5 ms per 5 MB here). That call is
        # timed on its own row; the others are the steady state of a loop over files.
        rounds = max(1, a.peer_repeat)
        per_round = max(1, -(-a.repeat // rounds))
        cold = "mlayer, 1st after peers"
        times = {name: [] for name in (*mine, cold, *theirs)}
        for _ in range(rounds):
            for name, fn in mine.items():
                t0 = time.perf_counter()
                fn()
                if name == "mlayer.read_bvh":
                    times[cold].append(time.perf_counter() - t0)
                for _ in range(per_round):
                    t0 = time.perf_counter()
                    fn()
                    times[name].append(time.perf_counter() - t0)
            for name, fn in theirs.items():
                t0 = time.perf_counter()
                fn()
                times[name].append(time.perf_counter() - t0)
        med = {name: float(np.median(v)) for name, v in times.items()}
        for name in (*mine, cold):
            row(name, med[name])
        t_ml, t_1 = med["mlayer.read_bvh"], med["mlayer.read_bvh threads=1"]
        for name in theirs:
            row(name, med[name], t_ml)
            print(f"{'':<32} {'  (vs mlayer threads=1)':<24} {'':>10} {'':>8} {'':>11}"
                  f" {med[name] / t_1:12.1f}")
    print(f"Medians of {per_round * rounds} (mlayer) and {rounds} (peers) runs in {rounds} rounds "
          "of every reader, after mlayer's first call of the round (timed on its own row); "
          "file reading included except for 'from memory'. peer/mlayer = how many times "
          "longer the peer takes than mlayer.read_bvh (default threads; the line below it: "
          f"threads=1). {os.cpu_count()} processors.")


if __name__ == "__main__":
    main()
