"""Forward-kinematics passes per `mlayer stylize` / `mlayer denoise` run (issue: one pipeline).

Counts, for one CLI run in this process on a real clip:
- the passes the Python package asks for (every call of Motion.positions / world_rotations /
  forward_kinematics / end_site_positions goes through Motion._fk, wrapped here), split into
  passes over the input and over other motions;
- with --gdb (needs gdb on PATH): every call of the C function mlr_fk_arrays in a child process
  run under gdb, which adds the C core's own full passes (the guards' FK of their input). The
  contact cleanup's FK of the frames it corrects is its own (cleanup_fk.c) and not counted.

    python bench/python/bench_pipeline_passes.py [--clip PATH] [--gdb]
"""
from __future__ import annotations

import argparse
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
DEFAULT_CLIP = ROOT.parent / "shared" / "data" / "mocap" / "cmu_01_01_playground_jumps.bvh"


def python_passes(argv):
    import mlayer
    from mlayer.model import motion as M
    inputs = []
    counts = {"input": 0, "other": 0}
    orig = M.Motion._fk
    read = mlayer.read_bvh

    def counting_read(*a, **k):
        m = read(*a, **k)
        inputs.append(m)
        return m

    def counting_fk(self, want_rot):
        same = any(self.root_pos is m.root_pos or self.rot is m.rot for m in inputs)
        counts["input" if same else "other"] += 1
        return orig(self, want_rot)

    M.Motion._fk = counting_fk
    import mlayer.io.bvh
    import mlayer.pipeline.pipeline
    # every name the clip is read through (Clip.from_file imports read_bvh at its file's top)
    mlayer.io.bvh.read_bvh = mlayer.read_bvh = mlayer.pipeline.pipeline.read_bvh = counting_read
    try:
        from mlayer.cli import main
        with open(os.devnull, "w") as null:
            old = sys.stdout, sys.stderr
            sys.stdout = sys.stderr = null
            try:
                rc = main(argv)
            finally:
                sys.stdout, sys.stderr = old
    finally:
        M.Motion._fk = orig
        mlayer.io.bvh.read_bvh = mlayer.read_bvh = mlayer.pipeline.pipeline.read_bvh = read
    if rc != 0:
        raise SystemExit(f"mlayer {' '.join(argv)} failed ({rc})")
    return counts


def c_passes(argv):
    script = ("set breakpoint pending on\nset pagination off\nbreak mlr_fk_arrays\n"
              "commands\nsilent\ncontinue\nend\nrun\ninfo breakpoints\n")
    with tempfile.NamedTemporaryFile("w", suffix=".gdb", delete=False) as f:
        f.write(script)
    try:
        code = f"import sys; from mlayer.cli import main; sys.exit(main({argv!r}))"
        out = subprocess.run(["gdb", "-q", "-batch", "-x", f.name, "--args", sys.executable,
                              "-c", code], capture_output=True, text=True, timeout=600).stdout
    finally:
        os.unlink(f.name)
    for line in out.splitlines():
        if "breakpoint already hit" in line:
            return int(line.split("hit")[1].split()[0])
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default=str(DEFAULT_CLIP))
    ap.add_argument("--gdb", action="store_true", help="also count C calls of mlr_fk_arrays")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "out.bvh")
        for argv in (["stylize", a.clip, "--alpha", "2", "-o", out],
                     ["denoise", a.clip, "-o", out]):
            py = python_passes(argv)
            line = (f"mlayer {argv[0]:8s} {pathlib.Path(a.clip).name}: Python FK passes "
                    f"{py['input']} over the input, {py['other']} over other motions")
            if a.gdb:
                if shutil.which("gdb") is None:
                    raise SystemExit("--gdb: gdb is not on PATH")
                line += f"; mlr_fk_arrays calls in all (Python and C) {c_passes(argv)}"
            print(line)


if __name__ == "__main__":
    main()
