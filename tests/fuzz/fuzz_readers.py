"""Fuzz the glTF and AMASS readers for a bounded time (issue 39, item 2).

    python tests/fuzz/fuzz_readers.py [--seconds 30] [--seed 0] [--keep DIR] [MOCAP_DIR]

Seeds: glTF (JSON with a data: buffer, JSON with a buffer file beside it, GLB) and AMASS .npz
files (stored and deflated) written by mlayer from the shared clips (MOCAP_DIR, default
../shared/data/mocap beside the repository). Each case is a seed mutated by byte flips,
inserted or deleted runs, JSON numbers replaced by extreme values, or zip members damaged, and
read by mlayer.read_gltf / mlayer.read_amass in a child process under a memory limit
(RLIMIT_AS 3 GiB) with a time limit per case. A case passes when the reader returns a Motion
or raises one of mlayer's errors; any other exception, a signal, running out of memory or of
time is a failure: its input is kept (--keep, default build-fuzz/readers/) and the script
exits 1. Each reader gets --seconds of cases.
"""
from __future__ import annotations

import argparse
import io
import json
import multiprocessing as mp
import os
import pathlib
import random
import shutil
import sys
import tempfile
import time
import zipfile

import numpy as np

MEMORY = 3 << 30  # bytes of address space the child may use
CASE_SECONDS = 20.0
EXTREMES = [0, -1, 1, 2**31, 2**32 + 1, 2**53, 10**18, -(2**63), 1e308, -1e308, 1e-320, 0.5]


def _child(conn) -> None:
    """Read the cases the parent sends; answer "ok", "mlayer" or "other: ..." for each."""
    import resource
    import warnings
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))
    warnings.simplefilter("ignore")
    import mlayer
    from mlayer.errors import Error as MlayerError
    while True:
        kind, path = conn.recv()
        try:
            if kind == "gltf":
                mlayer.read_gltf(path)
            else:
                mlayer.read_amass(path)
            conn.send("ok")
        except MlayerError:
            conn.send("mlayer")
        except BaseException as e:  # noqa: BLE001 - what the fuzzing looks for
            conn.send(f"other: {type(e).__name__}: {str(e)[:300]}")


class Runner:
    """The child process, restarted after a crash or a hang."""

    def __init__(self) -> None:
        self.ctx = mp.get_context("spawn")
        self.proc = None
        self.conn = None

    def start(self) -> None:
        parent, child = self.ctx.Pipe()
        self.proc = self.ctx.Process(target=_child, args=(child,), daemon=True)
        self.proc.start()
        self.conn = parent

    def run(self, kind: str, path: str) -> str:
        if self.proc is None or not self.proc.is_alive():
            self.start()
        self.conn.send((kind, path))
        if not self.conn.poll(CASE_SECONDS):
            self.stop()
            return f"hang: no answer within {CASE_SECONDS:g} s"
        try:
            return self.conn.recv()
        except (EOFError, OSError):
            code = self.proc.exitcode
            self.stop()
            return f"crash: the child died (exit code {code})"

    def stop(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.join(5)
        self.proc = self.conn = None


def _seeds(mocap: pathlib.Path, folder: pathlib.Path) -> dict[str, list[pathlib.Path]]:
    import warnings

    import mlayer
    warnings.simplefilter("ignore", mlayer.MlayerWarning)  # (CMU's unknown unit, written as m)
    out: dict[str, list[pathlib.Path]] = {"gltf": [], "amass": []}
    clips = sorted(mocap.glob("*.bvh"))[:3]
    for k, c in enumerate(clips):
        m = mlayer.read_bvh(c)[:12]
        p = folder / f"s{k}.gltf"
        mlayer.write_gltf(m, p, mesh=False)
        out["gltf"].append(p)
        g = folder / f"s{k}.glb"
        mlayer.write_gltf(m, g, mesh=False)
        out["gltf"].append(g)
    # one with its buffer in a file beside it
    doc = json.loads(out["gltf"][0].read_text())
    import base64
    data = base64.b64decode(doc["buffers"][0]["uri"].partition(",")[2])
    (folder / "side.bin").write_bytes(data)
    doc["buffers"][0]["uri"] = "side.bin"
    side = folder / "side.gltf"
    side.write_text(json.dumps(doc))
    out["gltf"].append(side)
    rng = np.random.default_rng(0)
    for k, (width, compress) in enumerate([(156, False), (72, True), (165, False)]):
        p = folder / f"a{k}.npz"
        arrays = {"poses": 0.3 * rng.standard_normal((10, width)),
                  "trans": rng.standard_normal((10, 3)), "mocap_framerate": np.array(60.0),
                  "betas": np.zeros(16), "gender": np.array("neutral")}
        (np.savez_compressed if compress else np.savez)(p, **arrays)
        out["amass"].append(p)
    return out


def _mutate_bytes(b: bytes, rng: random.Random) -> bytes:
    a = bytearray(b)
    for _ in range(rng.randint(1, 8)):
        op = rng.random()
        if not a:
            a += bytes([rng.randrange(256)])
        elif op < 0.5:
            a[rng.randrange(len(a))] = rng.randrange(256)
        elif op < 0.7:
            i = rng.randrange(len(a))
            del a[i:i + rng.randint(1, 64)]
        elif op < 0.85:
            i = rng.randrange(len(a) + 1)
            a[i:i] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
        else:
            i, j = rng.randrange(len(a)), rng.randrange(len(a))
            a[i:i] = a[j:j + rng.randint(1, 256)]
    return bytes(a)


def _mutate_json(text: str, rng: random.Random) -> str:
    """A number of the JSON replaced by an extreme value, or a list grown or emptied."""
    try:
        doc = json.loads(text)
    except ValueError:
        return text
    nodes = []

    def walk(x, parent, key):
        nodes.append((parent, key, x))
        if isinstance(x, dict):
            for k, v in x.items():
                walk(v, x, k)
        elif isinstance(x, list):
            for i, v in enumerate(x):
                walk(v, x, i)
    walk(doc, None, None)
    for _ in range(rng.randint(1, 4)):
        parent, key, x = rng.choice(nodes)
        if parent is None:
            continue
        r = rng.random()
        if isinstance(x, (int, float)) and not isinstance(x, bool) or r < 0.3:
            parent[key] = rng.choice(EXTREMES)
        elif isinstance(x, list) and r < 0.6:
            parent[key] = x * rng.randint(0, 50)
        elif r < 0.8:
            parent[key] = rng.choice([None, "", "x" * 1000, [], {}, True, "../side.bin"])
        else:
            parent[key] = {"nested": [[[[[[x]]]]]]}
    return json.dumps(doc)


def _mutate_zip(b: bytes, rng: random.Random) -> bytes:
    """A member of the archive rewritten: damaged, emptied, replaced by a raw pickle, or its
    .npy header changed to declare another shape."""
    try:
        src = zipfile.ZipFile(io.BytesIO(b))
        names = src.namelist()
        members = {n: src.read(n) for n in names}
    except Exception:  # noqa: BLE001 - a broken archive stays as it is
        return _mutate_bytes(b, rng)
    n = rng.choice(names)
    r = rng.random()
    if r < 0.3:
        members[n] = _mutate_bytes(members[n], rng)
    elif r < 0.45:
        members[n] = b""
    elif r < 0.6:
        import pickle
        members[n] = pickle.dumps([1, 2, 3])
    else:
        head = members[n][:128].replace(b"(10,", b"(%d," % rng.choice([0, 1, 10**9, 10**15]))
        members[n] = head + members[n][128:]
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", rng.choice([zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED])) as z:
        for k, v in members.items():
            z.writestr(k, v)
    return out.getvalue()


def fuzz(kind: str, seeds: list[pathlib.Path], seconds: float, rng: random.Random,
         folder: pathlib.Path, keep: pathlib.Path, runner: Runner) -> tuple[int, int]:
    cases = fails = read = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        seed = rng.choice(seeds)
        raw = seed.read_bytes()
        if kind == "gltf" and seed.suffix == ".gltf" and rng.random() < 0.5:
            data = _mutate_json(raw.decode(), rng).encode()
        elif kind == "amass" and rng.random() < 0.6:
            data = _mutate_zip(raw, rng)
        else:
            data = _mutate_bytes(raw, rng)
        case = folder / f"case{seed.suffix}"
        case.write_bytes(data)
        got = runner.run(kind, str(case))
        cases += 1
        read += got == "ok"
        if got not in ("ok", "mlayer"):
            fails += 1
            keep.mkdir(parents=True, exist_ok=True)
            kept = keep / f"{kind}-{cases}{seed.suffix}"
            shutil.copyfile(case, kept)
            print(f"fuzz_readers: {kind}: {got} ({kept})", flush=True)
    print(f"fuzz_readers: {kind}: {read} of the cases read as motions, the others refused "
          "with mlayer's errors or failed", flush=True)
    return cases, fails


def main(argv: list[str] | None = None) -> int:
    root = pathlib.Path(__file__).resolve().parents[2]
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mocap", nargs="?", default=os.environ.get(
        "MLR_TEST_MOCAP_DIR", str(root.parent / "shared" / "data" / "mocap")))
    ap.add_argument("--seconds", type=float, default=30.0, help="per reader")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--keep", default=str(root / "build-fuzz" / "readers"))
    a = ap.parse_args(argv)
    rng = random.Random(a.seed)
    runner = Runner()
    total_fails = 0
    with tempfile.TemporaryDirectory(prefix="mlr_fuzz_readers.") as tmp:
        folder = pathlib.Path(tmp)
        seeds = _seeds(pathlib.Path(a.mocap), folder)
        try:
            for kind in ("gltf", "amass"):
                cases, fails = fuzz(kind, seeds[kind], a.seconds, rng, folder,
                                    pathlib.Path(a.keep), runner)
                total_fails += fails
                print(f"fuzz_readers: {kind}: {cases} cases in {a.seconds:g} s, {fails} failed",
                      flush=True)
        finally:
            runner.stop()
    return 1 if total_fails else 0


if __name__ == "__main__":
    sys.exit(main())
