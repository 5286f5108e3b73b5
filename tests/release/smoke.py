"""Smoke test of an installed mlayer wheel, run by tests/release/run.sh in a fresh venv.

    python smoke.py VERSION OUT_DIR
    python smoke.py                   (cibuildwheel's test: the installed version, a temporary
                                       folder; Linux, macOS and Windows)

Imports the package, reads the bundled clip, denoises, stylizes and writes it, runs the CLI
(`mlayer --version`, `mlayer denoise`), and checks that the wheel has no CHOLMOD: have_cholmod()
is False, solver="cholmod" raises UnsupportedError with one line saying how to get it, and no
SuiteSparse library was loaded into this process. Exits non-zero with a message on failure.
"""
from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
import tempfile


def fail(msg: str) -> None:
    sys.exit(f"smoke: {msg}")


def loaded_libraries() -> list[str]:
    """The files mapped into this process (Linux; elsewhere none are listed)."""
    try:
        with open("/proc/self/maps") as f:
            return sorted({line.split()[-1] for line in f if "/" in line})
    except OSError:
        return []


def main() -> None:
    if len(sys.argv) == 3:
        version, out = sys.argv[1], pathlib.Path(sys.argv[2])
    elif len(sys.argv) == 1:
        from importlib.metadata import version as dist_version
        version, out = dist_version("mlayer"), pathlib.Path(tempfile.mkdtemp(prefix="smoke-"))
    else:
        fail("usage: smoke.py [VERSION OUT_DIR]")
    out.mkdir(parents=True, exist_ok=True)
    import numpy as np
    import mlayer

    where = pathlib.Path(mlayer.__file__).resolve()
    if "site-packages" not in where.parts:
        fail(f"mlayer imported from {where}, not from the installed wheel")
    if mlayer.__version__ != version or mlayer.library_version() != version:
        fail(f"versions {mlayer.__version__} / {mlayer.library_version()}, expected {version}")

    m = mlayer.data.load_sample()
    if (m.n_frames, m.skeleton.n_joints) != (994, 31):
        fail(f"sample clip: {m.n_frames} frames, {m.skeleton.n_joints} joints")
    clean = mlayer.denoise(m)
    bold = mlayer.stylize(m, 2.0)
    for name, mo in (("denoised", clean), ("stylized", bold)):
        if mo.n_frames != m.n_frames or not np.all(np.isfinite(mo.rot)):
            fail(f"{name}: bad result")
    mlayer.write_bvh(bold, out / "bold.bvh")
    back = mlayer.read_bvh(out / "bold.bvh")
    if not np.allclose(back.root_pos, bold.root_pos, atol=1e-3):
        fail("the written clip does not read back")
    x = mlayer.lgs(np.arange(50.0), lam=2.0)
    if x.shape != (50,) or not np.allclose(x, np.arange(50.0), atol=1e-9):
        fail("lgs of a line is not the line")

    if mlayer.have_cholmod():
        fail("the wheel was built with CHOLMOD")
    try:
        mlayer.lgs(np.zeros(10), solver="cholmod")
    except mlayer.UnsupportedError as e:
        text = str(e)
        if "\n" in text or "pip install" not in text:
            fail(f"the no-CHOLMOD message is not one line saying how to get it: {text!r}")
    else:
        fail("solver='cholmod' did not raise UnsupportedError")

    # the console script beside this interpreter (bin/mlayer, Scripts\\mlayer.exe)
    exe = shutil.which("mlayer", path=os.path.dirname(sys.executable))
    if exe is None:
        fail(f"no mlayer command beside {sys.executable}")
    got = subprocess.run([str(exe), "--version"], capture_output=True, text=True, check=True)
    if version not in got.stdout:
        fail(f"mlayer --version printed {got.stdout!r}")
    sample = str(mlayer.data.sample_path())
    subprocess.run([str(exe), "denoise", sample, "-o", str(out / "clean.bvh")], check=True,
                   capture_output=True, text=True)
    if mlayer.read_bvh(out / "clean.bvh").n_frames != m.n_frames:
        fail("mlayer denoise wrote a wrong clip")

    suitesparse = [p for p in loaded_libraries()
                   if any(k in os.path.basename(p) for k in ("cholmod", "suitesparse"))]
    if suitesparse:
        fail(f"SuiteSparse was loaded: {suitesparse}")
    print(f"smoke: mlayer {version} on Python {sys.version.split()[0]}: import, sample, denoise, "
          f"stylize, write, lgs, CLI --version and denoise; no CHOLMOD, none loaded")


if __name__ == "__main__":
    main()
