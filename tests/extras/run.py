"""The test suite as `pip install 'mlayer[test]'` alone would run it (issue 42, item 4), in an
environment that holds more (the .venv of scripts/setup.sh), without installing anything.

Every top-level module that an installed distribution provides is blocked (site/sitecustomize.py:
importing it raises ModuleNotFoundError, in this process and in every child process) unless its
distribution is in the requirement closure of mlayer[test] and of the build requirements (pip,
setuptools, meson-python, meson, ninja: what a fresh venv and a build from source hold). So the
extras' modules (matplotlib, Pillow, Dask, tqdm, pandas, imageio-ffmpeg, cryptography), the
test-only tools outside `test` (selenium) and whatever else they brought are all missing; a test
that needs one must skip, naming the extra (conftest.py: requires / need), or it fails here.
pytest's plugins installed by other packages are not loaded (PYTEST_DISABLE_PLUGIN_AUTOLOAD).

    python tests/extras/run.py [PYTEST ARGUMENTS]    (default: bindings/python/tests -q)
    python tests/extras/run.py --fast [PYTEST ARGS]  the same less SLOW (scripts/test.sh)
    python tests/extras/run.py --list                the modules it blocks, one a line
"""
from __future__ import annotations

import os
import pathlib
import subprocess
import sys
from importlib import metadata

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = pathlib.Path(__file__).resolve().parents[2]
SITE = pathlib.Path(__file__).resolve().parent / "site"
#: (distribution, extras) the environment of `pip install 'mlayer[test]'` starts from
ROOTS = [("mlayer", {"test"}), ("pip", set()), ("setuptools", set()),
         ("meson-python", set()), ("meson", set()), ("ninja", set())]

#: Left out by --fast (scripts/test.sh, where the whole suite runs with every extra next): the
#: slowest tests, which use no extra's feature (the viewer's network limits, forward kinematics
#: against bvhio, hostile inputs and attributes, golden outputs, the generated walks' skating),
#: about half of the time of this run.
SLOW = ["bindings/python/tests/viewer/test_viewer_limits.py",
        "bindings/python/tests/viewer/test_viewer_slow_clients.py",
        "bindings/python/tests/viewer/test_viewer_fuzz.py",
        "bindings/python/tests/test_public_attributes.py",
        "bindings/python/tests/test_hostile_inputs.py",
        "bindings/python/tests/test_golden.py",
        "bindings/python/tests/manifold/test_markov_dynamics.py",
        "bindings/python/tests/io/test_bvh.py::test_fk_agrees_with_bvhio",
        "bindings/python/tests/manifold/test_generate_guards.py::test_generated_walks_do_not_skate"]


def closure(roots=ROOTS) -> set[str]:
    """The canonical names of the installed distributions that `roots` need, transitively."""
    seen: dict[str, set[str]] = {}
    todo = [(name, set(extras)) for name, extras in roots]
    while todo:
        name, extras = todo.pop()
        key = canonicalize_name(name)
        if key in seen and extras <= seen[key]:
            continue
        seen[key] = seen.get(key, set()) | extras
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
        for line in dist.requires or []:
            req = Requirement(line)
            if req.marker is not None and not any(
                    req.marker.evaluate({"extra": e}) for e in (seen[key] or {""})):
                continue
            todo.append((req.name, set(req.extras)))
    return set(seen)


def blocked() -> list[str]:
    """The top-level modules of installed distributions outside the closure."""
    keep = closure()
    out = []
    for module, dists in metadata.packages_distributions().items():
        if module.isidentifier() and not any(canonicalize_name(d) in keep for d in dists):
            out.append(module)
    return sorted(out)


def main(argv: list[str]) -> int:
    names = blocked()
    if argv[:1] == ["--list"]:
        print("\n".join(names))
        return 0
    if "matplotlib" in names:  # (where it is not installed, there is nothing to show)
        print(f"extras: {len(names)} modules blocked outside mlayer[test], matplotlib among them")
    env = dict(os.environ, MLAYER_TEST_BLOCK=",".join(names), PYTEST_DISABLE_PLUGIN_AUTOLOAD="1")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(SITE), env.get("PYTHONPATH")) if p)
    fast = argv[:1] == ["--fast"]
    args = argv[1:] if fast else argv
    args = args or ["bindings/python/tests", "-q"]
    if fast:
        args += [f"--deselect={t}" if "::" in t else f"--ignore={t}" for t in SLOW]
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *args],
                          cwd=ROOT, env=env).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
