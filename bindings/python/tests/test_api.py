"""The binding covers the whole C API and reports versions."""
import re
import subprocess
import sys

import mlayer
from conftest import REPO


def exported_names():
    names = set()
    for h in (REPO / "include" / "mlayer").glob("*.h"):
        names.update(re.findall(r"MLR_API\s+[^;(]*?\b(mlr_\w+)\s*\(", h.read_text()))
    return names


def test_every_exported_function_is_in_the_cdef():
    cdef = (REPO / "bindings" / "python" / "cffi" / "_mlayer.cdef.h").read_text()
    names = exported_names()
    assert len(names) > 10
    missing = sorted(n for n in names if not re.search(rf"\b{n}\s*\(", cdef))
    assert not missing, f"declared MLR_API but missing from _mlayer.cdef.h: {missing}"


def test_every_exported_function_is_in_the_version_script():
    mapfile = (REPO / "libmlayer" / "mlayer.map").read_text()
    missing = sorted(n for n in exported_names() if not re.search(rf"\b{n};", mapfile))
    assert not missing, f"missing from mlayer.map: {missing}"


def test_versions():
    assert re.fullmatch(r"\d+\.\d+\.\d+", mlayer.library_version())
    assert mlayer.__version__ == mlayer.library_version()


def test_cli_version():
    for argv in (["--version"], ["version"]):
        r = subprocess.run([sys.executable, "-m", "mlayer", *argv], capture_output=True, text=True)
        assert r.returncode == 0
        assert mlayer.__version__ in r.stdout and "C library" in r.stdout


def test_cli_usage_error_exits_2():
    r = subprocess.run([sys.executable, "-m", "mlayer", "no-such-command"], capture_output=True,
                       text=True)
    assert r.returncode == 2
    r = subprocess.run([sys.executable, "-m", "mlayer"], capture_output=True, text=True)
    assert r.returncode == 2


def test_error_hierarchy():
    assert issubclass(mlayer.InvalidArgumentError, ValueError)
    assert issubclass(mlayer.ParseError, mlayer.Error)
    assert issubclass(mlayer.MlayerIOError, OSError)
