"""File lists of the sdist and the wheel against the git tree (tests/release/run.sh).

    python check_dists.py REPO SDIST WHEEL VERSION

sdist: exactly the files of HEAD's tree less those marked export-ignore in .gitattributes, plus
PKG-INFO; the files that build and test the project present; CI wiring, images and results
absent. wheel: tagged abi3; exactly the package's tracked files under bindings/python/mlayer
(every module installed, nothing else), the extension and the dist-info (with LICENSE).
"""
from __future__ import annotations

import re
import subprocess
import sys
import tarfile
import zipfile

REQUIRED_IN_SDIST = ["LICENSE", "CHANGELOG.md", "README.md", "pyproject.toml", "meson.build",
                     "meson_options.txt", "libmlayer/mlayer.map", "tests/meson.build",
                     "tests/abi/check_exports.py", "bindings/python/tests/conftest.py",
                     "bindings/python/mlayer/data/cmu_131_01_mj_style_walk.bvh",
                     "docs/VERSIONING.md"]
#: PEP 561: the marker that tells type checkers the package has inline type hints
REQUIRED_IN_WHEEL = ["mlayer/py.typed"]
FORBIDDEN_IN_SDIST = [".ci/", "docs/img/", "build", ".venv/", "bench/python/plausibility_results"]


def git(repo: str, *args: str, stdin: str | None = None) -> str:
    return subprocess.run(["git", "-C", repo, *args], input=stdin, capture_output=True,
                          text=True, check=True).stdout


def tracked(repo: str) -> list[str]:
    return git(repo, "ls-tree", "-r", "--name-only", "HEAD").splitlines()


def export_ignored(repo: str, files: list[str]) -> set[str]:
    """Files git archive leaves out: marked themselves or through a folder (`/.ci`)."""
    dirs = {"/".join(f.split("/")[:i]) for f in files for i in range(1, f.count("/") + 1)}
    paths = sorted(dirs | set(files))
    out = git(repo, "check-attr", "--stdin", "export-ignore", stdin="\n".join(paths) + "\n")
    marked = {line.split(": export-ignore: ")[0] for line in out.splitlines()
              if line.endswith(": export-ignore: set")}
    return {f for f in files if f in marked or any(f.startswith(d + "/") for d in marked)}


def compare(what: str, got: set[str], want: set[str]) -> list[str]:
    errors = []
    if got - want:
        errors.append(f"{what}: unexpected files: {sorted(got - want)}")
    if want - got:
        errors.append(f"{what}: missing files: {sorted(want - got)}")
    return errors


def main() -> None:
    repo, sdist, wheel, version = sys.argv[1:5]
    errors: list[str] = []
    files = tracked(repo)

    prefix = f"mlayer-{version}/"
    with tarfile.open(sdist) as tf:
        names = [m.name for m in tf.getmembers() if m.isfile()]
    if not all(n.startswith(prefix) for n in names):
        errors.append(f"sdist: members outside {prefix}")
    got = {n[len(prefix):] for n in names}
    want = (set(files) - export_ignored(repo, files)) | {"PKG-INFO"}
    errors += compare("sdist", got, want)
    errors += [f"sdist: {f} missing" for f in REQUIRED_IN_SDIST if f not in got]
    errors += [f"sdist: {n} should not be there" for n in sorted(got)
               if any(n.startswith(p) for p in FORBIDDEN_IN_SDIST)]

    tag = re.fullmatch(rf"mlayer-{re.escape(version)}-(cp3\d+)-abi3-([a-z0-9_]+)\.whl",
                       wheel.rsplit("/", 1)[-1])
    if not tag:
        errors.append(f"wheel: {wheel} is not tagged cp3X-abi3")
    pkg = "bindings/python/"
    dist_info = f"mlayer-{version}.dist-info/"
    with zipfile.ZipFile(wheel) as zf:
        got = set(zf.namelist())
        metadata = zf.read(dist_info + "METADATA").decode()
    want = {f[len(pkg):] for f in files if f.startswith(pkg + "mlayer/")}
    want |= {"mlayer/_mlayer.abi3.so"}
    want |= {dist_info + f for f in ("METADATA", "WHEEL", "RECORD", "entry_points.txt",
                                     "licenses/LICENSE")}
    errors += compare("wheel", got, want)
    errors += [f"wheel: {f} missing" for f in REQUIRED_IN_WHEEL if f not in got]
    for extra in ("plot", "batch", "test", "all"):
        if f"Provides-Extra: {extra}" not in metadata:
            errors.append(f"wheel: no extra {extra!r} in METADATA")
    if errors:
        sys.exit("\n".join(errors))
    print(f"dists: sdist {len(names)} files (HEAD's tree less export-ignore, plus PKG-INFO); "
          f"wheel {tag.group(1)}-abi3-{tag.group(2)}, {len(got)} files (the package, the "
          f"extension, dist-info with LICENSE)")


if __name__ == "__main__":
    main()
